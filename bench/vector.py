"""Vector env throughput: E copies of N robots stepped by one call. Run by hand:

    python bench/vector.py [--steps 20] [--train-seconds 60] [--out docs/figures/vector.md]
    python bench/vector.py --quick      # a smoke run of every path (seconds); prints only
    python bench/vector.py --only generated --sizes 256x16 --raw-only   # one row, the raw env alone (prints only)
    python bench/vector.py --only generated --sizes 16x256 --raw-only --spawn-m 60

The generated mix cannot run 16 x 256: its tasks draw a square spawn region of 22-30 m a side
(``spawn_m``, scenario/generators.py: "about 25-50 robots at 2 m separation"), and 256 robots 2 m apart
do not fit in it (random placement jams near 0.55 of the area covered by 1 m disks: ~85-155 robots;
even a hexagonal packing holds at most ~140-260), so the reset raises a PlacementError and the row
reads "-". ``--spawn-m S`` runs the generated rows on the same mix with every family's spawn region
``S`` m a side (a labelled variant: the robots' density differs from the mix's).

For E x N in (1 024 x 4), (256 x 16), (64 x 64), (16 x 256), on jacksboro and on the generated mix
(a new generated terrain per copy and per reset), in one process: robot-steps per second of the raw
vector env (``tse.vector_env``), the TorchRL env (``make_torchrl_env``), the SB3 VecEnv
(``make_sb3_vec_env``) and the PufferLib env (``make_puffer_env``), each also as a ratio to the
*single-env world rate* at the same total robot count: one ``parallel_env`` with E * N robots on
jacksboro at ``bench/env.py``'s density (about 10 robots within sensor range of each, as
``bench/world.py``'s figures), its world step and sensing alone (``World._step`` + ``World.sense``, no
observations or rewards), measured in the same process. (The vector env's copies carry observations
and rewards too, and their density is their scenario's.) Random actions in [-1, 1]; each path ``--steps`` steps after two warm-up steps,
the best of ``REPEATS`` runs. Then the memory of the vector env's state and buffers at 1 024 x 4, and
what one step allocates per robot at two sizes (numpy allocations, traced: equal per robot at both
sizes means nothing grows with E beyond the state and output arrays).

Then end-to-end training (collection + update, ``--train-seconds`` each) on jacksboro and on the
generated mix, 256 x 16, torch on one thread: SB3 PPO on the SB3 VecEnv and PufferLib's PPO (``pufferl.PuffeRL``)
on the PufferLib env, each with a 64-64 MLP and with the shipped 256-256 network, as robot-steps
(environment samples) per second over the whole run. The PPO settings are throughput settings, not a
recipe: 8 steps per sub-environment per rollout (4 096 sub-environments: 32 768 samples), one epoch,
4 minibatches (SB3); PuffeRL with an 8-step horizon, minibatches of 8 192, one epoch. The table also goes to ``--out`` with the
command and the load average.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
import tracemalloc

import numpy as np

import tin_swarm_env as tse

SIZES = ((1024, 4), (256, 16), (64, 64), (16, 256))
SCENARIOS = ("jacksboro", "generated")
REPEATS = 3
QUICK = {"sizes": ((8, 4),), "steps": 2, "train_seconds": 2.0}


def _best(fn, steps: int, robots: int) -> float:
    """Robot-steps per second of ``fn()`` (one step), the best of REPEATS runs of ``steps``."""
    fn()
    fn()
    best = np.inf
    for _ in range(REPEATS):
        gc.collect()
        t = time.perf_counter()
        for _ in range(steps):
            fn()
        best = min(best, time.perf_counter() - t)
    return robots * steps / best


_WORLD = {}


def world_rate(R, steps):
    """The single-env world rate at R robots: one env of R robots on jacksboro at ``bench/env.py``'s
    density (about 10 robots within sensor range of each, the density ``bench/world.py`` quotes its
    rates at), its world step and sensing alone."""
    if R in _WORLD:
        return _WORLD[R]
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from env import config

    env = tse.parallel_env(config(R), n_robots=R)
    env.reset_arrays(seed=0)
    world, st = env.world, [env.world_state]
    a = np.ascontiguousarray(np.random.default_rng(0).uniform(-1, 1, (R, 2)))

    def step():
        st[0] = world._step(st[0], a)[0]
        world.sense(st[0])

    _WORLD[R] = _best(step, steps, R)
    return _WORLD[R]


def path_rates(scenario, E, N, steps, raw_only: bool = False) -> dict:
    """Robot-steps/s of every path at E x N (``raw_only``: the raw vector env alone)."""
    import torch

    from tin_swarm_env.adapters import make_sb3_vec_env
    from tin_swarm_env.adapters.puffer import make_puffer_env
    from tin_swarm_env.adapters.torchrl import make_torchrl_env

    R = E * N
    a = np.random.default_rng(0).uniform(-1, 1, (E, N, 2))
    out = {}
    v = tse.vector_env(scenario, n_envs=E, n_robots=N, seed=0)
    v.reset()
    out["raw"] = _best(lambda: v.step(a), steps, R)
    if raw_only:
        return out
    te = make_torchrl_env(scenario, n_envs=E, n_robots=N, seed=0)
    td = [te.reset()]
    ta = torch.as_tensor(a, dtype=torch.float32)

    def torch_step():
        td[0].set(("robot", "action"), ta)
        td[0] = te.step(td[0])["next"]

    out["torchrl"] = _best(torch_step, steps, R)
    sb = make_sb3_vec_env(scenario, n_robots=N, n_envs=E, seed=0)
    sb.reset()
    flat = a.reshape(R, 2).astype(np.float32)
    out["sb3"] = _best(lambda: sb.step(flat), steps, R)
    pe = make_puffer_env(scenario, n_envs=E, n_robots=N, seed=0)
    pe.reset()
    out["puffer"] = _best(lambda: pe.step(flat), steps, R)
    return out


def memory(E=1024, N=4) -> tuple[int, float, float]:
    """``(state and buffer bytes at E x N, bytes allocated per robot by one step at E x N, the same at
    E / 4 x N)`` (numpy allocations, traced)."""
    per = []
    for e in (E, max(E // 4, 1)):
        v = tse.vector_env("jacksboro", n_envs=e, n_robots=N, seed=0)
        v.reset()
        a = np.random.default_rng(0).uniform(-1, 1, (e, N, 2))
        v.step(a)
        if e == E:
            arrays = [x for x in vars(v).values() if isinstance(x, np.ndarray)]
            arrays += [x for s in v._slots for x in s] + list(v._rows) + list(v._pack.a.values())
            arrays += list(v._fpack.a.values()) if v._fpack.a is not None else []
            state = sum(x.nbytes for x in arrays)
        tracemalloc.start()
        v.step(a)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        per.append(peak / (e * N))
    return state, per[0], per[1]


class _MLP:
    """A PuffeRL policy: a tanh MLP, a Gaussian head with a learned log-std, a value head."""

    def __new__(cls, d, hidden):
        import torch
        from torch import nn

        class MLP(nn.Module):
            def __init__(self):
                super().__init__()
                layers, w = [], d
                for h in hidden:
                    layers += [nn.Linear(w, h), nn.Tanh()]
                    w = h
                self.body = nn.Sequential(*layers)
                self.mean = nn.Linear(w, 2)
                self.value = nn.Linear(w, 1)
                self.logstd = nn.Parameter(torch.zeros(1, 2))
                self.hidden_size = w

            def forward_eval(self, obs, state=None):
                h = self.body(obs.float())
                mean = self.mean(h)
                return torch.distributions.Normal(mean, self.logstd.exp().expand_as(mean)), self.value(h)

            def forward(self, obs, state=None):
                return self.forward_eval(obs, state)

        return MLP()


def train_rates(seconds: float, E=256, N=16, scenario="generated") -> dict:
    """End-to-end training robot-steps/s on ``scenario``: SB3 PPO and PufferLib's PPO, 64-64 and 256-256."""
    import torch
    from stable_baselines3 import PPO

    from tin_swarm_env.adapters import make_sb3_vec_env
    from tin_swarm_env.adapters.puffer import make_puffer_env, use_cpu_advantage

    torch.set_num_threads(1)
    out = {}
    for hidden in ((64, 64), (256, 256)):
        vec = make_sb3_vec_env(scenario, n_robots=N, n_envs=E, seed=0)
        model = PPO("MlpPolicy", vec, n_steps=8, batch_size=E * N * 8 // 4, n_epochs=1, device="cpu", seed=0,
                    policy_kwargs={"net_arch": list(hidden)})
        chunk = E * N * 8
        t = time.perf_counter()
        while time.perf_counter() - t < seconds:
            model.learn(total_timesteps=chunk, reset_num_timesteps=False)
        out[("sb3", hidden)] = model.num_timesteps / (time.perf_counter() - t)
        vec.close()
        use_cpu_advantage()
        from pufferlib import pufferl

        sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "agents"))
        from train_puffer import Args, config

        pe = make_puffer_env(scenario, n_envs=E, n_robots=N, seed=0)
        pufferl.PuffeRL.print_dashboard = lambda *a, **k: None
        args = Args(n_envs=E, n_robots=N, horizon=8, minibatch_size=E * N * 2, update_epochs=1)
        tr = pufferl.PuffeRL(config(args, pe.num_agents), pe, _MLP(pe.single_observation_space.shape[0], hidden))
        t = time.perf_counter()
        while time.perf_counter() - t < seconds:
            tr.evaluate()
            tr.train()
        out[("puffer", hidden)] = tr.global_step / (time.perf_counter() - t)
        tr.utilization.stop()
    return out


def wide_generated(spawn_m: float):
    """The generated mix with every family's spawn region ``spawn_m`` m a side (``--spawn-m``)."""
    import dataclasses

    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.scenario.generators import ALL_FAMILIES

    cfg = load_scenario("generated")
    ranges = {f: {"spawn_m": [float(spawn_m), float(spawn_m)]} for f in ALL_FAMILIES}
    return cfg.replace(terrain=dataclasses.replace(cfg.terrain, ranges=ranges))


def _row(scenario, E, N, steps, raw_only, spawn_m, emit):
    label = scenario if not (spawn_m and scenario == "generated") else f"generated (spawn_m {spawn_m:g})"
    scen = wide_generated(spawn_m) if label != scenario else scenario
    try:
        r = path_rates(scen, E, N, steps, raw_only)
    except tse.TinSwarmError as exc:  # e.g. a generated terrain's spawn region cannot hold N robots
        emit(f"| {label} | {E} x {N} | – | – | – | – | – | – | – | – |")
        print(f"  {label} {E} x {N}: {exc}", file=sys.stderr)
        return
    if raw_only:
        emit(f"| {label} | {E} x {N} | {r['raw']:.3g} | | | | | | | |")
        return
    w = world_rate(E * N, steps)
    emit(f"| {label} | {E} x {N} | {r['raw']:.3g} | {r['torchrl']:.3g} | {r['sb3']:.3g} | {r['puffer']:.3g} "
         f"| {w:.3g} | {r['raw'] / w:.0%} | {r['torchrl'] / r['raw']:.0%} | {r['sb3'] / r['raw']:.0%} |")


def main(steps: int, train_seconds: float, out: str | None, sizes=SIZES, quick: bool = False,
         scenarios=SCENARIOS, raw_only: bool = False, spawn_m: float | None = None) -> None:
    import numba

    lines = []

    def emit(s=""):
        print(s, flush=True)
        lines.append(s)

    load = os.getloadavg()
    emit(f"Measured with `python bench/vector.py --steps {steps} --train-seconds {train_seconds:g}"
         f"{' --quick' if quick else ''}{' --raw-only' if raw_only else ''}"
         f"{f' --spawn-m {spawn_m:g}' if spawn_m else ''}`, {numba.get_num_threads()} numba threads, load average at the start "
         f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on {os.cpu_count()} cores.")
    emit()
    emit("| scenario | E x N | raw vector env | TorchRL env | SB3 VecEnv | PufferLib env | single-env world rate "
         "| raw / world | TorchRL / raw | SB3 / raw |")
    emit("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for scenario in scenarios:
        for E, N in sizes:
            _row(scenario, E, N, steps, raw_only, spawn_m, emit)
    if raw_only:
        load = os.getloadavg()
        print(f"\nLoad average at the end {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}.")
        return
    state, per_big, per_small = memory(*((8, 4) if quick else (1024, 4)))
    emit()
    emit(f"Memory at {'8' if quick else '1 024'} x 4 on jacksboro: state and buffers {state / 2 ** 20:.1f} MiB "
         f"(the packed terrain held once for every copy); one step allocates {per_big:.0f} bytes per robot (numpy, "
         f"traced), {per_small:.0f} at a quarter of the copies.")
    emit()
    te, tn = (4, 4) if quick else (256, 16)
    emit(f"| training robot-steps/s, {te} x {tn}, {train_seconds:g} s each, torch on 1 thread | 64-64 MLP "
         "| 256-256 MLP |")
    emit("|---|---:|---:|")
    for scenario in SCENARIOS:
        tr = train_rates(train_seconds, te, tn, scenario)
        for lib, name in (("sb3", "SB3 PPO (VecEnv)"), ("puffer", "PufferLib PPO (pufferl)")):
            emit(f"| {scenario}: {name} | {tr[(lib, (64, 64))]:.3g} | {tr[(lib, (256, 256))]:.3g} |")
    load = os.getloadavg()
    emit(f"\nLoad average at the end {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}.")
    if out:
        tmp = f"{out}.part"
        with open(tmp, "w") as fh:
            fh.write("# Vector env throughput\n\n" + "\n".join(lines) + "\n")
        os.replace(tmp, out)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=20, help="steps per timed run")
    p.add_argument("--train-seconds", type=float, default=60.0, help="seconds of each training run")
    p.add_argument("--out", default=None, help="write the table here (Markdown)")
    p.add_argument("--quick", action="store_true", help="a smoke run of every path (seconds); prints only")
    p.add_argument("--only", nargs="+", choices=SCENARIOS, default=SCENARIOS, help="these scenarios only")
    p.add_argument("--sizes", nargs="+", default=None, help="E x N sizes, e.g. 256x16 (default: all four)")
    p.add_argument("--raw-only", action="store_true", help="the raw vector env alone: no adapters, memory or "
                   "training (prints only)")
    p.add_argument("--spawn-m", type=float, default=None, help="generated rows: every family's spawn region this "
                   "many m a side (a labelled variant; the mix's is 22-30 m, too small for 256 robots)")
    a = p.parse_args()
    sizes = SIZES if a.sizes is None else tuple(tuple(int(v) for v in z.lower().split("x")) for z in a.sizes)
    if a.quick:
        main(QUICK["steps"], QUICK["train_seconds"], None, QUICK["sizes"], quick=True, scenarios=tuple(a.only),
             raw_only=a.raw_only, spawn_m=a.spawn_m)
    else:
        main(a.steps, a.train_seconds, None if a.raw_only else a.out, sizes, scenarios=tuple(a.only),
             raw_only=a.raw_only, spawn_m=a.spawn_m)
