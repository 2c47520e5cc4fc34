"""Recurrent policy files (policies/recurrent.py): the numpy cells equal torch's, an exported
RecurrentPPO acts as the torch model over a whole episode, memory is per robot and reset with the
episode, the mirror option is equivariant over histories, bad files are refused by name, and the
CLI runs one on the core install."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.errors import ArgumentError, PolicyFileError
from tin_swarm_env.policies import load_policy, save_policy
from tin_swarm_env.policies.recurrent import CELLS, RecurrentPolicy, cell_step

ROOT = Path(__file__).resolve().parents[2]
# the layout these policy files were written for: no terrain scan (59 elements), the default before it
# had the scan; a policy file carries its layout and runs on an env built with it (policy_scenario)
SCEN = {"scenario": load_scenario("cliff_goal").with_layout(ObsLayout(k_scan=0)), "n_robots": 4, "max_cycles": 80}


def _env(**kw):
    return tse.parallel_env(**{**SCEN, **kw})


def _random_cell(cell, d, H, seed, scale=0.5):
    rng = np.random.default_rng(seed)
    G = CELLS[cell]
    return {"cell_W_ih": rng.normal(0, scale, (G * H, d)), "cell_W_hh": rng.normal(0, scale, (G * H, H)),
            "cell_b_ih": rng.normal(0, scale, G * H), "cell_b_hh": rng.normal(0, scale, G * H)}


def _head(H, seed, scale=2.0):
    rng = np.random.default_rng(seed + 100)
    return [(rng.normal(0, 1, (12, H)), rng.normal(0, 1, 12)), (rng.normal(0, scale, (2, 12)), rng.normal(0, 1, 2))]


def _save(tmp_path, name, cell="lstm", H=8, seed=0, **kw):
    e = _env()
    return save_policy(tmp_path / name, _head(H, seed), layout=e.layout, scenario="cliff_goal",
                       cell=(cell, _random_cell(cell, e.layout.size, H, seed)), **kw)


@pytest.mark.parametrize("cell", sorted(CELLS))
def test_numpy_cells_equal_torch(cell):
    torch = pytest.importorskip("torch")
    torch.set_num_threads(1)
    d, H, n, T = 7, 5, 3, 12
    mod = (torch.nn.LSTM if cell == "lstm" else torch.nn.GRU)(d, H).double()
    w = {"cell_W_ih": mod.weight_ih_l0, "cell_W_hh": mod.weight_hh_l0, "cell_b_ih": mod.bias_ih_l0,
         "cell_b_hh": mod.bias_hh_l0}
    w = {k: v.detach().numpy().copy() for k, v in w.items()}
    x = np.random.default_rng(0).normal(0, 2, (T, n, d))
    with torch.no_grad():
        ref, _ = mod(torch.from_numpy(x))
    h, c = np.zeros((n, H)), np.zeros((n, H))
    for t in range(T):
        h, c = cell_step(cell, w, x[t], h, c)
        np.testing.assert_allclose(h, ref[t].numpy(), atol=1e-12)


@pytest.fixture(scope="module")
def rppo(tmp_path_factory):
    """A tiny RecurrentPPO trained a few hundred steps, its VecEnv and its exported policy."""
    torch = pytest.importorskip("torch")
    pytest.importorskip("sb3_contrib")
    from sb3_contrib import RecurrentPPO

    from tin_swarm_env.adapters.sb3 import export_sb3_policy

    torch.set_num_threads(1)
    vec = tse.adapters.make_sb3_vec_env(SCEN["scenario"], n_robots=4, n_envs=1, seed=0, max_cycles=40)
    model = RecurrentPPO("MlpLstmPolicy", vec, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu",
                         policy_kwargs={"net_arch": [16], "lstm_hidden_size": 12})
    model.learn(256)
    with torch.no_grad():  # outputs large enough that clipping to [-1, 1] is exercised
        model.policy.action_net.weight.mul_(1000.0)
    d = tmp_path_factory.mktemp("rpol") / "rppo"
    export_sb3_policy(model, d, vec, extra={"note": "test"})
    return model, d


def test_exported_recurrent_policy_acts_as_the_torch_model_over_an_episode(rppo):
    from tin_swarm_env.training.scoring import RecurrentSB3Policy

    model, d = rppo
    meta = json.loads((d / "policy.json").read_text())
    assert meta["network"]["type"] == "recurrent" and meta["network"]["cell"] == "lstm"
    assert meta["network"]["hidden_size"] == 12 and meta["network"]["layer_sizes"] == [12, 16, 2]
    assert meta["training"]["algorithm"] == "RecurrentPPO"
    env = _env()
    pol = load_policy(d, env)
    assert isinstance(pol, RecurrentPolicy)
    ref = RecurrentSB3Policy(model)
    memoryless = load_policy(d, env)
    obs = env.reset_arrays(seed=5)
    pol.reset()
    ref.reset()
    steps, clipped, differs = 0, 0, 0.0
    while env.live_mask.any():
        want = ref.act_batch(obs)
        got = pol.act_batch(obs)
        np.testing.assert_allclose(got, want, atol=1e-5, err_msg=f"step {steps}")
        memoryless.reset()  # the same network with its memory wiped every step
        differs = max(differs, float(np.abs(memoryless.act_batch(obs) - got).max()))
        clipped += int(np.sum(np.abs(got) == 1.0))
        obs, *_ = env.step_arrays(want)
        steps += 1
    assert steps == SCEN["max_cycles"] or not env.live_mask.any()
    assert steps >= 20 and clipped and differs > 1e-3  # a whole episode; clipping and memory both exercised
    # a second episode after reset() starts from zero memory again, as the torch model's
    obs = env.reset_arrays(seed=6)
    pol.reset()
    ref.reset()
    for _ in range(5):
        want = ref.act_batch(obs)
        np.testing.assert_allclose(pol.act_batch(obs), want, atol=1e-5)
        obs, *_ = env.step_arrays(want)


def test_memory_is_per_robot_and_new_agents_start_from_zero(tmp_path):
    e = _env()
    pol = load_policy(_save(tmp_path, "p", "gru"), e)
    rng = np.random.default_rng(1)
    seq = rng.uniform(-1, 1, (6, 3, e.layout.size)).astype(np.float32)
    together = [pol.act_batch(seq[t]) for t in range(6)]
    for i in range(3):  # each robot alone, in row 0 of a fresh memory: the same actions
        pol.reset()
        alone = [pol.act_batch(seq[t, i:i + 1]) for t in range(6)]
        np.testing.assert_array_equal(np.concatenate(alone), np.stack(together)[:, i])
    # rows: robot 2 driven through row 7 keeps its own memory
    pol.reset()
    got = [pol.act_batch(seq[t, [2]], rows=[7]) for t in range(6)]
    np.testing.assert_array_equal(np.concatenate(got), np.stack(together)[:, 2])
    # act(): a new agent name gets a fresh memory; known names keep theirs
    pol.reset()
    first = pol.act({"robot_0": seq[0, 0], "robot_1": seq[0, 1]})
    again = pol.act({"robot_0": seq[1, 0], "robot_9": seq[0, 1]})
    np.testing.assert_array_equal(first["robot_1"], again["robot_9"])  # robot_9 is new: as robot_1 at its start
    np.testing.assert_array_equal(again["robot_0"], together[1][0])
    with pytest.raises(ArgumentError, match="rows must be"):
        pol.act_batch(seq[0], rows=[0, 0, 1])


@pytest.mark.parametrize("cell", sorted(CELLS))
def test_mirror_recurrent_policy_is_equivariant_over_histories(tmp_path, cell):
    e = _env()
    lay = e.layout
    p = _save(tmp_path, "m", cell, seed=3, symmetry="mirror")
    a_pol, b_pol = load_policy(p, e), load_policy(p, e)
    assert a_pol.symmetry == "mirror"
    rng = np.random.default_rng(2)
    seq = rng.uniform(-1, 1, (8, 5, lay.size)).astype(np.float32)
    flip = np.array([1.0, -1.0], dtype=np.float32)
    for t in range(8):
        np.testing.assert_array_equal(b_pol.act_batch(lay.mirror(seq[t])), a_pol.act_batch(seq[t]) * flip)
    plain = load_policy(_save(tmp_path, "n", cell, seed=3), e)
    other = load_policy(_save(tmp_path, "n", cell, seed=3), e)
    gap = max(np.abs(other.act_batch(lay.mirror(seq[t])) - plain.act_batch(seq[t]) * flip).max() for t in range(8))
    assert gap > 0.05  # without the option it is not equivariant


def test_mirror_recurrent_policy_with_scan_beams_is_equivariant_over_histories(tmp_path):
    """The mirror of a layout with a terrain scan permutes the beams: the recurrent file's mirror
    stream reads them permuted, equivariant over a whole history bit for bit."""
    import dataclasses

    from tin_swarm_env.scenario import load_scenario

    cfg = load_scenario("cliff_goal")
    e = tse.parallel_env(scenario=cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=6)),
                         n_robots=5)
    lay = e.layout
    H = 8
    p = save_policy(tmp_path / "scan", _head(H, 4), layout=lay, scenario="cliff_goal", symmetry="mirror",
                    cell=("gru", _random_cell("gru", lay.size, H, 4)))
    a_pol, b_pol = load_policy(p, e), load_policy(p, e)
    seq = np.random.default_rng(5).uniform(-1, 1, (8, 5, lay.size)).astype(np.float32)
    flip = np.array([1.0, -1.0], dtype=np.float32)
    for t in range(8):
        np.testing.assert_array_equal(b_pol.act_batch(lay.mirror(seq[t])), a_pol.act_batch(seq[t]) * flip)


def _edit(p, tmp_path, fn_json=None, fn_npz=None):
    q = tmp_path / "edited"
    shutil.copytree(p, q)
    if fn_json:
        meta = json.loads((q / "policy.json").read_text())
        fn_json(meta)
        (q / "policy.json").write_text(json.dumps(meta))
    if fn_npz:
        with np.load(q / "weights.npz") as f:
            arrays = {k: f[k] for k in f.files}
        fn_npz(arrays)
        np.savez(q / "weights.npz", **arrays)
    return q


BAD = {
    "cell": (lambda j: j["network"].update(cell="rnn"), None, r"policy\.json.*'network\.cell' is 'rnn'"),
    "no_cell": (lambda j: j["network"].pop("cell"), None, r"policy\.json.*missing key 'network\.cell'"),
    "no_hidden": (lambda j: j["network"].pop("hidden_size"), None, r"missing key 'network\.hidden_size'"),
    "head_start": (lambda j: j["network"].update(hidden_size=9), None,
                   r"'network\.layer_sizes' must start at hidden_size 9"),
    "input": (lambda j: j["network"].update(input_size=60), None,
              r"policy\.json: key 'observation\.size' \(59\) differs from the cell's 'network\.input_size' \(60\)"),
    "input_both": (lambda j: (j["network"].update(input_size=60), j["observation"].update(size=60)), None,
                   r"weights\.npz.*'cell_W_ih' has shape \(32, 59\)"),
    "type": (lambda j: j["network"].update(type="transformer"), None, r"'network\.type' is 'transformer'"),
    "missing_array": (None, lambda a: a.pop("cell_W_hh"), r"weights\.npz: missing array 'cell_W_hh'"),
    "shape": (None, lambda a: a.update(cell_b_ih=np.zeros(31)), r"weights\.npz: array 'cell_b_ih' has shape \(31,\)"),
    "nan": (None, lambda a: a["cell_W_hh"].__setitem__((0, 0), np.nan), r"'cell_W_hh' holds NaN"),
    "extra": (None, lambda a: a.update(W7=np.zeros(2)), r"unexpected \['W7'\]"),
    "gru_arrays": (lambda j: j["network"].update(cell="gru"), None, r"'cell_W_ih' has shape \(32, 59\).*gru"),
    "huge": (lambda j: j["network"].update(hidden_size=3000, layer_sizes=[3000, 12, 2]), None,
             r"policy\.json.*lstm cell.*'network\.hidden_size' 3000.*beyond the limits"),
    "large_weight": (None, lambda a: a["cell_W_ih"].__setitem__((0, 0), 1e9), r"'cell_W_ih'.*magnitude 1e\+09"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_recurrent_files_are_refused_by_name(tmp_path, case):
    fj, fn, pattern = BAD[case]
    q = _edit(_save(tmp_path, "p"), tmp_path, fj, fn)
    with pytest.raises(PolicyFileError, match=pattern):
        load_policy(q, _env())


def test_a_recurrent_file_for_another_layout_is_refused(tmp_path):
    from tin_swarm_env.scenario import load_scenario

    cfg = load_scenario("cliff_goal")
    import dataclasses

    other = tse.parallel_env(dataclasses.replace(cfg, observation=dataclasses.replace(cfg.observation, k_robots=6)),
                             n_robots=4)
    with pytest.raises(PolicyFileError, match=r"'observation\.layout'.*'k_robots': 4"):
        load_policy(_save(tmp_path, "p"), other)


def test_the_cli_runs_a_recurrent_policy_without_torch(tmp_path):
    p = _save(tmp_path, "rec", "lstm", shield="safety_cut")
    code = (
        "import sys\n"
        "class Block:  # importing torch/SB3 fails (a finder, so scipy's 'torch in sys.modules' checks stay False)\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('torch', 'stable_baselines3', 'sb3_contrib'):\n"
        "            raise ImportError(f'blocked: {name}')\n"
        "sys.meta_path.insert(0, Block())\n"
        "from tin_swarm_env.apps.cli import main\n"
        f"assert main(['run', 'ramp', '--policy', {str(p)!r}, '--robots', '3', '--max-cycles', '15', '--quiet']) == 0\n"
        f"assert main(['eval', 'flat', '--seeds', '1', '--robots', '3', '--policies', 'random', '--model', {str(p)!r},"
        f" '--out', {str(tmp_path / 'ev')!r}]) == 0\n"
        "assert not {'torch', 'stable_baselines3', 'sb3_contrib'} & set(sys.modules)\n"
        "print('ok')\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "rec" in (tmp_path / "ev.md").read_text()


def _save_fb(tmp_path, name, cell="gru", H=8, seed=0, **kw):
    """A recurrent file with ``"feedback": "action"`` (random weights, the cell reading the
    observation and the previous action)."""
    e = _env()
    return save_policy(tmp_path / name, _head(H, seed), layout=e.layout, scenario="cliff_goal",
                       cell=(cell, _random_cell(cell, e.layout.size + 2, H, seed)), feedback="action", **kw)


@pytest.mark.parametrize("cell", sorted(CELLS))
def test_feedback_cell_reads_the_observation_then_the_previous_commanded_action(tmp_path, cell):
    """The file with feedback equals, step by step, the same cell fed ``[o, previous action]`` by
    hand (the previous action being what the policy itself commanded before the shield, zero at
    the first step and after reset); the weights on the feedback columns matter."""
    e = _env()
    lay = e.layout
    p = _save_fb(tmp_path, "fb", cell, seed=4, shield="safety_cut")
    pol = load_policy(p, e)
    meta = json.loads((p / "policy.json").read_text())
    assert meta["network"]["feedback"] == "action" and meta["network"]["input_size"] == lay.size + 2
    assert meta["observation"]["size"] == lay.size and pol.obs_size == lay.size and pol.feedback == "action"
    with np.load(p / "weights.npz") as f:
        w = {k: f[k] for k in f.files}
    layers = [(w[f"W{i}"], w[f"b{i}"]) for i in range(2)]
    ref = RecurrentPolicy(cell, {k: w[k] for k in w if k.startswith("cell_")}, layers,
                          layout=lay.to_dict())  # no feedback: fed [o, prev] by hand
    seq = np.random.default_rng(5).uniform(-1, 1, (2, 10, 5, lay.size))
    for ep in seq:
        pol.reset()
        ref.reset()
        prev = np.zeros((5, 2))
        for o in ep:
            a = pol.net_batch(o)
            b = ref.net_batch(np.concatenate([o, prev], axis=1))
            np.testing.assert_array_equal(a, b)
            prev = b.astype(np.float64)
    blind = load_policy(_edit(p, tmp_path, None, lambda a: a["cell_W_ih"].__setitem__((slice(None), slice(-2, None)),
                                                                                         0.0)), e)
    pol.reset()
    gap = max(np.abs(pol.net_batch(o) - blind.net_batch(o)).max() for o in seq[0])
    assert gap > 1e-3  # the feedback columns are read


@pytest.mark.parametrize("head", ["mean", "categorical"])
def test_feedback_file_is_mirror_equivariant_over_histories(tmp_path, head):
    """With the mirror option, the mirrored stream reads the mirrored previous action: a mirrored
    history gives mirrored actions (and, categorical, permuted logits) at every step, exactly."""
    from tin_swarm_env.policies.heads import categorical_classes, categorical_head

    e = _env()
    lay = e.layout
    kw = {}
    if head == "categorical":
        K = len(categorical_classes())
        rng = np.random.default_rng(9)
        kw = {"head": categorical_head()}
    p = save_policy(tmp_path / "m", _head(8, 3) if head == "mean" else
                    [(rng.normal(0, 1, (12, 8)), rng.normal(0, 1, 12)), (rng.normal(0, 2, (K, 12)),
                                                                         rng.normal(0, 1, K))],
                    layout=lay, scenario="cliff_goal", cell=("gru", _random_cell("gru", lay.size + 2, 8, 3)),
                    feedback="action", symmetry="mirror", **kw)
    a_pol, b_pol = load_policy(p, e), load_policy(p, e)
    seq = np.random.default_rng(2).uniform(-1, 1, (12, 5, lay.size))
    flip = np.array([1.0, -1.0], dtype=np.float32)
    acts = []
    for o in seq:
        if head == "categorical":
            z, _ = a_pol.logits(o)
            zm, _ = b_pol.logits(lay.mirror(o))
            assert np.array_equal(zm, z[:, a_pol.head.perm])
            a, am = a_pol.head.act(z), b_pol.head.act(zm)
            a_pol.remember(a)
            b_pol.remember(am)
        else:
            a, am = a_pol.net_batch(o), b_pol.net_batch(lay.mirror(o))
        np.testing.assert_array_equal(am, a * flip)
        acts.append(a)
    assert len(np.unique(np.concatenate(acts).round(6), axis=0)) > 3  # the actions vary: not a trivial comparison


FEEDBACK_BAD = {
    "unknown": (lambda j: j["network"].update(feedback="sound"), r"policy\.json: key 'network\.feedback' is 'sound'"),
    "sizes": (lambda j: j["network"].update(input_size=59), r"policy\.json: key 'observation\.size' \(59\) differs "
              r"from the cell's 'network\.input_size' less its 'network\.feedback' inputs \(57\)"),
    "too_small": (lambda j: j["network"].update(input_size=2), r"'network\.input_size' is 2; with 'network\.feedback'"),
    "dropped": (lambda j: j["network"].pop("feedback"), r"'observation\.size' \(59\) differs from the cell's "
                r"'network\.input_size' \(61\)"),
    "list": (lambda j: j["network"].update(feedback=["action"]), r"policy\.json: key 'network\.feedback' is "
             r"\['action'\]"),
    "cell_list": (lambda j: j["network"].update(cell=["gru"]), r"policy\.json: key 'network\.cell' is \['gru'\]"),
    "on_an_mlp": (lambda j: [j["network"].update(type="mlp", layer_sizes=[59, 8, 2]), j["network"].pop("cell")],
                  r"policy\.json: key 'network\.feedback' is for a recurrent network"),
}


@pytest.mark.parametrize("case", sorted(FEEDBACK_BAD))
def test_bad_feedback_files_are_refused_by_name(tmp_path, case):
    fj, pattern = FEEDBACK_BAD[case]
    q = _edit(_save_fb(tmp_path, "p"), tmp_path, fj)
    with pytest.raises(PolicyFileError, match=pattern):
        load_policy(q, _env())


def test_save_policy_refuses_feedback_without_a_cell(tmp_path):
    with pytest.raises(ArgumentError, match="feedback='action' needs a memory cell"):
        save_policy(tmp_path / "m", _head(59, 3), layout=_env().layout, scenario="cliff_goal", feedback="action")
    assert not (tmp_path / "m").exists()
