"""Shared fixtures and helpers of the test suite (test files never import each other)."""

import importlib.util
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis.configuration import set_hypothesis_home_dir

settings.register_profile(
    "ci", max_examples=60, deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=200, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
# hypothesis keeps caches (e.g. its character tables) in ./.hypothesis: keep them out of the repository
set_hypothesis_home_dir(Path(tempfile.gettempdir()) / "tin_swarm_env_hypothesis")


def _random_tin(seed: int, n: int = 30, zscale: float = 50.0):
    """A Delaunay TIN over n random points in a 1000 m square, corners included."""
    from tin_swarm_env.terrain import Tin

    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 1000, (n, 2))
    xy = np.vstack([[[0, 0], [1000, 0], [1000, 1000], [0, 1000]], xy])
    z = rng.uniform(0, zscale, len(xy))
    return Tin.from_points(np.column_stack([xy, z]))


@pytest.fixture(scope="session")
def random_tin():
    """``random_tin(seed, n=30, zscale=50.0)``: a Delaunay TIN over n random points in a 1000 m square."""
    return _random_tin


def _random_rays(tin, rng, n, height=(0.0, 30.0)):
    x0, y0, x1, y1 = tin.bounds
    a = rng.uniform([x0, y0], [x1, y1], (n, 2))
    b = rng.uniform([x0, y0], [x1, y1], (n, 2))
    ha = tin.height_at(a) + rng.uniform(*height, n)
    hb = tin.height_at(b) + rng.uniform(*height, n)
    return np.column_stack([a, ha]), np.column_stack([b, hb])


@pytest.fixture(scope="session")
def random_rays():
    """``random_rays(tin, rng, n, height=(0.0, 30.0))``: n random (a, b) end points inside the TIN's bounds,
    each ``height`` metres above the ground (uniform)."""
    return _random_rays


def _disc_obstacles(tin, rng, n_discs):
    """Impassable: triangles touching one of ``n_discs`` random discs (radius 60-180 m)."""
    c = rng.uniform(150, 850, (n_discs, 2))
    r = rng.uniform(60, 180, n_discs)
    pts = tin.vertices[tin.triangles, :2]  # (T, 3, 2)
    cen = pts.mean(axis=1, keepdims=True)
    probe = np.concatenate([pts, cen], axis=1)  # (T, 4, 2)
    d = np.linalg.norm(probe[:, :, None, :] - c[None, None], axis=-1)  # (T, 4, n)
    return ~(d < r).any(axis=(1, 2))


@pytest.fixture(scope="session")
def disc_obstacles():
    """``disc_obstacles(tin, rng, n_discs)``: the passable mask with triangles touching random discs removed."""
    return _disc_obstacles


def _obstacle_case(random_tin, seed, n=40, n_discs=3):
    """A random TIN (``random_tin(seed, n)``), discs of impassable triangles, a goal on a passable one:
    ``(tin, passable, goal, rng)``."""
    tin = random_tin(seed, n)
    rng = np.random.default_rng(seed)
    passable = _disc_obstacles(tin, rng, n_discs)
    ok = np.flatnonzero(passable)
    t = int(rng.choice(ok)) if len(ok) else 0
    goal = rng.dirichlet(np.ones(3)) @ tin.vertices[tin.triangles[t], :2]
    return tin, passable, goal, rng


@pytest.fixture(scope="session")
def obstacle_case():
    """``obstacle_case(random_tin, seed, n=40, n_discs=3)``: ``(tin, passable, goal, rng)`` on a random TIN."""
    return _obstacle_case


@pytest.fixture(scope="session")
def jacksboro():
    from tin_swarm_env.terrain import sample_dem

    return sample_dem("jacksboro")


def _cliff_tin(width=0.5, top=100.0):
    """Plateau at `top` m for x <= 100, a cliff face one triangle pair wide (x 100..100+width),
    floor at 0 m up to x = 200; y in [0, 100]."""
    from tin_swarm_env.terrain import Tin

    xs = [0.0, 100.0, 100.0 + width, 200.0]
    zs = [top, top, 0.0, 0.0]
    return Tin.from_points(np.array([(x, y, z) for x, z in zip(xs, zs) for y in (0.0, 100.0)]))


@pytest.fixture(scope="session")
def cliff_tin():
    """``cliff_tin(width=0.5, top=100.0)``: a plateau (x <= 100), a cliff face ``width`` m wide, a floor to x = 200."""
    return _cliff_tin


def _world_params(**kw):
    from tin_swarm_env.world import BatteryParams, RobotParams, SensorParams, WorldParams

    robot = RobotParams(**kw.pop("robot", {}))
    sensor = SensorParams(**kw.pop("sensor", {}))
    battery = BatteryParams(**kw.pop("battery", {}))
    return WorldParams(robot=robot, sensor=sensor, battery=battery, **kw)


@pytest.fixture(scope="session")
def world_params():
    """``world_params(robot={...}, sensor={...}, battery={...}, **world_keys)``: a WorldParams from plain dicts."""
    return _world_params


def _load_helper(name: str):
    """Import the helper module tests/helpers/<name>.py by its path (the suite runs in importlib mode, so
    tests/ is not on sys.path; test files get helpers through the fixtures below, never by import)."""
    path = Path(__file__).parent / "helpers" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_tin_swarm_tests_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


canyons = _load_helper("canyons")


@pytest.fixture(scope="session")
def canyon_config():
    """``canyon_config(side, travel, trench=False, robots=20, max_cycles=1500)``: one canyon variant's scenario."""
    return canyons.canyon_config


@pytest.fixture(scope="session")
def pass_band():
    """``pass_band(side, travel)``: the canyon pass's (y0, y1) band."""
    return canyons.pass_band


@pytest.fixture(params=canyons.VARIANTS, ids=[f"{s}-{t}" for s, t in canyons.VARIANTS])
def canyon_variant(request):
    """(side, travel) of each of the four canyon variants."""
    return request.param


def _repo_script(relpath: str):
    """Import a repository script (``research/diag_fit.py``, ...) by its path, once per session; its
    own folder goes on sys.path (scripts there import each other)."""
    path = Path(__file__).resolve().parents[1] / relpath
    name = "_tin_swarm_script_" + relpath.replace("/", "_").removesuffix(".py")
    if name not in sys.modules:
        if str(path.parent) not in sys.path:
            sys.path.insert(0, str(path.parent))
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]  # not half-imported for the next test
            raise
    return sys.modules[name]


@pytest.fixture(scope="session")
def repo_script():
    """``repo_script(relpath)``: the repository script at ``relpath`` imported as a module."""
    return _repo_script


@pytest.fixture(scope="session")
def repo_root():
    """The repository root (read only: tests write under tmp_path)."""
    return Path(__file__).resolve().parents[1]


@pytest.fixture
def generated_doc():
    """``check(relpath, text)``: a generated documentation file (relative to the repository) must equal
    ``text``; with ``TIN_SWARM_WRITE_DOCS=1`` it is rewritten first. See docs/contributing.md."""

    def check(relpath: str, text: str) -> None:
        path = Path(__file__).resolve().parents[1] / relpath
        if os.environ.get("TIN_SWARM_WRITE_DOCS") == "1":
            path.parent.mkdir(parents=True, exist_ok=True)
            part = path.with_name(f".{path.name}.part")
            part.write_text(text)
            os.replace(part, path)
        old = path.read_text() if path.exists() else None
        assert old == text, (f"{relpath} is stale: regenerate it with TIN_SWARM_WRITE_DOCS=1 and the test "
                             "that failed (see docs/contributing.md)")

    return check


@pytest.fixture(scope="session")
def env_with_k_robots():
    """``env_with_k_robots(k, n_robots=4)``: the cliff_goal env with ``k`` robot slots in its observation."""
    import dataclasses

    import tin_swarm_env as tse
    from tin_swarm_env.scenario import load_scenario

    def make(k: int, n_robots: int = 4):
        cfg = load_scenario("cliff_goal")
        return tse.parallel_env(scenario=cfg.replace(observation=dataclasses.replace(cfg.observation, k_robots=k)),
                                n_robots=n_robots)

    return make


def _obs_row(layout, R, target_xy, breaks=(), robots=(), speed=1.0):
    """One hand-built observation row (body frame): target at ``target_xy`` m; breaks as
    (closest x, y, normal x, y, drop_m); robots as (x, y)."""
    o = np.zeros(layout.size)
    own = layout.own
    d = np.hypot(*target_xy)
    o[own["speed"]] = speed
    o[own["target_valid"]] = 1
    o[own["target_dir"]] = np.asarray(target_xy) / d
    o[own["target_dist"]] = d / (d + R)
    b = layout.breaks.start
    for k, (x, y, nx, ny, drop) in enumerate(breaks):
        o[b + 8 * k: b + 8 * k + 8] = [1, x / R, y / R, nx, ny, drop / (abs(drop) + 10), np.hypot(x, y) / R, 1]
    r = layout.robots.start
    for k, (x, y) in enumerate(robots):
        o[r + 4 * k: r + 4 * k + 4] = [1, x / R, y / R, np.hypot(x, y) / R]
    return o[None]


@pytest.fixture(scope="session")
def obs_row():
    """``obs_row(layout, R, target_xy, breaks=(), robots=(), speed=1.0)``: one hand-built body-frame observation row."""
    return _obs_row


def _observations_match(env):
    """The env's compiled observations of its current state, checked equal (to float32 rounding)
    to the numpy reference (env/reference.py); returns them."""
    from tin_swarm_env.env.observation import build_observations
    from tin_swarm_env.env.reference import build_observations_reference

    args = (env.world, env.world_state, env.sensed(), env.target_assignment, env.live_mask, env.layout)
    a, b = build_observations(*args), build_observations_reference(*args)
    assert a.dtype == b.dtype == np.float32
    np.testing.assert_allclose(a, b, atol=2e-7)
    return a


@pytest.fixture(scope="session")
def observations_match():
    """:func:`_observations_match`: compiled observations against the reference, one step's worth."""
    return _observations_match
