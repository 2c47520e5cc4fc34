"""PPO with PufferLib (``pufferlib.pufferl.PuffeRL``) on the vector env, to a wall-clock budget.

    python agents/train_puffer.py --scenario agents/scenarios/train_generated.toml --max-minutes 30

Every robot of every copy is one PufferLib agent of one native ``PufferEnv``
(:mod:`tin_swarm_env.adapters.puffer`: ``n_envs * n_robots`` agents stepped by one call). The
policy is PufferLib's ``models.Default`` with a deeper encoder (:class:`TanhMLP`: two tanh layers
of ``--hidden`` units; the value head shares them, a Gaussian head with a learned log-std), trained
by PuffeRL's PPO from scratch, behind the safety shield (``--shield``) and with the rewards scaled
(``--reward-scale``: PuffeRL clips rewards to ``[-1, 1]``). Each epoch prints the steps per second
and the shares of the robots that ended (arrived, fell, battery, timed out); ``progress.csv`` keeps
them. Then the actor's deterministic action (its mean, clipped to the action box, as PuffeRL clips
its samples) is exported pickle-free to ``OUT_DIR/policy`` and checked against torch on real
observations; the torch weights go to ``OUT_DIR/model.pt`` (a state dict). The default scenario is
the recipes' training mix: the held-out families and maps of the standard suite stay out. Needs the
``[puffer]`` extra (``pufferlib-core``).

``--cell gru``: a memory (:class:`MirrorGRU`): a GRU reads the observation and the two heads (the
Gaussian's mean, the value) read its state; with ``--symmetry mirror`` two streams (the observations
and their mirror images) go through it, equivariant over whole histories. PuffeRL starts every
robot's state at zero at each epoch's first step and replays the epoch's ``--horizon`` steps from zero
in its update, so the memory it trains spans ``--horizon`` steps; the exported recurrent file
(:mod:`tin_swarm_env.policies.recurrent`) starts at zero at each episode and runs over all of it.
"""

from __future__ import annotations

import csv
import json
import time
from collections import defaultdict
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from tin_swarm_env.apps.args import opt, parse_dataclass
from tin_swarm_env.policies.network import SHIELDS
from tin_swarm_env.training.config import scenarios_of


@dataclass
class Args:
    scenario: str = opt("agents/scenarios/train_generated.toml", "scenario names or TOML files, comma-separated: "
                        "the copies take them in turn (default: the training families only)")
    n_envs: int = opt(64, "copies of the swarm stepped by one call", lo=1)
    n_robots: int = opt(16, "robots per copy", lo=1)
    max_cycles: int = opt(0, "steps per episode (0: the scenario's)", lo=0)
    hidden: int = opt(128, "units of each of the two tanh layers", lo=1)
    shield: str = opt("safety_cut", "the safety shield the actor acts behind (and its exported file)",
                      choices=SHIELDS)
    export_shield: str = opt("", "the exported file's shield, if not --shield's (a file trained behind safety_cut "
                             "deployed behind safety_cut_scan)", choices=("",) + SHIELDS)
    symmetry: str = opt("none", "mirror: the actor and critic mirror-equivariant by construction (TanhMLP, MirrorGRU)",
                        choices=("none", "mirror"))
    cell: str = opt("none", "gru: a memory cell before the heads (MirrorGRU; its memory spans --horizon steps in "
                    "training, the whole episode in the exported file)", choices=("none", "gru"))
    prior: str = opt("none", "apf: a residual policy, its actions added to the default APF's commands (before the "
                     "clip and the shield; the exported file's \"prior\"); apf_mirror: to the mirror-equivariant "
                     "APF of two streams (tin_swarm_env/policies/residual.py)", choices=("none", "apf", "apf_mirror"))
    critic_warmup_minutes: float = opt(0.0, "the actor's own head (the mean's last layer, the log-std) stays as it "
                                       "starts for this long while the critic learns (the shared encoder learns "
                                       "too, so the mean moves a little: a residual stays near its prior until the "
                                       "values are fitted)", lo=0)
    init_logstd: float = opt(0.0, "the Gaussian's log-std at the start (a residual starts near its prior: -1.6 "
                             "is a std of 0.2)")
    reward_scale: float = opt(0.01, "rewards are multiplied by this (PuffeRL clips them to [-1, 1]: a fall is -1)",
                              lo=0, lo_open=True)
    horizon: int = opt(64, "steps collected per agent per epoch (PuffeRL's bptt_horizon)", lo=2)
    minibatch_size: int = opt(8192, "samples per PPO minibatch", lo=1)
    update_epochs: int = opt(2, "PPO passes over each batch", lo=1)
    lr: float = opt(3e-4, "Adam learning rate", lo=0, lo_open=True)
    gamma: float = opt(0.99, "discount", lo=0, hi=1)
    max_minutes: float = opt(30.0, "wall-clock budget", lo=0, lo_open=True)
    max_steps: int = opt(10**9, "agent steps at most", lo=1)
    seed: int = opt(0, "seed of the copies' seed streams and of torch", lo=0)
    torch_threads: int = opt(1, "torch threads (1: the env gets the other core)", lo=1)
    snapshot_minutes: float = opt(5.0, "write the actor to OUT_DIR/snapshots/mMMM every this many minutes (its "
                                  "learning curve: agents/plot_curves.py)", lo=0, lo_open=True)
    out_dir: str = opt("runs/ppo_puffer", "run directory: progress.csv, model.pt, run.json, policy/")


def config(args: Args, total_agents: int) -> dict:
    """PuffeRL's configuration (its ``default.ini`` keys), with the recipe's numbers."""
    batch = total_agents * args.horizon
    mb = min(args.minibatch_size, batch) // args.horizon * args.horizon
    return {"seed": args.seed, "torch_deterministic": True, "device": "cpu", "cpu_offload": False, "compile": False,
            "compile_mode": "default", "compile_fullgraph": False, "precision": "float32",
            "use_rnn": args.cell != "none",
            "batch_size": batch, "bptt_horizon": args.horizon, "minibatch_size": mb, "max_minibatch_size": mb,
            "update_epochs": args.update_epochs, "total_timesteps": args.max_steps, "optimizer": "adam",
            "learning_rate": args.lr, "adam_beta1": 0.9, "adam_beta2": 0.999, "adam_eps": 1e-8, "anneal_lr": False,
            "gamma": args.gamma, "gae_lambda": 0.95, "clip_coef": 0.2, "vf_coef": 0.5, "vf_clip_coef": 0.2,
            "ent_coef": 0.0, "max_grad_norm": 0.5, "prio_alpha": 0.0, "prio_beta0": 1.0, "vtrace_c_clip": 1.0,
            "vtrace_rho_clip": 1.0, "checkpoint_interval": 10**9, "data_dir": "/tmp/puffer_unused", "env": "tin_swarm"}


def tanh_mlp_class():
    """:class:`TanhMLP`, made on first use (it derives from PufferLib's ``models.Default``)."""
    import torch
    from pufferlib import models, pytorch

    from tin_swarm_env.env.observation import ACTION_PARITY

    class TanhMLP(models.Default):
        """PufferLib's ``Default`` with a two-layer tanh encoder (the policy file's ``tanh`` MLP).
        ``mirror``: ``(perm, signs)`` of :func:`~tin_swarm_env.policies.symmetry.mirror_map`: the
        Gaussian's mean is ``(g(o) + M g(M o)) / 2`` and the value ``(v(o) + v(M o)) / 2``, as SB3's
        ``MirrorActorCriticPolicy``: mirror-equivariant by construction, the policy file's
        ``"symmetry": "mirror"`` with the same weights."""

        def __init__(self, env, hidden_size=128, mirror=None):
            super().__init__(env, hidden_size=hidden_size)
            n_obs = int(np.prod(env.single_observation_space.shape))
            self.encoder = torch.nn.Sequential(pytorch.layer_init(torch.nn.Linear(n_obs, hidden_size)), torch.nn.Tanh(),
                                               pytorch.layer_init(torch.nn.Linear(hidden_size, hidden_size)),
                                               torch.nn.Tanh())
            self.mirrored = mirror is not None
            if self.mirrored:
                self.register_buffer("_perm", torch.as_tensor(np.array(mirror[0]), dtype=torch.long))
                self.register_buffer("_signs", torch.as_tensor(np.array(mirror[1]), dtype=torch.float32))
                self.register_buffer("_parity", torch.as_tensor(ACTION_PARITY, dtype=torch.float32))

        def mean(self, x):
            """The deterministic action before its clip, ``(n, 2)``, from observations ``(n, d)``."""
            return self.forward_eval(x)[0].loc

        def forward_eval(self, observations, state=None):
            if not self.mirrored:
                return super().forward_eval(observations, state)
            x = observations.view(observations.shape[0], -1).float()
            n = x.shape[0]
            h = self.encoder(torch.cat([x, x[:, self._perm] * self._signs]))
            mean, value = self.decoder_mean(h), self.value(h)
            mean = (mean[:n] + mean[n:] * self._parity) / 2
            std = torch.exp(self.decoder_logstd.expand_as(mean))
            return torch.distributions.Normal(mean, std), (value[:n] + value[n:]) / 2

    return TanhMLP


def mirror_gru_class():
    """:class:`MirrorGRU`, made on first use (torch)."""
    import torch
    from torch import nn

    from tin_swarm_env.env.observation import ACTION_PARITY

    class MirrorGRU(nn.Module):
        """A GRU on the observation, then a tanh head for the Gaussian's mean and one for the value
        (the recurrent policy file's network: :mod:`tin_swarm_env.policies.recurrent`, cell ``"gru"``).
        ``mirror`` (``(perm, signs)``): two streams through the same GRU, one fed the observations and
        one their mirror images; the mean is ``(g(h) + M g(h_m)) / 2``, the value ``(v(h) + v(h_m)) / 2``
        (the file's ``"symmetry": "mirror"``). PuffeRL keeps the state (its ``lstm_h``, ``hidden_size``
        wide: both streams side by side; its ``lstm_c`` is unused) over one epoch's ``bptt_horizon`` steps,
        from zero, and :meth:`forward` replays those steps from zero: memory spans the horizon in training."""

        is_continuous = True

        def __init__(self, env, hidden_size=128, mirror=None):
            super().__init__()
            d = int(np.prod(env.single_observation_space.shape))
            self.H, self.mirrored = hidden_size, mirror is not None
            self.hidden_size = hidden_size * (2 if self.mirrored else 1)
            self.gru = nn.GRU(d, hidden_size)
            self.cell = nn.GRUCell(d, hidden_size)  # the same weights, one step at a time
            self.cell.weight_ih, self.cell.weight_hh = self.gru.weight_ih_l0, self.gru.weight_hh_l0
            self.cell.bias_ih, self.cell.bias_hh = self.gru.bias_ih_l0, self.gru.bias_hh_l0
            self.actor = nn.Sequential(nn.Linear(hidden_size, hidden_size), nn.Tanh(), nn.Linear(hidden_size, 2))
            self.value = nn.Sequential(nn.Linear(hidden_size, hidden_size), nn.Tanh(), nn.Linear(hidden_size, 1))
            nn.init.orthogonal_(self.actor[2].weight, 0.01)
            nn.init.zeros_(self.actor[2].bias)
            self.logstd = nn.Parameter(torch.zeros(1, 2))
            if self.mirrored:
                self.register_buffer("_perm", torch.as_tensor(np.array(mirror[0]), dtype=torch.long))
                self.register_buffer("_signs", torch.as_tensor(np.array(mirror[1]), dtype=torch.float32))
                self.register_buffer("_parity", torch.as_tensor(ACTION_PARITY, dtype=torch.float32))

        def _streams(self, x):
            """``x (..., B, d)`` and its mirror image side by side: ``(..., 2B, d)`` (``x`` alone without)."""
            return torch.cat([x, x[..., self._perm] * self._signs], dim=-2) if self.mirrored else x

        def _heads(self, y, b):
            """The mean and value from GRU outputs ``y (..., 2B or B, H)`` of ``b`` robots."""
            mean, value = self.actor(y), self.value(y)[..., 0]
            if self.mirrored:
                mean = (mean[..., :b, :] + mean[..., b:, :] * self._parity) / 2
                value = (value[..., :b] + value[..., b:]) / 2
            return mean, value

        def _dist(self, mean):
            return torch.distributions.Normal(mean, torch.exp(self.logstd.expand_as(mean)))

        def forward_eval(self, observations, state):
            """One step of every robot: the state ``(n, hidden_size)`` in ``state["lstm_h"]`` advances."""
            x = observations.view(observations.shape[0], -1).float()
            n, h = x.shape[0], state.get("lstm_h")
            h = None if h is None else (torch.cat([h[:, :self.H], h[:, self.H:]]) if self.mirrored else h)
            y = self.cell(self._streams(x), h)
            state["lstm_h"] = torch.cat([y[:n], y[n:]], dim=1) if self.mirrored else y
            mean, value = self._heads(y, n)
            return self._dist(mean), value

        def sequence_mean(self, x):
            """The mean before its clip, ``(T, B, 2)``, of sequences ``x (T, B, d)`` from a zero state."""
            y, _ = self.gru(self._streams(x.float()))
            return self._heads(y, x.shape[1])[0]

        def forward(self, observations, state):
            """Training: ``observations (B, T, d)`` (PuffeRL's segments), every sequence from zero."""
            B, T = observations.shape[:2]
            y, _ = self.gru(self._streams(observations.reshape(B, T, -1).transpose(0, 1).float()))
            mean, value = self._heads(y, B)
            return self._dist(mean.transpose(0, 1).reshape(B * T, 2)), value.transpose(0, 1)

        def file_arrays(self):
            """``(cell, head layers)`` of the recurrent policy file."""
            g = {k: getattr(self.gru, f"{k}_l0").detach().double().numpy() for k in ("weight_ih", "weight_hh",
                                                                                      "bias_ih", "bias_hh")}
            cell = {"cell_W_ih": g["weight_ih"], "cell_W_hh": g["weight_hh"], "cell_b_ih": g["bias_ih"],
                    "cell_b_hh": g["bias_hh"]}
            return cell, [(m.weight.detach().double().numpy(), m.bias.detach().double().numpy())
                          for m in (self.actor[0], self.actor[2])]

    return MirrorGRU


def mean_layers(policy) -> list:
    """``[(W, b), ...]`` of the actor's mean network (the encoder's two layers, then ``decoder_mean``)."""
    lin = [policy.encoder[0], policy.encoder[2], policy.decoder_mean]
    return [(m.weight.detach().double().numpy(), m.bias.detach().double().numpy()) for m in lin]


def actor_parameters(policy) -> list:
    """The parameters only the actor uses: the Gaussian's mean head and log-std."""
    if hasattr(policy, "decoder_mean"):  # TanhMLP (the encoder is shared with the value head)
        return [*policy.decoder_mean.parameters(), policy.decoder_logstd]
    return [*policy.actor.parameters(), policy.logstd]  # MirrorGRU (the GRU is shared)


def file_shield(args: Args) -> str:
    return args.export_shield or args.shield


def sequence_action_gap(path, env, policy, shield, obs, batch: int = 8) -> float:
    """The largest difference between the recurrent file's actions and the torch policy's, both run
    from a zero state over the same sequences: ``obs (n, d)`` real observations cut into ``batch``
    robots' sequences (the file's rows advance one step per call)."""
    import torch

    from tin_swarm_env.policies.learned import load_policy

    T = len(obs) // batch
    x = np.asarray(obs[:T * batch], dtype=np.float64).reshape(T, batch, -1)
    with torch.no_grad():
        mean = np.clip(policy.sequence_mean(torch.as_tensor(x, dtype=torch.float32)).double().numpy(), -1, 1)
    file = load_policy(path, env)
    file.reset()
    gaps = []
    for t in range(T):
        want = mean[t] if shield is None else shield(mean[t], x[t])
        gaps.append(np.abs(file.act_batch(x[t]) - want).max())
    return float(max(gaps))


def export(policy, args: Args, rows: list, out: Path, check: bool = True) -> float:
    """Write the actor's deterministic action to ``out/policy`` and (``check``) check it against torch's."""
    import torch

    import tin_swarm_env as tse
    from tin_swarm_env.policies.base import make_shield, unwrap_env
    from tin_swarm_env.policies.export import export_actor, max_action_gap, real_observations
    from tin_swarm_env.policies.learned import save_policy

    env = tse.parallel_env(scenario=scenarios_of(args)[0], n_robots=args.n_robots,
                           **({"max_cycles": args.max_cycles} if args.max_cycles else {}))
    extra = {"library": "pufferlib", "algorithm": "ppo", "agent_steps": rows[-1]["agent_steps"] if rows else 0,
             "epochs": len(rows), "minutes": rows[-1]["minutes"] if rows else 0.0, "args": asdict(args),
             "torch": torch.__version__, "tin_swarm_env": tse.__version__}
    out.mkdir(parents=True, exist_ok=True)
    layout = unwrap_env(env).layout
    if args.cell == "none":
        export_actor(out / "policy", mean_layers(policy), "tanh", squash="clip", layout=layout,
                     scenario=args.scenario, extra=extra, shield=file_shield(args), symmetry=args.symmetry,
                     prior=args.prior)
    else:
        cell, head = policy.file_arrays()
        save_policy(out / "policy", head, "tanh", layout=layout, scenario=args.scenario, extra=extra,
                    shield=file_shield(args), symmetry=args.symmetry, cell=(args.cell, cell))
    if not check:
        return float("nan")
    shield = make_shield(file_shield(args), env)
    obs = real_observations(env, seeds=(args.seed + 100, args.seed + 101))
    if args.cell == "none":
        from tin_swarm_env.policies.residual import add_prior, make_prior

        prior = make_prior(args.prior, env, "export")

        def torch_actions(o):
            with torch.no_grad():
                g = policy.mean(torch.as_tensor(o, dtype=torch.float32)).double().numpy()
            a = np.clip(g, -1, 1) if prior is None else add_prior(prior(o), g)
            a = a if shield is None else shield(a, o)
            if prior is not None:
                prior.driven(a)
            return a

        gap = max_action_gap(out / "policy", env, torch_actions, obs)
    else:
        gap = sequence_action_gap(out / "policy", env, policy, shield, obs)
    if not gap <= 1e-4:
        raise SystemExit(f"{out / 'policy'}: the exported actions differ from torch's by {gap:.3g}")
    (out / "run.json").write_text(json.dumps({**extra, "export_max_action_gap": gap}, indent=1) + "\n")
    print(f"exported {out / 'policy'}: numpy vs torch actions differ by at most {gap:.2e}", flush=True)
    return gap


def main(argv=None) -> Path:
    args = parse_dataclass(Args, argv, description=__doc__.splitlines()[0])
    import torch

    from tin_swarm_env.adapters.puffer import make_puffer_env, use_cpu_advantage

    use_cpu_advantage()  # PufferLib's compiled advantage kernel needs CUDA torch: the same kernel in torch
    from pufferlib import pufferl

    torch.set_num_threads(args.torch_threads)
    torch.manual_seed(args.seed)
    kw = {"max_cycles": args.max_cycles} if args.max_cycles else {}
    env = make_puffer_env(scenarios_of(args), n_envs=args.n_envs, n_robots=args.n_robots, seed=args.seed,
                          shield=args.shield, reward_scale=args.reward_scale, prior=args.prior, **kw)
    mirror = None
    if args.symmetry == "mirror":
        from tin_swarm_env.policies.symmetry import mirror_map

        mirror = mirror_map(env.vec.layout)
    cls = tanh_mlp_class() if args.cell == "none" else mirror_gru_class()
    policy = cls(env, hidden_size=args.hidden, mirror=mirror)
    if args.prior != "none" and args.cell != "none":
        raise SystemExit("--prior needs --cell none: a residual policy file is an MLP (APF holds the memory)")
    with torch.no_grad():  # the Gaussian's log-std at the start (TanhMLP: decoder_logstd, MirrorGRU: logstd)
        (policy.decoder_logstd if args.cell == "none" else policy.logstd).fill_(args.init_logstd)
    pufferl.PuffeRL.print_dashboard = lambda *a, **k: None  # one line per epoch instead of the full-screen dashboard
    trainer = pufferl.PuffeRL(config(args, env.num_agents), env, policy)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows, t0, snap = [], time.perf_counter(), 0.0
    actor = actor_parameters(policy)
    for p in actor:  # the critic's warm-up (--critic-warmup-minutes): Adam skips parameters without gradients
        p.requires_grad_(args.critic_warmup_minutes <= 0)
    while trainer.global_step < args.max_steps and time.perf_counter() - t0 < 60 * args.max_minutes:
        if not actor[0].requires_grad and time.perf_counter() - t0 >= 60 * args.critic_warmup_minutes:
            for p in actor:
                p.requires_grad_(True)
        stats = trainer.evaluate()
        ended = defaultdict(list)
        for k, v in stats.items():
            ended[k].extend(v if isinstance(v, list) else [v])
        stats.clear()
        trainer.train()
        minutes = (time.perf_counter() - t0) / 60
        row = {"minutes": round(minutes, 3), "agent_steps": int(trainer.global_step),
               "steps_per_s": round(trainer.global_step / (60 * minutes), 1),
               **{k: round(float(np.mean(v)), 4) for k, v in ended.items() if v}}
        rows.append(row)
        print(row, flush=True)
        if minutes >= snap + args.snapshot_minutes:
            snap = args.snapshot_minutes * (minutes // args.snapshot_minutes)
            export(policy, args, rows, out / "snapshots" / f"m{minutes:05.1f}", check=False)
    trainer.utilization.stop()  # PuffeRL's monitor thread (not a daemon: the process would not exit)
    torch.save(policy.state_dict(), out / "model.pt")
    keys = sorted({k for r in rows for k in r})
    with open(out / "progress.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    env.close()
    export(policy, args, rows, out)
    return out


if __name__ == "__main__":
    main()
