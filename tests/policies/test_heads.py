"""The categorical action head (policies/heads.py): the class set is mirror-closed, the policy is
mirror-equivariant in distribution exactly (MLP and recurrent, over histories), the mode's
tie-break and the per-robot sampling streams are as documented, and bad files are refused by name."""

from __future__ import annotations

import json
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
from tin_swarm_env.policies.heads import (CategoricalHead, categorical_classes, categorical_head, mirror_permutation,
                                          nearest_class, softmax, uniforms)
from tin_swarm_env.policies.recurrent import CELLS

ROOT = Path(__file__).resolve().parents[2]
# the layout these policy files were written for: no terrain scan (59 elements), the default before it
# had the scan; a policy file carries its layout and runs on an env built with it (policy_scenario)
SCEN = {"scenario": load_scenario("cliff_goal").with_layout(ObsLayout(k_scan=0)), "n_robots": 4, "max_cycles": 60}


def _env():
    return tse.parallel_env(**SCEN)


def _layers(d, K, seed, scale=1.0):
    rng = np.random.default_rng(seed)
    return [(rng.normal(0, scale, (16, d)), rng.normal(0, scale, 16)), (rng.normal(0, scale, (K, 16)),
                                                                         rng.normal(0, scale, K))]


def _cell(d, H, seed):
    rng = np.random.default_rng(seed + 7)
    G = CELLS["gru"]
    return {"cell_W_ih": rng.normal(0, 0.5, (G * H, d)), "cell_W_hh": rng.normal(0, 0.5, (G * H, H)),
            "cell_b_ih": rng.normal(0, 0.5, G * H), "cell_b_hh": rng.normal(0, 0.5, G * H)}


def _save(tmp_path, name, recurrent=False, symmetry="mirror", acting="mode", seed=0):
    e = _env()
    K = len(categorical_classes())
    d = e.layout.size
    cell = ("gru", _cell(d, 16, seed)) if recurrent else None
    return save_policy(tmp_path / name, _layers(16 if recurrent else d, K, seed), layout=e.layout,
                       scenario="cliff_goal", symmetry=symmetry, cell=cell,
                       head=categorical_head(acting=acting, seed=seed))


def test_classes_are_mirror_closed_and_ordered_as_documented():
    c = categorical_classes(16, (0.5, 1.0))
    assert c.shape == (33, 2) and np.array_equal(c[0], [0, 0])
    assert np.array_equal(c[1], [0.5, 0.0]) and np.array_equal(c[16], [-0.5, 0.0])
    assert c[2, 1] > 0 and np.array_equal(c[3], c[2] * [1, -1])  # +t before -t, exact mirror
    p = mirror_permutation(c)
    assert np.array_equal(p[p], np.arange(33)) and np.array_equal(c[p], c * [1, -1])
    assert np.allclose(np.hypot(*c[1:17].T), 0.5) and np.allclose(np.hypot(*c[17:].T), 1.0)
    assert len(np.unique(c, axis=0)) == 33
    assert mirror_permutation([[0.0, 0.5], [1.0, 0.0]]) is None
    odd = categorical_classes(5, (1.0,), stop=False)  # no straight back with an odd count
    assert odd.shape == (5, 2) and mirror_permutation(odd) is not None


def test_softmax_permutes_exactly_and_nearest_class():
    rng = np.random.default_rng(1)
    z = rng.normal(0, 3, (200, 33))
    perm = mirror_permutation(categorical_classes())
    assert np.array_equal(softmax(z[:, perm]), softmax(z)[:, perm])  # bit for bit
    assert np.allclose(softmax(z).sum(1), 1.0)
    c = categorical_classes()
    assert np.array_equal(nearest_class(c, c), np.arange(33))
    assert np.array_equal(nearest_class([[0.0, 0.0], [0.9, 0.05], [2.0, 0.0]], c), [0, 17, 17])


@pytest.mark.parametrize("recurrent", [False, True])
def test_mirror_equivariant_in_distribution_exactly(tmp_path, recurrent):
    """logits(M o) == logits(o)[P] bit for bit on random observations (for the recurrent file:
    over a random history of mirrored observations), and so the probabilities."""
    e = _env()
    pol = load_policy(_save(tmp_path, "p", recurrent=recurrent), e)
    twin = load_policy(_save(tmp_path, "p", recurrent=recurrent), e)
    perm = pol.head.perm
    rng = np.random.default_rng(2)
    signs = e.layout.mirror_signs()
    for _ in range(5 if recurrent else 1):
        o = rng.normal(0, 1, (64, e.layout.size))
        if recurrent:
            z, _ = pol.logits(o)
            zm, _ = twin.logits(o * signs)
        else:
            z, zm = pol.logits(o), pol.logits(o * signs)
        assert np.array_equal(zm, z[:, perm])
        assert np.array_equal(softmax(zm), softmax(z)[:, perm])
        assert np.abs(z - z[:, perm]).max() > 1e-3  # the observations are not their own mirror images
    act = pol.act_batch(o) if not recurrent else None
    if act is not None:  # the mode's action of M o is the mirrored action (no exact ties on random data)
        assert np.array_equal(pol.act_batch(o * signs), act * np.array([1, -1], np.float32))


def test_mode_breaks_an_exact_tie_toward_plus_y_and_straight_is_not_the_mode(tmp_path):
    """At an observation that is its own mirror image the two sides' logits are equal; the mode is
    the lower class index, the +y member of the pair (documented), never a mean of the two."""
    e = _env()
    pol = load_policy(_save(tmp_path, "p"), e)
    signs = e.layout.mirror_signs()
    o = np.random.default_rng(3).normal(0, 1, (50, e.layout.size)) * (signs > 0)  # self-mirror
    z = pol.logits(o)
    assert np.array_equal(z, z[:, pol.head.perm])
    k = pol.head.choose(z)
    a = pol.head.actions[k]
    assert np.all(a[:, 1] >= 0)
    mirror_top = pol.head.perm[k]
    assert np.array_equal(z[np.arange(50), mirror_top], z[np.arange(50), k])
    assert np.all(k <= mirror_top)
    h = CategoricalHead(categorical_head())
    zz = np.full((1, 33), -5.0)
    zz[0, [4, 5]] = 2.0  # a +t/-t pair tied
    assert h.choose(zz)[0] == 4 and h.actions[4, 1] > 0


def test_sampling_streams_are_per_robot_reproducible_and_follow_the_probabilities():
    h = CategoricalHead(categorical_head(acting="sample", seed=11))
    z = np.log(np.array([[0.5, 0.3, 0.2] + [1e-300] * 30]))
    z = np.repeat(np.maximum(z, -700), 3, axis=0)
    first = np.stack([h.choose(z, [0, 1, 2]) for _ in range(50)])
    h.reset()
    again = np.stack([h.choose(z[:1], [1]) for _ in range(50)])[:, 0]
    assert np.array_equal(again, first[:, 1])  # row 1's stream, alone or with others
    assert not np.array_equal(first[:, 0], first[:, 1])  # rows draw independently
    h2 = CategoricalHead(categorical_head(acting="sample", seed=12))
    assert not np.array_equal(np.stack([h2.choose(z, [0, 1, 2]) for _ in range(50)]), first)
    h.reset()
    n = 20000
    big = np.repeat(z[:1], n, axis=0)
    k = h.choose(big, np.arange(n))
    freq = np.bincount(k, minlength=33)[:3] / n
    assert np.abs(freq - [0.5, 0.3, 0.2]).max() < 0.015  # 3+ standard errors
    assert k.max() <= 2
    u = uniforms(5, np.arange(100000), np.zeros(100000))
    assert 0 <= u.min() and u.max() < 1 and abs(u.mean() - 0.5) < 0.005


def test_a_sampling_file_draws_both_sides_at_a_tie_and_reset_restarts(tmp_path):
    e = _env()
    pol = load_policy(_save(tmp_path, "s", acting="sample"), e)
    signs = e.layout.mirror_signs()
    o = np.repeat(np.random.default_rng(4).normal(0, 1, (1, e.layout.size)) * (signs > 0), 400, axis=0)
    a = pol.act_batch(o)
    assert (a[:, 1] > 0).sum() > 50 and (a[:, 1] < 0).sum() > 50  # the tie is broken both ways
    pol.reset()
    assert np.array_equal(pol.act_batch(o), a)
    assert not np.array_equal(pol.act_batch(o), a)


def _mutate(tmp_path, fn, **kw):
    p = _save(tmp_path, "bad", **kw)
    meta = json.loads((p / "policy.json").read_text())
    fn(meta)
    (p / "policy.json").write_text(json.dumps(meta))
    return p


BAD = {
    "type": (lambda m: m["head"].update(type="gaussian"), "'head.type'"),
    "actions_not_list": (lambda m: m["head"].update(actions="left"), "'head.actions'"),
    "actions_range": (lambda m: m["head"]["actions"][3].__setitem__(0, 1.5), "outside [-1, 1]"),
    "actions_twice": (lambda m: m["head"]["actions"].__setitem__(1, m["head"]["actions"][0]), "twice"),
    "classes_vs_layer": (lambda m: m["head"]["actions"].pop(), "one logit per class"),
    "acting": (lambda m: m["head"].update(acting="greedy"), "'head.acting'"),
    "seed": (lambda m: m["head"].update(seed=-1), "'head.seed'"),
    "unknown_key": (lambda m: m["head"].update(temperature=2), "unknown keys"),
    "no_head": (lambda m: m.pop("head"), "last layer size 33"),
    "not_mirror_closed": (lambda m: m["head"]["actions"].__setitem__(2, [0.1, 0.05]), "closed under the mirror"),
    "head_not_object": (lambda m: m.update(head=[1]), "key 'head' must be an object"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_head_files_are_refused_by_name(tmp_path, case):
    fn, msg = BAD[case]
    p = _mutate(tmp_path, fn)
    with pytest.raises(PolicyFileError, match="policy.json") as ei:
        load_policy(p, _env())
    assert msg in str(ei.value)


def test_a_mirror_free_file_need_not_be_mirror_closed(tmp_path):
    p = _mutate(tmp_path, lambda m: m["head"]["actions"].__setitem__(2, [0.1, 0.05]), symmetry="none")
    pol = load_policy(p, _env())
    assert pol.head.perm is None and pol.act_batch(np.zeros((2, _env().layout.size))).shape == (2, 2)


def test_side_acting_asks_which_way_before_how_far():
    """Straight on is the single likeliest class (0.4) but a turn to -y is likelier in all (0.45
    over two headings): "side" turns, "mode" does not; mirrored logits give the mirrored class;
    an exact tie between the sides goes to +y."""
    side = CategoricalHead(categorical_head(acting="side"))
    mode = CategoricalHead(categorical_head())
    c, perm = side.actions, side.perm
    p = np.full(33, 1e-6)
    ahead = int(np.flatnonzero((c[:, 0] == 1.0) & (c[:, 1] == 0))[0])
    right = np.flatnonzero((c[:, 1] < 0) & (np.hypot(*c.T) == 1.0))[:2]
    p[ahead], p[right[0]], p[right[1]] = 0.4, 0.2, 0.25
    z = np.log(p / p.sum())[None]
    assert mode.choose(z)[0] == ahead
    k = side.choose(z)[0]
    assert k == right[1] and c[k, 1] < 0
    assert side.choose(z[:, perm])[0] == perm[k]
    zz = np.log(np.full((1, 33), 1e-6))
    zz[0, right[1]] = zz[0, perm[right[1]]] = 0.0
    assert c[side.choose(zz)[0], 1] > 0
    rng = np.random.default_rng(5)
    zr = rng.normal(0, 2, (300, 33))
    assert np.array_equal(side.choose(zr[:, perm]), perm[side.choose(zr)])


def test_the_cli_runs_a_sampling_recurrent_categorical_file_without_torch(tmp_path):
    p = _save(tmp_path, "cat", recurrent=True, acting="sample")
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('torch', 'stable_baselines3', 'sb3_contrib'):\n"
        "            raise ImportError(f'blocked: {name}')\n"
        "sys.meta_path.insert(0, Block())\n"
        "from tin_swarm_env.apps.cli import main\n"
        f"assert main(['eval', 'cliff_goal', '--seeds', '1', '--robots', '4', '--policies', '', '--model', {str(p)!r},"
        f" '--out', {str(tmp_path / 'ev')!r}]) == 0\n"
        "assert not {'torch', 'stable_baselines3', 'sb3_contrib'} & set(sys.modules)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "| cat |" in (tmp_path / "ev.md").read_text()


def test_a_mirror_policy_built_in_memory_refuses_a_head_that_is_not_mirror_closed():
    from tin_swarm_env.errors import ArgumentError
    from tin_swarm_env.policies.learned import MLPPolicy

    e = _env()
    acts = categorical_classes().tolist()
    acts[2] = [0.1, 0.05]
    with pytest.raises(ArgumentError, match="not closed under the mirror"):
        MLPPolicy(_layers(e.layout.size, 33, 0), layout=e.layout.to_dict(), symmetry="mirror",
                  head=categorical_head(acts), source="mem")


def test_a_sampling_mlp_file_draws_per_robot_whoever_else_acts(tmp_path):
    """act() keeps each agent's row: robot_3's draws do not change when robots 0 and 2 have left."""
    e = _env()
    obs = {f"robot_{i}": np.random.default_rng(i).normal(0, 1, e.layout.size).astype(np.float32) for i in range(4)}
    full, part = (load_policy(_save(tmp_path, name, acting="sample"), e) for name in ("a", "b"))
    seq_full = [full.act(obs)["robot_3"] for _ in range(6)]
    part.act(obs)  # every robot seen once (rows fixed), then only robots 1 and 3 act
    seq_part = [seq_full[0]] + [part.act({k: obs[k] for k in ("robot_1", "robot_3")})["robot_3"] for _ in range(5)]
    assert all(np.array_equal(a, b) for a, b in zip(seq_full, seq_part))
    assert len({tuple(a) for a in seq_full}) > 1  # it does sample


@pytest.mark.parametrize("rows", [[0, 0], [-1, 0], [0]])
def test_sampling_rows_must_be_distinct_nonnegative_and_one_per_observation(tmp_path, rows):
    pol = load_policy(_save(tmp_path, "s", acting="sample"), _env())
    with pytest.raises(ArgumentError, match="rows must be 2 distinct robot rows"):
        pol.act_batch(np.zeros((2, pol.obs_size), dtype=np.float32), rows)
