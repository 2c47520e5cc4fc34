"""Mutation check, run by hand (not in CI): planted bugs the fast unit tests must catch.

    flock /tmp/heavy.lock python bench/mutants.py [--only ID,ID] [--list] [--timeout 300]
                                                 [--out docs/figures/mutants.md]
    python bench/mutants.py --quick      # a smoke run (seconds): every mutant planted and compiled, no tests

Each mutant is one realistic, hand-written change to one line of ``terrain/``, ``world/``,
``env/`` or ``policies/learned.py`` (and ``policies/network.py``, its layers) (a sign flip, an off-by-one, swapped axes, a wrong
comparison, a dropped term) with the few fast test files that should notice it. The script copies
the package once into a temporary directory, runs every selected test file once on the
unmutated copy (they must pass), then for each mutant writes the change into the copy, runs its
tests there (``PYTHONPATH`` = the copy, ``pytest -x``) and puts the line back. A mutant is
*killed* when a test fails (or the run times out), *survives* when every test passes. The score is
killed / (mutants - those judged equivalent, listed in ``EQUIVALENT`` with the reason).

The Markdown table goes to ``--out`` (default ``docs/figures/mutants.md``), headed with the
command and the load average; survivors are printed and written there to be judged by hand.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    id: str
    path: str  # relative to tin_swarm_env/
    old: str  # must occur exactly once in the file (or `nth` picks the occurrence)
    new: str
    tests: tuple[str, ...]
    nth: int = -1  # -1: `old` must be unique; else which occurrence (0 the first)


# fast test selections
REWARD = ("tests/env/test_reward.py",)
OBS = ("tests/env/test_observation.py",
       "tests/env/test_tin_swarm.py::test_break_slots_next_to_a_cliff_point_to_the_safe_side")
ENV = ("tests/env/test_reward.py", "tests/env/test_tin_swarm.py::test_arrival_terminates_with_reason_arrived",
       "tests/env/test_tin_swarm.py::test_truncation_and_dead_agents_leave_the_step_after",
       "tests/env/test_tin_swarm.py::test_driving_off_the_cliff_terminates_with_reason_fell",
       "tests/integration/test_geodesic.py::test_reward_is_the_decrease_of_the_distance_to_go")
LOCO = ("tests/world/test_locomotion.py", "tests/world/test_world.py")
WORLD = ("tests/world/test_world.py", "tests/world/test_locomotion.py", "tests/world/test_battery.py",
         "tests/world/test_sensing.py", "tests/world/test_entities.py",
         "tests/world/test_step_kernel.py")
FIELDS = ("tests/world/test_fields.py",)
TIN = ("tests/terrain/test_tin.py", "tests/terrain/test_kernels.py")
QUERIES = ("tests/terrain/test_tin.py", "tests/terrain/test_kernels.py")
BREAKS = ("tests/terrain/test_breaks.py",)
VALIDITY = ("tests/terrain/test_validity.py", "tests/terrain/test_tin.py")
DEM_IO = ("tests/terrain/test_dem_io.py",)
TIN_IO = ("tests/terrain/test_tin_io.py",)
VIP = ("tests/terrain/test_vip.py",)
CTG = ("tests/terrain/test_cost_to_go.py",)
LEARNED = tuple(f"tests/policies/test_learned.py::{t}" for t in (  # the torch-free ones
    "test_layout_mismatch_is_refused_naming_both", "test_edited_json_is_refused_naming_file_and_key",
    "test_edited_weights_are_refused_naming_the_file", "test_missing_or_unreadable_files_are_named",
    "test_save_is_atomic_and_replaces_only_a_policy_directory", "test_shield_filters_through_the_safety_cut",
    )) + ("tests/policies/test_network.py",)
SB3 = ("tests/adapters/test_sb3.py::test_adapter_episode_length_counts_the_robot_s_own_steps_and_return_its_own_rewards",)

M = Mutant
MUTANTS = [
    # -- the bugs issue 29 names --------------------------------------------------------------------------
    M("reward-containment-sign", "env/reward.py", "progress_per_m * _gain1(e0, e1)", "progress_per_m * _gain1(e1, e0)",
      REWARD),
    M("reward-collision-sign", "env/reward.py", "r += collision * coll[i]",
      "r -= collision * coll[i]", ENV),
    M("reward-arrival-strict", "env/reward.py", "pos[i, 1]) <= radius", "pos[i, 1]) < radius",
      REWARD),
    M("locomotion-rotation-transposed", "world/locomotion.py",  # in the kernel World.step runs
      "vxw = max_speed * (ch * c0 - sh * c1)\n    vyw = max_speed * (sh * c0 + ch * c1)",
      "vxw = max_speed * (ch * c0 + sh * c1)\n    vyw = max_speed * (-sh * c0 + ch * c1)", LOCO),
    M("locomotion-rotation-transposed-reference", "world/locomotion.py",  # in body_to_world, the numpy reference
      "ch * c[:, 0] - sh * c[:, 1], sh * c[:, 0] + ch * c[:, 1]",
      "ch * c[:, 0] + sh * c[:, 1], -sh * c[:, 0] + ch * c[:, 1]", LOCO),
    M("sb3-length-in-steps", "adapters/sb3.py", "self._ep_len += live_before", "self._ep_len += 1", SB3),
    # -- env/reward.py --------------------------------------------------------------------------------------
    M("reward-ring-strict", "env/reward.py", "(1.0 if e1 <= ring_tol else 0.0)", "(1.0 if e1 < ring_tol else 0.0)",
      REWARD),
    M("reward-battery-on-arrival", "env/reward.py", "e = emptied[i] and not arrived", "e = emptied[i]",
      REWARD),
    M("reward-arrive-after-fall", "env/reward.py", "if has and not fell[i]:",
      "if has:", REWARD),
    M("reward-precedence", "env/reward.py",
      "if arrived:\n            code = _ARRIVED\n        if fell[i]:\n            code = _FELL",
      "if fell[i]:\n            code = _FELL\n        if arrived:\n            code = _ARRIVED", REWARD),
    M("reward-energy-scale", "env/reward.py", "energy[i] / 1000.0", "energy[i] / 100.0", REWARD),
    M("reward-gain-or", "env/reward.py", "if np.isfinite(before) and np.isfinite(after):",
      "if np.isfinite(before) or np.isfinite(after):", REWARD),
    M("reward-no-target-zero", "env/reward.py", "d = np.full(state.n_robots, np.inf)",
      "d = np.full(state.n_robots, 0.0)", REWARD),
    M("reward-dead-paid", "env/reward.py", "r32[i] = np.float32(0.0)", "r32[i] = np.float32(r)", REWARD),
    M("reward-goal-progress-sign", "env/reward.py", "progress_per_m * _gain1(before[i], after[i])",
      "progress_per_m * _gain1(after[i], before[i])", REWARD),
    # -- env/observation.py ---------------------------------------------------------------------------------
    M("obs-point-y-sign", "env/observation.py", "obs[i, b + sl.y] = (-s * dx + c * dy) / R",
      "obs[i, b + sl.y] = (s * dx + c * dy) / R", OBS, nth=0),  # the robot/target/asset slots
    M("obs-break-normal-transposed", "env/observation.py", "obs[i, b + sl.ny] = -s * nx + c * ny",
      "obs[i, b + sl.ny] = s * nx + c * ny", OBS),
    M("obs-target-dist-scale", "env/observation.py", "obs[i, o.target_dist] = d / (d + R)",
      "obs[i, o.target_dist] = d / R", OBS),
    M("obs-target-dz-sign", "env/observation.py", "dz = tz[t] - heights[i]", "dz = heights[i] - tz[t]", OBS),
    M("obs-uphill-y", "env/observation.py", "obs[i, o.uphill + 1] = (-s * gx + c * gy) / gn",
      "obs[i, o.uphill + 1] = (s * gx - c * gy) / gn", OBS),
    M("obs-tilt-scale", "env/observation.py", "float(P.robot.max_speed_mps), np.pi / 2, 90.0)",
      "float(P.robot.max_speed_mps), np.pi, 90.0)", OBS),
    M("obs-drop-scale", "env/observation.py", "drops[j] / (abs(drops[j]) + dz_scale)", "drops[j] / dz_scale", OBS),
    M("obs-danger-inverted", "env/observation.py", "(br.kinds != ANGLE).astype(np.float64)",
      "(br.kinds == ANGLE).astype(np.float64)", OBS),
    M("obs-clip-low", "env/observation.py", "min(max(obs[i, m], -1.0), 1.0)", "min(max(obs[i, m], 0.0), 1.0)", OBS),
    M("obs-target-dir-x", "env/observation.py", "obs[i, o.target_dir] = (c * dx + s * dy) / d",
      "obs[i, o.target_dir] = (c * dx - s * dy) / d", OBS),
    # -- env/tin_swarm.py -----------------------------------------------------------------------------------
    M("env-truncate-off-by-one", "env/reward.py", "timeout = (steps >= max_cycles)[cop]",
      "timeout = (steps > max_cycles)[cop]", ENV),  # in end_step, the one bookkeeping of both envs
    M("env-dist-not-updated", "env/tin_swarm.py", "        self._dist = dist\n", "", ENV),
    # -- world/locomotion.py --------------------------------------------------------------------------------
    M("loco-disc-clip", "world/locomotion.py", "c = c / np.maximum(norm, 1.0)[:, None]",
      "c = c / np.minimum(norm, 1.0)[:, None]", LOCO),
    M("loco-downhill-slows", "world/locomotion.py", "np.arctan(np.maximum(rise, 0.0))", "np.arctan(np.abs(rise))",
      LOCO),
    M("loco-climb-scale", "world/locomotion.py", "1.0 - pitch_deg / max_climb_deg", "1.0 - pitch_deg / 90.0", LOCO),
    M("loco-turn-one-way", "world/locomotion.py", "np.clip(diff, -max_turn_rad, max_turn_rad)",
      "np.clip(diff, 0.0, max_turn_rad)", LOCO),
    M("loco-turn-no-wrap", "world/locomotion.py", "diff = (want - headings + np.pi) % (2 * np.pi) - np.pi",
      "diff = want - headings", LOCO),
    M("loco-fall-direction-walk", "world/locomotion.py", "grad[nb, 0] * dx + grad[nb, 1] * dy < 0.0",
      "grad[nb, 0] * dx + grad[nb, 1] * dy > 0.0", LOCO),
    M("loco-fall-direction-start", "world/locomotion.py", "disp[mv]) < 0)", "disp[mv]) > 0)", LOCO),
    M("loco-inactive-move", "world/locomotion.py", "vel_cmd[status != Reason.NONE] = 0.0", "pass", LOCO),
    M("loco-no-pullback", "world/locomotion.py", "s_stop = max(min(s - ds_pull, s), s_in, 0.0)", "s_stop = s", LOCO),
    M("loco-kernel-downhill-slows", "world/locomotion.py", "math.atan(max(rise, 0.0))", "math.atan(abs(rise))", LOCO),
    M("loco-kernel-inactive-moves", "world/locomotion.py", "if not active:\n        vxw = 0.0",
      "if False:\n        vxw = 0.0", LOCO),
    M("loco-kernel-turn-one-way", "world/locomotion.py", "h = h + min(max(diff, -max_turn), max_turn)",
      "h = h + min(max(diff, 0.0), max_turn)", LOCO),
    M("loco-kernel-fall-direction", "world/locomotion.py", "if grad[ta, 0] * dx + grad[ta, 1] * dy < 0:",
      "if grad[ta, 0] * dx + grad[ta, 1] * dy > 0:", LOCO),
    M("loco-kernel-climb-sign", "world/locomotion.py", "climb = z - h0", "climb = h0 - z",
      WORLD),
    # -- world/battery.py, world/world.py -------------------------------------------------------------------
    M("battery-descent-recharges", "world/step_kernel.py", "climb_j_per_m * _max0(cl)", "climb_j_per_m * cl", WORLD),
    M("battery-inactive-drains", "world/step_kernel.py", "if not active:\n        use = 0.0",
      "if False:\n        use = 0.0", WORLD),
    M("battery-negative", "world/step_kernel.py", "b = _max0(b0 - use)", "b = b0 - use", WORLD),
    M("world-emptied-strict", "world/step_kernel.py", "st == _NONE and b <= 0.0", "st == _NONE and b < 0.0", WORLD),
    M("world-collision-radius", "world/world.py", "float(2 * P.robot.radius_m))",
      "float(P.robot.radius_m))", WORLD + REWARD),  # in step_scalars, what both envs' step reads
    M("world-collisions-not-summed", "world/world.py", "collisions=state.collisions + coll", "collisions=coll", WORLD),
    # -- world/sensing.py, world/batch_kernels.py (sense_copies: the sensing of both envs) --------------------
    M("sense-fov-full", "world/batch_kernels.py", "half_fov = math.radians(sensor.fov_deg) / 2 + 1e-12",
      "half_fov = math.radians(sensor.fov_deg) + 1e-12", WORLD),
    M("sense-bearing-sign", "world/sense_kernels.py", "wrap_pi(math.atan2(dy, dx) - heading)",
      "wrap_pi(math.atan2(dy, dx) + heading)", WORLD),
    M("sense-no-sensor-height", "world/batch_kernels.py", "sz = np.ascontiguousarray(heights + sensor.height_m)",
      "sz = np.ascontiguousarray(heights)", WORLD),
    M("sense-no-entity-height", "world/batch_kernels.py", "eh = params.entity_height_m", "eh = 0.0", WORLD),
    M("sense-nearest-k-skip", "world/sensing.py", "if v >= best[i, k - 1]:", "if v >= best[i, 0]:", WORLD),
    # -- world/fields.py ------------------------------------------------------------------------------------
    M("fields-robot-attracts", "world/fields.py", "force = -(gain * w * w)[..., None] * unit",
      "force = (gain * w * w)[..., None] * unit", FIELDS),
    M("fields-target-one-sided", "world/fields.py", "gain * np.clip(e / range_m, -1.0, 1.0)",
      "gain * np.clip(e / range_m, 0.0, 1.0)", FIELDS),
    M("fields-break-decay", "world/fields.py", "gain * np.exp(-d / decay_m), 0.0)", "gain * np.exp(-d * decay_m), 0.0)",
      FIELDS),
    M("fields-height-saturation", "world/fields.py", "(gain * dz / (x + scale_m))", "(gain * dz / scale_m)", FIELDS),
    M("fields-facing-side", "world/fields.py", "np.sum(rel * normal, axis=-1) <= 1e-9",
      "np.sum(rel * normal, axis=-1) >= -1e-9", FIELDS),
    # -- terrain/tin.py -------------------------------------------------------------------------------------
    M("tin-aspect-axes", "terrain/tin.py", "np.arctan2(-gx, -gy)", "np.arctan2(-gy, -gx)", TIN),
    M("tin-gy-sign", "terrain/tin.py", "gy = -n[:, 1] / n[:, 2]", "gy = n[:, 1] / n[:, 2]", TIN),
    M("tin-height-axis", "terrain/tin.py", "g[:, 1] * (pts[:, 1] - v[:, 1])", "g[:, 1] * (pts[:, 1] - v[:, 0])", TIN),
    M("tin-tilt-compass", "terrain/tin.py", "heading_compass = np.pi / 2 - h", "heading_compass = h - np.pi / 2",
      TIN + ("tests/env/test_observation.py",)),
    M("tin-slope-asin", "terrain/tin.py", "self.slope_deg = np.degrees(np.arctan(g))",
      "self.slope_deg = np.degrees(np.arcsin(np.minimum(g, 1.0)))", TIN + BREAKS),
    # -- terrain/_kernels.py --------------------------------------------------------------------------------
    M("kern-los-sight-param", "terrain/_kernels.py", "z_sight = az + s * (bz - az)\n        if z_edge",
      "z_sight = az + u * (bz - az)\n        if z_edge", QUERIES, nth=0),  # los_walk
    M("kern-los-leaves-visible", "terrain/_kernels.py", "return 0  # the sight line leaves the TIN",
      "return 1  # the sight line leaves the TIN", QUERIES),
    M("kern-locate-tol-sign", "terrain/_kernels.py", "if orient(vx[a], vy[a], vx[b], vy[b], x, y) < -tol:",
      "if orient(vx[a], vy[a], vx[b], vy[b], x, y) < tol:", QUERIES),
    M("kern-bucket-axes", "terrain/_kernels.py", "c = int(fj) * gnx + int(fi)", "c = int(fi) * gny + int(fj)",
      QUERIES),
    # -- terrain/breaks.py ----------------------------------------------------------------------------------
    M("breaks-normal-not-flipped", "terrain/breaks.py", "    n[flip] *= -1\n", "", BREAKS),
    M("breaks-drop-sign", "terrain/breaks.py", "drops[nb] = 0.5 * (p[nb, 2] + q[nb, 2]) - z_opp",
      "drops[nb] = z_opp - 0.5 * (p[nb, 2] + q[nb, 2])", BREAKS),
    M("breaks-safe-side", "terrain/breaks.py", "np.where(is_steep[e_idx], ~steep[a0],", "np.where(is_steep[e_idx], steep[a0],",
      BREAKS),
    M("breaks-closest-unclipped", "terrain/breaks.py", "u = np.clip(np.sum((points - a) * ab, axis=-1) / L2, 0.0, 1.0)",
      "u = np.sum((points - a) * ab, axis=-1) / L2", BREAKS),
    M("breaks-angle-ge", "terrain/breaks.py", "is_angle &= angle > break_angle_deg",
      "is_angle &= angle > 2 * break_angle_deg", BREAKS),
    # -- terrain/validity.py, tin_io.py, dem_io.py, vip.py --------------------------------------------------
    M("validity-separated-strict", "terrain/validity.py", "sep |= s.max(axis=1) <= tol[:, 0]",
      "sep |= s.max(axis=1) < -tol[:, 0]", VALIDITY),
    M("dem-asc-no-flip", "terrain/dem_io.py", "    z = z[::-1]  # ESRI rows run north to south; ours run south to north\n",
      "", DEM_IO),
    M("vip-deviation-mean", "terrain/vip.py", "dev = np.abs(zc - 0.5 * (za + zb))", "dev = np.abs(zc - za)", VIP),
    # -- terrain/cost_to_go.py ------------------------------------------------------------------------------
    M("ctg-seed-distance-axis", "terrain/cost_to_go.py", "np.hypot(nx[seeds] - self.goal_xy[0], ny[seeds] - self.goal_xy[1])",
      "np.hypot(nx[seeds] - self.goal_xy[0], ny[seeds] - self.goal_xy[0])", CTG),
    # -- policies/learned.py --------------------------------------------------------------------------------
    M("learned-last-layer-activated", "policies/learned.py", "if i < len(self.layers) - 1:", "if i < len(self.layers):",
      LEARNED),
    M("learned-no-clip", "policies/learned.py", "return np.clip(self._mean(obs), -1.0, 1.0).astype(np.float32)",
      "return self._mean(obs).astype(np.float32)", LEARNED),
    M("learned-dense-bias", "policies/network.py", "            s = b[j]\n", "            s = 0.0\n", LEARNED),
    M("learned-relu-leaky", "policies/network.py", '"relu": lambda x: np.maximum(x, 0.0)',
      '"relu": lambda x: np.maximum(x, 0.01 * x)', LEARNED),
    M("learned-nan-accepted", "policies/network.py", "if not np.all(np.isfinite(a)):", "if np.all(np.isnan(a)):",
      LEARNED),
    M("learned-size-unchecked", "policies/learned.py",
      'if meta["observation"]["size"] != e.layout.size:', 'if meta["observation"]["size"] < e.layout.size:', LEARNED),
]

MARKER = "<!-- judged by hand: everything below this line is kept when bench/mutants.py rewrites the table -->"

# mutants judged equivalent by hand (no test can tell them from the original): id -> why
EQUIVALENT: dict[str, str] = {
    "reward-precedence": "the two assignments touch disjoint robots (`arrived` already excludes `events.fell`), "
                         "so their order cannot matter",
    "learned-size-unchecked": "unreachable: the layout compared just before includes the size, so a size "
                              "mismatch is refused there first",
}


def _run(cmd, env, timeout):
    t0 = time.monotonic()
    try:
        r = subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           timeout=timeout)
        return r.returncode, r.stdout, time.monotonic() - t0
    except subprocess.TimeoutExpired as exc:
        return None, (exc.stdout or "") if isinstance(exc.stdout, str) else "", time.monotonic() - t0


def _pytest(tests):
    # -P: no current directory on sys.path, so `import tin_swarm_env` finds the copy on PYTHONPATH
    return [sys.executable, "-P", "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]


def stale_mutants(muts=MUTANTS, root: Path = ROOT) -> list[str]:
    """One line per mutant whose planted change no longer applies exactly where meant (its ``old``
    text is gone from, or not unique in, its file; or a test it names is missing), plus duplicate
    ids; empty when all apply. tests/integration/test_bench_mutants.py keeps this list empty, so a
    rewrite of the code under a mutant fails CI instead of silently voiding the mutant."""
    ids = [m.id for m in MUTANTS]
    out = [f"duplicate mutant id {i!r}" for i in sorted({i for i in ids if ids.count(i) > 1})]
    for m in muts:
        path = root / "tin_swarm_env" / m.path
        count = path.read_text().count(m.old) if path.is_file() else 0
        if count == 0 or (m.nth < 0 and count != 1) or m.nth >= count:
            out.append(f"mutant {m.id}: {m.old!r} occurs {count} times in {m.path}")
        for t in m.tests:
            if not (root / t.split("::")[0]).is_file():
                out.append(f"mutant {m.id}: its test file {t.split('::')[0]} does not exist")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="comma-separated mutant ids")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per mutant run (a timeout counts as killed)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures" / "mutants.md"), help="Markdown output ('' none)")
    ap.add_argument("--quick", action="store_true", help="a smoke run (seconds): every selected mutant planted and "
                    "compiled, no test run, nothing written")
    a = ap.parse_args(argv)
    muts = MUTANTS
    if a.only:
        want = set(a.only.split(","))
        unknown = want - {m.id for m in MUTANTS}
        if unknown:
            ap.error(f"unknown mutant ids {sorted(unknown)}")
        muts = [m for m in MUTANTS if m.id in want]
    if a.list:
        for m in muts:
            print(f"{m.id:34s} {m.path:22s} {' '.join(m.tests)}")
        return 0
    stale = stale_mutants(muts)
    if stale:
        raise SystemExit("\n".join(stale))
    if a.quick:
        return _plant_all(muts)
    load = os.getloadavg()[0]
    t_start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="tin_mutants_") as tmp:
        pkg = Path(tmp) / "tin_swarm_env"
        shutil.copytree(ROOT / "tin_swarm_env", pkg, ignore=shutil.ignore_patterns("__pycache__"))
        env = {**os.environ, "PYTHONPATH": tmp, "MPLBACKEND": "Agg"}
        selected = sorted({t for m in muts for t in m.tests})
        rc, out, dt = _run(_pytest(selected), env, 3 * a.timeout)
        if rc != 0:
            print(out[-4000:])
            raise SystemExit(f"the unmutated copy fails its selected tests (rc {rc}): fix them first")
        print(f"baseline: {len(selected)} selections pass on the unmutated copy in {dt:.0f} s", flush=True)
        probe = subprocess.run([sys.executable, "-P", "-c", "import tin_swarm_env; print(tin_swarm_env.__file__)"],
                               cwd=ROOT, env=env, stdout=subprocess.PIPE, text=True, check=True).stdout.strip()
        if not probe.startswith(tmp):
            raise SystemExit(f"the tests would import {probe}, not the copy in {tmp}")
        rows = []
        for m in muts:
            f = pkg / m.path
            orig = f.read_text()
            st = f.stat()
            f.write_text(_planted(orig, m))
            # numba's on-disk cache is checked against each kernel's own file only: a kernel that
            # inlines or calls the mutated one from another file would run its stale cached code
            # (the mutant would "survive" untested). A fresh cache directory per compiled mutant.
            menv = {**env, "NUMBA_CACHE_DIR": str(Path(tmp) / f"numba_{m.id}")} if "@njit" in orig else env
            try:
                rc, out, dt = _run(_pytest(m.tests), menv, a.timeout)
            finally:
                shutil.rmtree(Path(tmp) / f"numba_{m.id}", ignore_errors=True)
                f.write_text(orig)
                os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns))
            status = "timeout" if rc is None else ("survived" if rc == 0 else "killed")
            failed = next((ln.split(" ")[1] for ln in out.splitlines() if ln.startswith("FAILED ")), "")
            if rc not in (None, 0, 1):
                failed = failed or f"pytest exit {rc}"
            rows.append((m, status, failed, dt))
            print(f"{status:8s} {dt:6.1f} s  {m.id:34s} {failed}", flush=True)
    total = time.monotonic() - t_start
    equiv = [r for r in rows if r[0].id in EQUIVALENT]
    counted = [r for r in rows if r[0].id not in EQUIVALENT]
    killed = sum(r[1] != "survived" for r in counted)
    survivors = [r for r in counted if r[1] == "survived"]
    score = killed / max(len(counted), 1)
    print(f"\nscore: {killed}/{len(counted)} non-equivalent mutants killed ({100 * score:.1f} %), "
          f"{len(equiv)} judged equivalent; {total / 60:.1f} min")
    for m, *_ in survivors:
        print(f"SURVIVED {m.id}: {m.path}: {m.old!r} -> {m.new!r}")
    if a.out:
        _write(Path(a.out), rows, killed, len(counted), score, load, total, argv)
    return 0


def _planted(orig: str, m: Mutant) -> str:
    """``orig`` with mutant ``m``'s change written in at its ``nth`` occurrence (the first: 0)."""
    i = -1
    for _ in range(max(m.nth, 0) + 1):
        i = orig.index(m.old, i + 1)
    return orig[:i] + m.new + orig[i + len(m.old):]


def _plant_all(muts) -> int:
    """``--quick``: each mutant's changed file still compiles (no test is run); prints one line each."""
    for m in muts:
        path = ROOT / "tin_swarm_env" / m.path
        compile(_planted(path.read_text(), m), str(path), "exec")
        print(f"planted {m.id:34s} {m.path:22s} compiles; its tests: {' '.join(m.tests)}")
    print(f"{len(muts)} mutants apply exactly once and compile (--quick: no test run)")
    return 0


def _write(path, rows, killed, counted, score, load, total, argv):
    cmd = "flock /tmp/heavy.lock python bench/mutants.py" + (" " + " ".join(argv) if argv else "")
    lines = [f"Mutation check: `{cmd}` (load average {load:.1f} at the start, {total / 60:.1f} min, "
             f"{os.cpu_count()} cores).", "",
             f"**Score: {killed} of {counted} non-equivalent mutants killed ({100 * score:.1f} %)**; "
             f"{len(rows) - counted} judged equivalent. Each mutant is one hand-written change to one line "
             "(`bench/mutants.py` lists them with the tests run against each).", "",
             "| mutant | file | result | first failing test | s |", "|---|---|---|---|---:|"]
    for m, status, failed, dt in rows:
        res = f"equivalent: {EQUIVALENT[m.id]}" if m.id in EQUIVALENT else status
        lines.append(f"| `{m.id}` | {m.path} | {res} | {failed.split('::')[-1] if failed else ''} | {dt:.0f} |")
    keep = ""  # the survivors' judgement, written by hand below the marker, survives a new run
    if path.exists() and MARKER in path.read_text():
        keep = path.read_text()[path.read_text().index(MARKER):]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n\n" + (keep or MARKER + "\n"))


if __name__ == "__main__":
    sys.exit(main())
