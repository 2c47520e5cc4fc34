import os

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=60, deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=200, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def random_tin(seed: int, n: int = 30, zscale: float = 50.0):
    """A Delaunay TIN over n random points in a 1000 m square, corners included."""
    from tin_swarm_env.terrain import Tin

    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 1000, (n, 2))
    xy = np.vstack([[[0, 0], [1000, 0], [1000, 1000], [0, 1000]], xy])
    z = rng.uniform(0, zscale, len(xy))
    return Tin.from_points(np.column_stack([xy, z]))


@pytest.fixture(scope="session")
def jacksboro():
    from tin_swarm_env.terrain import sample_dem

    return sample_dem("jacksboro")


ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


@pytest.fixture
def generated_doc():
    """``check(relpath, text)``: a generated documentation file (relative to the repository) must equal
    ``text``; with ``TIN_SWARM_WRITE_DOCS=1`` it is rewritten first. See docs/contributing.md."""

    def check(relpath: str, text: str) -> None:
        path = ROOT / relpath
        if os.environ.get("TIN_SWARM_WRITE_DOCS") == "1":
            path.parent.mkdir(parents=True, exist_ok=True)
            part = path.with_name(f".{path.name}.part")
            part.write_text(text)
            os.replace(part, path)
        old = path.read_text() if path.exists() else None
        assert old == text, (f"{relpath} is stale: regenerate it with TIN_SWARM_WRITE_DOCS=1 and the test "
                             "that failed (see docs/contributing.md)")

    return check
