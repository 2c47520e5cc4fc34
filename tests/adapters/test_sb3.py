"""The Stable-Baselines3 adapter: VecEnv contract, seeding, dead robots, and a PPO smoke run."""

import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the train extra: pip install 'tin_swarm_env[train]'")
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import VecEnv  # noqa: E402

import tin_swarm_env as tse  # noqa: E402
from tin_swarm_env.errors import ArgumentError, TinSwarmError  # noqa: E402


def vec(**kw):
    args = {"scenario": "cliff_goal", "n_robots": 4, "n_envs": 2, "seed": 0, "max_cycles": 30}
    args.update(kw)
    return tse.adapters.make_sb3_vec_env(args.pop("scenario"), **args)


def test_vecenv_contract_shapes_dtypes_and_time_limit():
    v = vec()
    assert isinstance(v, VecEnv) and v.num_envs == 8
    obs = v.reset()
    assert obs.shape == (8, 91) and obs.dtype == np.float32
    rng = np.random.default_rng(0)
    for t in range(30):
        obs, rew, done, info = v.step(rng.uniform(-1, 1, (8, 2)).astype(np.float32))
        assert obs.shape == (8, 91) and obs.dtype == np.float32
        assert rew.shape == (8,) and rew.dtype == np.float32 and done.dtype == bool
        assert len(info) == 8
        assert all(v.observation_space.contains(o) for o in obs)
    # step 30 = max_cycles: every live robot ends, truncated, with its last observation
    assert done.all()
    live_end = [i for i in info if "episode" in i]
    assert live_end and all(i["TimeLimit.truncated"] and i["terminal_observation"].shape == (91,) for i in live_end)
    assert all(i["episode"]["l"] == 30 for i in live_end)
    # auto-reset: the observations returned are the new episode's (robots back in the spawn region)
    assert all(env.steps == 0 and env.live_mask.all() for env in v.envs)
    assert not np.any(np.all(obs == 0, axis=1))


def test_fall_is_done_without_time_limit_and_dead_robots_are_frozen():
    v = vec(scenario="ramp", n_robots=2, n_envs=1, max_cycles=60)
    v.reset()
    env = v.envs[0]
    # robot 0 next to the cliff facing east; robot 1 far away, standing still
    obs = env.reset_arrays(seed=0, options={"robot_positions": [[217.0, 120.0], [30.0, 120.0]],
                                            "headings": [0.0, 0.0]})
    act = np.array([[1.0, 0.0], [0.0, 0.0]], np.float32)
    obs, rew, done, info = v.step(act)
    for _ in range(5):
        if done[0]:
            break
        obs, rew, done, info = v.step(act)
    assert done[0] and not done[1]
    assert info[0]["TimeLimit.truncated"] is False and info[0]["reason"] == "fell"
    assert np.any(info[0]["terminal_observation"] != 0)
    assert rew[0] <= env.config.rewards.fall + 5
    # frozen: zero observation, zero reward, not done, until the copy's episode ends
    for _ in range(10):
        obs, rew, done, info = v.step(np.ones((2, 2), np.float32))
        assert np.all(obs[0] == 0) and rew[0] == 0.0 and not done[0]
        assert np.any(obs[1] != 0)


def test_frozen_slot_continues_into_the_next_episode_without_a_second_done():
    v = vec(scenario="ramp", n_robots=2, n_envs=1, max_cycles=12)
    v.reset()
    v.envs[0].reset_arrays(seed=0, options={"robot_positions": [[217.0, 120.0], [30.0, 120.0]],
                                            "headings": [0.0, 0.0]})
    act = np.array([[1.0, 0.0], [0.0, 0.0]], np.float32)
    dones = []
    for t in range(12):
        obs, rew, done, info = v.step(act)
        dones.append(done.copy())
    assert sum(d[0] for d in dones) == 1  # robot 0 fell: its one done, long before the copy ended
    assert not dones[-1][0] and info[0] == {}  # the copy reset: no second done for the frozen slot
    assert dones[-1][1] and info[1]["TimeLimit.truncated"] is True
    assert v.envs[0].steps == 0 and np.any(obs[0] != 0)  # slot 0 continues with the new episode


def toward_target(obs):  # (n, d) -> (n, 2): drive at the assigned target (cliff_goal: over the cliff)
    return np.asarray(obs, np.float32)[..., 7:9].copy()


class TowardTarget:
    """A stand-in SB3 model for evaluate_policy."""

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return toward_target(obs), None


def reference_robot_episodes(n_robots, n_envs, seed, max_cycles, copy_episodes):
    """From plain PettingZoo envs (no adapter): per slot c * n_robots + i, the list of
    (return, live steps, global step at which the robot-episode ended) of robot i of copy c."""
    from tin_swarm_env.env.vector import copy_seed_stream

    out = [[] for _ in range(n_envs * n_robots)]
    for c in range(n_envs):
        env = tse.parallel_env(scenario="cliff_goal", n_robots=n_robots, max_cycles=max_cycles)
        seeds = copy_seed_stream(seed, c)  # the adapter's copy c draws its episodes' seeds from it
        t = 0
        for e in range(copy_episodes):
            obs, _ = env.reset(seed=int(seeds.integers(0, 2 ** 63 - 1)))
            ret = dict.fromkeys(env.possible_agents, 0.0)
            live = dict.fromkeys(env.possible_agents, 0)
            end = {}
            while env.agents:
                obs, rew, term, trunc, _ = env.step({a: toward_target(obs[a]) for a in env.agents})
                t += 1
                for a in rew:
                    ret[a] += float(np.float32(rew[a]))
                    live[a] += 1
                    if term[a] or trunc[a]:
                        end[a] = t
            for i, a in enumerate(env.possible_agents):
                out[c * n_robots + i].append((ret[a], live[a], end[a]))
    return out


def test_vecmonitor_counts_one_episode_per_robot_episode_with_falls():
    from stable_baselines3.common.vec_env import VecMonitor

    n_robots, n_envs, steps = 4, 2, 200
    ref = reference_robot_episodes(n_robots, n_envs, seed=0, max_cycles=90, copy_episodes=4)
    expected = [[e for e in slot if e[2] <= steps] for slot in ref]
    falls = sum(length < 90 for slot in expected for _, length, _ in slot)
    assert falls >= 4  # robots fell before their copy's episode ended: frozen stretches happened
    m = VecMonitor(vec(n_robots=n_robots, n_envs=n_envs, max_cycles=90))
    obs = m.reset()
    seen = [[] for _ in range(m.num_envs)]
    for _ in range(steps):
        obs, rew, done, info = m.step(toward_target(obs))
        for j in np.flatnonzero(done):
            seen[j].append((info[j]["episode"]["r"], info[j]["episode"]["l"]))
    assert m.episode_count == sum(len(s) for s in expected) == sum(len(s) for s in seen)
    for j, (got, want) in enumerate(zip(seen, expected)):
        # returns exact; VecMonitor's length runs from the slot's previous done, frozen stretch included
        assert [r for r, _ in got] == pytest.approx([r for r, _, _ in want], rel=1e-5, abs=1e-4), j
        assert [length for _, length in got] == np.diff([0] + [end for _, _, end in want]).tolist(), j


@pytest.mark.parametrize("monitor", [False, True])
def test_evaluate_policy_n_eval_episodes_counts_robot_episodes(monitor):
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.vec_env import VecMonitor

    n_robots, n_envs = 4, 2
    v = vec(n_robots=n_robots, n_envs=n_envs, max_cycles=90)
    v = VecMonitor(v) if monitor else v
    rets, lens = evaluate_policy(TowardTarget(), v, n_eval_episodes=2 * v.num_envs, return_episode_rewards=True,
                                 warn=False)
    ref = reference_robot_episodes(n_robots, n_envs, seed=0, max_cycles=90, copy_episodes=2)
    # each slot's first two robot-episodes; lengths run from the slot's previous done (frozen stretch included)
    want = sorted((r, int(length)) for slot in ref
                  for r, length in zip([e[0] for e in slot], np.diff([0] + [e[2] for e in slot])))
    got = sorted((float(r), int(n)) for r, n in zip(rets, lens))
    assert len(got) == 16
    assert [r for r, _ in got] == pytest.approx([r for r, _ in want], rel=1e-5, abs=1e-4)
    assert [n for _, n in got] == [n for _, n in want]
    assert sum(length < 90 for slot in ref for _, length, _ in slot) >= 2  # falls among them


def rollout(v, steps, seed):
    rng = np.random.default_rng(seed)
    v.seed(5)
    out = [v.reset()]
    for _ in range(steps):
        o, r, d, _ = v.step(rng.uniform(-1, 1, (v.num_envs, 2)).astype(np.float32))
        out += [o, r[:, None].repeat(o.shape[1], 1), d[:, None].repeat(o.shape[1], 1)]
    return np.concatenate(out)


def test_two_adapters_with_the_same_seed_give_identical_rollouts():
    a = rollout(vec(max_cycles=25), 60, 1)
    b = rollout(vec(max_cycles=25), 60, 1)
    assert a.tobytes() == b.tobytes()
    c = vec(max_cycles=25)
    c.seed(6)
    assert not np.array_equal(c.reset(), vec(max_cycles=25).reset())
    # copies get different seeds
    v = vec()
    o = v.reset()
    assert not np.array_equal(o[:4], o[4:])


def test_ppo_accepts_the_adapter_with_a_seed():
    v = vec(max_cycles=20)
    m = PPO("MlpPolicy", v, n_steps=16, batch_size=32, n_epochs=1, seed=3, device="cpu")
    m.learn(total_timesteps=256)
    assert m.num_timesteps >= 256
    a, _ = m.predict(v.reset(), deterministic=True)
    assert a.shape == (8, 2)


def test_smoke_train_with_imitation_in_a_subprocess_then_load_and_evaluate_the_policy(tmp_path):
    """`tin-swarm train` on the imitation path (BC, one DAgger round, a little PPO) with the
    shield, then the exported pickle-free policies (before and after PPO): loaded with
    load_policy the network acts as the SB3 model it came from and the policy as that model
    through the shield, and `tin-swarm eval --model DIR` runs it beside random and APF."""
    from tin_swarm_env.policies import ShieldedPolicy, load_policy
    from tin_swarm_env.training.policy_factory import SB3Policy

    out = tmp_path / "run"
    r = subprocess.run([sys.executable, "-m", "tin_swarm_env", "train", "flat", "--timesteps", "128",
                        "--bc-episodes", "1", "--dagger-rounds", "1", "--bc-robots", "3", "--bc-epochs", "2",
                        "--n-robots", "4", "--n-envs", "1", "--n-steps", "32", "--batch-size", "64",
                        "--eval-every", "256", "--eval-episodes", "1", "--max-cycles", "30",
                        "--shield", "safety_cut", "--out-dir", str(out), "--progress-bar", "false"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "BC: 90 samples" in r.stdout and "DAgger round 1" in r.stdout and str(out / "policy") in r.stdout
    for f in ("model.zip", "model.json", "eval.csv", "curve.png", "policy/policy.json", "policy/weights.npz",
              "policy_imitation/policy.json", "policy_imitation/weights.npz"):
        assert (out / f).exists(), f
    env = tse.parallel_env(scenario="flat", n_robots=4, max_cycles=30)
    pol = load_policy(out / "policy", env)
    assert pol.shield == "safety_cut" and load_policy(out / "policy_imitation", env).shield == "safety_cut"
    assert load_policy(out / "policy_imitation", env).training["stage"] == "imitation"
    obs = env.reset_arrays(seed=1)
    sb3 = SB3Policy.load(out / "model.zip")  # our own file: trusted
    assert np.allclose(pol.net_batch(obs), sb3.act_batch(obs), atol=1e-5)
    assert np.allclose(pol.act_batch(obs), ShieldedPolicy(sb3, env).act_batch(obs), atol=1e-5)
    ev = tmp_path / "ev"
    r = subprocess.run([sys.executable, "-m", "tin_swarm_env", "eval", "flat", "--seeds", "2", "--robots", "4",
                        "--model", str(out / "policy"), "--out", str(ev)], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    md = (tmp_path / "ev.md").read_text()
    assert "| flat | random |" in md and "| flat | apf |" in md and "| flat | run |" in md
    assert (tmp_path / "ev.csv").exists() and (tmp_path / "ev.png").stat().st_size > 5000
    assert math.isfinite(float(md.split("| flat | run |")[1].split("|")[-2].split("±")[0]))


def test_shielded_vec_env_steps_with_the_shielded_actions():
    """``shield="safety_cut"``: each copy steps with its robots' actions passed through the
    policy-file shield of that copy (same rollouts as an unshielded VecEnv given the cut actions)."""
    from tin_swarm_env.policies.base import SafetyShield

    a, b = (tse.adapters.make_sb3_vec_env("cliff_goal", n_robots=6, n_envs=2, seed=4, max_cycles=40, shield=s)
            for s in ("safety_cut", "none"))
    oa, ob = a.reset(), b.reset()
    rng = np.random.default_rng(0)
    cut_any = False
    for _ in range(30):
        act = rng.uniform(-1, 1, (a.num_envs, 2)).astype(np.float32)
        cut = np.concatenate([SafetyShield(e)(act[c * 6:(c + 1) * 6], ob[c * 6:(c + 1) * 6]) for c, e in enumerate(b.envs)])
        cut_any |= not np.allclose(cut, act)
        oa, ra, da, _ = a.step(act)
        ob, rb, db, _ = b.step(cut)
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(ra, rb)
    assert cut_any
    with pytest.raises(TinSwarmError, match="shield"):
        tse.adapters.make_sb3_vec_env("flat", n_robots=2, shield="bogus")


def test_missing_sb3_names_the_extra(monkeypatch):
    import builtins

    from tin_swarm_env.errors import MissingExtraError

    real = builtins.__import__

    def no_sb3(name, *a, **k):
        if name.startswith("stable_baselines3"):
            raise ImportError("no sb3")
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_sb3)
    with pytest.raises(MissingExtraError, match=r"tin_swarm_env\[train\]"):
        from tin_swarm_env.training.policy_factory import SB3Policy

        SB3Policy.load("x.zip")


def test_adapter_episode_length_counts_the_robot_s_own_steps_and_return_its_own_rewards():
    """info["episode"] of the adapter itself (no VecMonitor, which overwrites it): robot 0 falls
    at step k of a 12-step copy episode, robot 1 runs to the time limit. Robot 0's first episode
    is k long; after the copy resets, its second episode is 12 long (the frozen stretch of the
    first copy episode is not counted in either), and each return is the sum of that robot's
    rewards over its own live steps."""
    v = vec(scenario="ramp", n_robots=2, n_envs=1, max_cycles=12)
    v.reset()
    v.envs[0].reset_arrays(seed=0, options={"robot_positions": [[217.0, 120.0], [30.0, 120.0]],
                                            "headings": [0.0, 0.0]})
    act = np.array([[1.0, 0.0], [0.0, 0.0]], np.float32)
    episodes = {0: [], 1: []}
    ret = np.zeros(2)
    steps = np.zeros(2, int)
    for _ in range(24):  # two copy episodes
        live = v.envs[0].live_mask.copy()
        _, rew, done, info = v.step(act)
        ret += rew
        steps += live
        for j in np.flatnonzero(done):
            episodes[j].append((info[j]["episode"]["l"], info[j]["episode"]["r"], int(steps[j]), ret[j]))
            ret[j], steps[j] = 0.0, 0
    (l0, r0, s0, ret0), (l0b, r0b, s0b, ret0b) = episodes[0]
    assert 1 <= l0 == s0 < 12 and l0b == s0b == 12  # robot 0 fell first, then timed out
    assert [e[0] for e in episodes[1]] == [12, 12]
    assert r0 == pytest.approx(ret0, abs=1e-4) and r0b == pytest.approx(ret0b, abs=1e-4)
    assert r0 < -50  # the fall penalty is in the first return, not the second
    assert r0b > -50


@pytest.mark.parametrize("k_scan", [0, 6])
def test_the_mirror_policy_is_equivariant_and_exports_to_the_same_actions(tmp_path, k_scan):
    """MirrorActorCriticPolicy (train --symmetry mirror): the Gaussian's mean and the value are
    mirror-equivariant / invariant on random observations, log-probabilities of mirrored actions
    are equal, and the exported policy file (``"symmetry": "mirror"``) gives model.predict's
    deterministic actions. With a terrain scan the mirror also permutes the beams (mirror_perm)."""
    import dataclasses

    torch = pytest.importorskip("torch")
    from stable_baselines3 import PPO

    from tin_swarm_env.adapters.sb3 import export_sb3_policy, mirror_policy_class
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.symmetry import mirror_map
    from tin_swarm_env.scenario import load_scenario

    cfg = load_scenario("cliff_goal")
    cfg = cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=k_scan))
    vec = tse.adapters.make_sb3_vec_env(cfg, n_robots=4, n_envs=1, seed=0, max_cycles=30)
    lay = vec.envs[0].layout
    perm, signs = mirror_map(lay)
    model = PPO(mirror_policy_class(), vec, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu",
                policy_kwargs={"net_arch": [16, 16], "mirror_signs": signs.tolist(), "mirror_perm": perm.tolist()})
    model.learn(64)
    with torch.no_grad():
        model.policy.action_net.weight.mul_(300.0)  # outputs beyond [-1, 1]: the clip is exercised
    rng = np.random.default_rng(0)
    o = rng.uniform(-1, 1, (300, lay.size)).astype(np.float32)
    mo = lay.mirror(o)
    pol = model.policy
    with torch.no_grad():
        m, v = pol.mirror_mean_value(torch.as_tensor(o))
        mm, vm = pol.mirror_mean_value(torch.as_tensor(mo))
        a = torch.as_tensor(rng.uniform(-1, 1, (300, 2)).astype(np.float32))
        _, lp, _ = pol.evaluate_actions(torch.as_tensor(o), a)
        _, lpm, _ = pol.evaluate_actions(torch.as_tensor(mo), torch.as_tensor(mirror_action(a.numpy())))
    np.testing.assert_allclose(mm.numpy(), mirror_action(m.numpy()), atol=1e-5)
    np.testing.assert_allclose(vm.numpy(), v.numpy(), atol=1e-5)
    np.testing.assert_allclose(lpm.numpy(), lp.numpy(), rtol=1e-5, atol=1e-4)
    # the plain actor inside is not equivariant (the averaging does the work)
    with torch.no_grad():
        raw = pol.action_net(pol.mlp_extractor.forward_actor(torch.as_tensor(o)))
        raw_m = pol.action_net(pol.mlp_extractor.forward_actor(torch.as_tensor(mo)))
    assert np.abs(raw_m.numpy() - mirror_action(raw.numpy())).max() > 0.1
    d = export_sb3_policy(model, tmp_path / "mirror", vec)
    file_pol = load_policy(d, vec.envs[0])
    assert file_pol.symmetry == "mirror"
    want, _ = model.predict(o, deterministic=True)
    got = file_pol.act_batch(o)
    np.testing.assert_allclose(got, want, atol=1e-5)
    assert np.any(np.abs(got) == 1.0) and np.any(np.abs(got) < 1.0)
    with pytest.raises(TinSwarmError, match=f"mirror_signs of length {lay.size}"):
        PPO(mirror_policy_class(), vec, policy_kwargs={"mirror_signs": [1.0]}, device="cpu")
    with pytest.raises(TinSwarmError, match="mirror_perm must be a permutation"):
        PPO(mirror_policy_class(), vec, policy_kwargs={"mirror_signs": signs.tolist(), "mirror_perm": [0] * lay.size},
            device="cpu")
    # a model mirrored with another map than its layout's is not exported (the file would act unlike it)
    wrong = signs.copy()
    wrong[0] = -wrong[0]
    other = PPO(mirror_policy_class(), vec, n_steps=32, batch_size=64, seed=0, device="cpu",
                policy_kwargs={"net_arch": [16, 16], "mirror_signs": wrong.tolist(), "mirror_perm": perm.tolist()})
    with pytest.raises(TinSwarmError, match="not the mirror map of the layout"):
        export_sb3_policy(other, tmp_path / "wrong", vec)
    assert not (tmp_path / "wrong").exists()


def test_a_scenario_mix_alternates_copies_and_needs_one_robot_count():
    v = tse.adapters.make_sb3_vec_env(["flat", "cliff_goal"], n_robots=3, n_envs=4, seed=0, max_cycles=20)
    assert [e.config.name for e in v.envs] == ["flat", "cliff_goal", "flat", "cliff_goal"]
    assert v.num_envs == 12 and v.reset().shape == (12, v.observation_space.shape[0])
    with pytest.raises(ArgumentError, match="robots"):
        tse.adapters.make_sb3_vec_env(["flat", "hill"], n_envs=2, seed=0)  # 20 and 30 robots
