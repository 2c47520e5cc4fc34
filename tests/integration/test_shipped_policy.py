"""The shipped policy, committed at agents/models/shared (docs/learning.md, "The shipped policy";
agents/reproduce_shared.sh): it loads on the core install (no torch, no pickle), is refused by an env whose
observation layout differs, is exactly mirror-equivariant behind its scan shield (over whole histories: a
residual file over the two-stream APF, which has a memory), and drives robots to the goal on cliff_goal (a
reduced budget of that evaluation); the same for the mirror candidate agents/models/shared_mirror and the
files it replaced, shared_gru_extra, shared_gru and shared_mlp."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.training.policy_factory import policy_scenario
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.errors import PolicyFileError
from tin_swarm_env.policies import load_policy
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT / "agents" / "models" / "shared"


def test_the_shipped_policy_is_small_pickle_free_data():
    files = sorted(p.name for p in SHARED.iterdir())
    assert files == ["policy.json", "weights.npz"]
    assert sum(p.stat().st_size for p in SHARED.iterdir()) < 4 * 2**20
    meta = json.loads((SHARED / "policy.json").read_text())
    assert meta["format"] == "tin_swarm_env.policy" and meta["shield"] == "safety_cut_scan"
    assert meta["symmetry"] == "mirror" and meta["observation"]["layout"]["k_scan"] == 32  # the default layout's scan
    assert meta["network"]["type"] == "mlp" and meta["prior"] == "apf_mirror"  # a correction to the equivariant APF
    with np.load(SHARED / "weights.npz", allow_pickle=False) as w:  # raises on any object array
        assert all(w[k].dtype.kind == "f" and np.isfinite(w[k]).all() for k in w.files)


def test_the_shipped_policy_runs_without_torch_or_pickle():
    code = (
        "import sys, pickle\n"
        "for m in ('torch', 'stable_baselines3'): sys.modules[m] = None  # importing them now fails\n"
        "import tin_swarm_env as tse\n"
        "from tin_swarm_env.policies import load_policy\n"
        "from tin_swarm_env.training.policy_factory import policy_scenario\n"
        f"env = tse.parallel_env(scenario=policy_scenario('ramp', {str(SHARED)!r}), n_robots=3)\n"
        "obs, _ = env.reset(seed=0)\n"
        "import numpy as np\n"
        "from tin_swarm_env.policies.learned import dense\n"
        "dense(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros(1))  # numba's compile cache is read with pickle\n"
        "from tin_swarm_env.policies.base import make_shield\n"
        "make_shield('safety_cut_scan', env)(np.zeros((3, 2)), np.stack(list(obs.values())))  # so are the shield's\n"
        "from tin_swarm_env.policies import APFPolicy\n"
        "APFPolicy(env).act_batch(np.stack(list(obs.values())))  # and APF's (the file's prior)\n"
        "def no(*a, **k): raise AssertionError('pickle used')\n"
        "pickle.load = pickle.loads = no  # from here on: loading the policy file and acting\n"
        f"pol = load_policy({str(SHARED)!r}, env)\n"
        "acts = pol.act(obs)\n"
        "print(sorted(acts), [a.shape for a in acts.values()])\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert "['robot_0', 'robot_1', 'robot_2'] [(2,), (2,), (2,)]" in r.stdout


def test_the_shipped_policy_is_refused_by_another_layout(env_with_k_robots):
    with pytest.raises(PolicyFileError, match=r"shared.*policy\.json.*layout.*'k_robots': 6"):
        load_policy(SHARED, env_with_k_robots(6))


def test_the_shipped_policy_brings_robots_in_on_cliff_goal():
    env = tse.parallel_env(scenario=policy_scenario("cliff_goal", str(SHARED)), n_robots=6)  # its layout
    out = rollout(env, load_policy(SHARED, env), seed=EVAL_SEED0)
    assert out.count(Reason.FELL) == 0
    assert out.count(Reason.ARRIVED) >= 5, out.counts()


def test_cli_runs_and_evaluates_the_shipped_policy(tmp_path):
    from tin_swarm_env.apps.cli import main

    assert main(["run", "ramp", "--policy", str(SHARED), "--robots", "3", "--max-cycles", "20", "--quiet"]) == 0
    out = tmp_path / "ev"
    assert main(["eval", "flat", "--seeds", "1", "--robots", "3", "--policies", "apf", "--model", str(SHARED),
                 "--out", str(out)]) == 0
    assert "shared" in out.with_suffix(".md").read_text()


@pytest.mark.parametrize("name,shield", [("shared", "safety_cut_scan"), ("shared_gru_extra", "safety_cut_scan"),
                                         ("shared_gru", "safety_cut_scan"),
                                         ("shared_mirror", "safety_cut"), ("shared_mlp", "safety_cut_scan")])
def test_the_mirror_policy_files_are_pickle_free_equivariant_and_bring_robots_in(name, shield):
    """agents/models/shared (the shipped policy, a residual over the two-stream APF), shared_gru_extra (the
    recurrent file it replaced), shared_gru (the recurrent file before that, trained without the bay and rough
    families), shared_mlp (the feed-forward file before that) and shared_mirror (docs/figures/shared_mirror.md): small pickle-free data, mirror-equivariant files behind
    their shields (the action on the mirror image of any observation history is the mirror image of the
    action), and they drive robots in on cliff_goal."""
    from tin_swarm_env.env.observation import mirror_action

    d = ROOT / "agents" / "models" / name
    assert sorted(p.name for p in d.iterdir()) == ["policy.json", "weights.npz"]
    meta = json.loads((d / "policy.json").read_text())
    assert meta["symmetry"] == "mirror" and meta["shield"] == shield
    env = tse.parallel_env(scenario=policy_scenario("cliff_goal", str(d)), n_robots=6)
    pol, twin = load_policy(d, env), load_policy(d, env)  # twin sees the mirror images (a recurrent file: its own
    # state, so the check holds over whole histories, not only one step)
    o = np.random.default_rng(0).uniform(-1, 1, (12, 200, env.layout.size))  # 12 steps of 200 robots
    for t in range(len(o)):
        np.testing.assert_allclose(twin.act_batch(env.layout.mirror(o[t])), mirror_action(pol.act_batch(o[t])),
                                   atol=1e-9, err_msg=f"step {t}")
    pol.reset()
    out = rollout(env, pol, seed=EVAL_SEED0)
    assert out.count(Reason.FELL) == 0
    assert out.count(Reason.ARRIVED) >= 5, out.counts()
