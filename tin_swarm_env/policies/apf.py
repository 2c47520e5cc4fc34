"""Artificial Potential Field policy with a boundary search: acts from the observation alone, for
all robots at once. This docstring is the one home of the rule. The default search is the *chart
search* (below, with the default observation's terrain scan); the *boundary search* (bug rules)
and the fields alone (no break field) are kept as weaker baselines, with their figures in
``docs/figures/apf.md`` beside the default's.

**Fields.** The observation (:class:`~tin_swarm_env.env.observation.ObsLayout`) is egocentric, so
the fields of :mod:`tin_swarm_env.world.fields` are evaluated in the body frame and their sum is
the commanded body-frame velocity, full speed once the force reaches ``speed_saturation``:
``action = F / max(|F|, speed_saturation)``. Last, the command is cut by the safety shield
(:class:`~tin_swarm_env.policies.base.SafetyShield`): no command into the blind sector, no robot
closes on a robot it sees to within 1.5 body diameters nor on a dangerous break it sees to within
one. What the policy takes from the environment is static: the observation layout, the sensor
range, the task's standoff, the robot's radius, top speed and time step, never the world state.

**Boundary search** (``search="bug"``, with the break field on; :mod:`tin_swarm_env.policies.bug`). A robot whose
attraction points into a dangerous break it sees from the safe side within ``follow_engage_m``
is *blocked*: a potential field alone has a minimum there. The robot then searches along the
boundary of the ground it may not leave, bug-algorithm style (Lumelsky and Stepanov's Bug2,
Kamon and Rivlin's DistBug, the lost-cow doubling search), with this memory per robot
(:class:`~tin_swarm_env.policies.bug.BugMemory`, numpy arrays over robot rows):

* *odometry*: its heading ``psi`` in its own frame. The observation gives the target's distance
  and bearing and the speed achieved last step; the robot knows its last command, so it knows
  how it moved (along the command, by that speed) and, the target being a fixed point, how its
  heading turned: its position relative to its target is then ``q = -R(psi) rel_t``, exact up to
  the observation's float32 rounding (a mobile target drags the frame; the whole-circuit test is
  off then);
* the *hit point* ``H`` (``q`` where the search started) and the distance to go there ``rec``;
* the *side* (+1 the boundary on the robot's right, -1 on its left), the side it started on,
  the boundary driven from ``H`` (``arc``, signed), the *budget* and which sides have *ended*;
* the followed break's closest point last seen (so it goes round the end of a break that drops
  out of its ``K_b`` slots instead of jumping to another), a stall counter, the gap state;
* a *loop finder*: :data:`~tin_swarm_env.policies.bug.RING` (16) places along its current *leg*
  (the boundary driven since it last met a boundary, turned or drove through a gap), first
  ``ring_m`` apart, every other one dropped and the spacing doubled when the ring fills (so they
  span the leg), each with its direction of travel and the least distance to go (and from ``H``)
  on the stretch after it; the lap's nearest place it heads for, and the distance to go where it
  last left a loop (rule 3).

The rules, each step:

1. *Meet* a boundary: blocked while heading for the target. Nearer than ``rec - margin_m``: a
   fresh search (``H`` here, ``rec`` the distance to go here), on the side whose tangent points
   more toward the target; else it takes its last search up again (same ``H``, side, budget).
   Either way it follows the break that blocks it (not the one it followed before it left).
2. *Follow* (:func:`~tin_swarm_env.world.fields.follow_field`): it keeps ``follow_hold_m`` off
   the followed break, the break that continues last step's (:func:`~tin_swarm_env.policies.bug._followed`).
   Another break seen at its *end* whose closest point lies more than a passable gap (``pass_m``)
   from the point followed last step is across an open way: for half a turn round the point it
   followed (``pi follow_hold_m`` of driving) the robot goes round that point instead, so it
   turns into a ramp mouth or pass at the end of its wall even when that end has dropped out of
   its ``K_b`` break slots (the nearest breaks, often seen from their unsafe side, crowd them).
   Not when the point it followed was seen square on (not at an end) and now lies in the blind
   sector behind it: that break runs on out of view, and the break ahead closes a corner with it.
3. *Leave* when not blocked and nearer than ``rec - margin_m``, and either on the *m-line*
   (the line from ``H`` to the target: Bug2) or ``leave_gain`` nearer than ``rec``; or when it
   sees the way to the target clear of dangerous breaks as far as it senses (the followed
   break's point last seen counts: it may drop out of the ``K_b`` slots for a step as the robot
   turns) and that clear stretch would bring it nearer than ``rec - margin_m`` (DistBug's range
   rule), but not again
   once such a leave has proved wrong (it met a boundary again no nearer than ``rec - margin_m``
   and took the search up), until it has shown that it goes round a loop that ``H`` is not on
   (an island reached through a gap): it passes a place on its way again going the same way,
   ``home_arc_m`` or more after it (Brent's cycle finding: the place moves on to where the robot
   is at doubling distances driven, so a loop is found within the distance to it plus twice its
   length); or drive through a gap between two break ends that leads toward the target
   (:func:`~tin_swarm_env.policies.bug.pass_gap`); or (Bug1, on whatever boundary it is on) when it
   has driven round a closed boundary and is back at the place of least distance to go on that
   lap: it passed a place of its leg again going the same way (within ``home_m``, heading within
   45 degrees), ``home_arc_m`` or more after it, on a lap that does not pass ``H`` (that one is rule
   5's); it then goes round once more to that place and leaves there, ``rec`` and the clear-view
   ban aside, provided the place is ``margin_m`` nearer than where it last left a loop in this search
   (a boundary met at once there is taken up, rule 1). A lap with no such place is followed on.
4. *Turn back* (side -> -side) when the boundary *ends* on this side: the terrain's border is
   followed or lies ahead, or the robot stalls (``stall_steps``; four times that with robots
   near: a queue); or when it has driven ``budget`` along this side from ``H`` (first
   ``first_budget * rec``, at least ``min_budget`` sensor ranges), the budget doubling at each
   turn, unless the other side has ended. Passing ``H`` on its way back it goes on along the other side.
   An end counts only heading out from ``H``: on its way back it retraces boundary it has driven,
   so the border or a stall met there (the corner it turned in, a queue) ends neither side.
5. *Unreachable*: the boundary ended on both sides, or it has come back to ``H`` going the way
   it set off after going round (the whole boundary) twice in the search: the target cannot be
   reached from where it is. It says so (:attr:`APFPolicy.unreachable`) and stands still. The
   first time round counts as an end of that side (rule 4: it turns back and goes round the other
   way, or says so at once if the other side has ended): the boundary is sensed through ``K_b``
   slots only, and an opening walked past one way (a ramp mouth on a mesa) can show the other way.

*Why this is complete* (terrain a rectangle, obstacles finite). Each fresh search starts at least
``margin_m`` nearer the target than the one before, and between searches the robot heads for the
target, so there are finitely many searches. Within one, the doubling budget explores each side
further at every turn until it ends (at the border: the two ends and the border close the
robot's part of the terrain) or the robot comes round to ``H``; either way after finitely many
turns the whole boundary through ``H`` has been driven. If the target is reachable, the m-line
from ``H`` meets that boundary again at a point nearer the target with the way to the target
clear (Bug2's argument), where rule 3 lets the robot leave; so a robot that finds no such point
has shown its target unreachable (rule 5). No loop is driven twice the same way: a loop round
``H`` is driven once each way at most, then ends the search, and the turn-backs retrace what the
budget allowed, each time further. The argument assumes the robot keeps to the boundary
through ``H``; one that crosses to another boundary through a gap or ramp can follow that one
round for good (never nearer than ``rec``, never back at ``H``). Rule 3's loop finder closes that
case the way Bug1 does: a closed boundary driven round once is left on the next lap at its place
nearest the target, each such leave in a search ``margin_m`` nearer than the last, so a search
has finitely many; a closed boundary whose lap comes no nearer than the last such leave is
still followed on (open: measured in ``research/apf_notes.md``), as are boundaries that are
not closed but long (the budget and the border end those).

**Chart search** (``search="chart"``, the default; :mod:`tin_swarm_env.policies.chart`; the bug
search above is ``search="bug"``). Instead of the bug rules, each robot keeps a chart of what it has sensed and
heads along the shortest way to its target on it, taking ground it has not sensed as open (the
free-space assumption of D* and its kin). Memory per robot
(:class:`~tin_swarm_env.policies.chart.ChartMemory`, constants in
:class:`~tin_swarm_env.policies.chart.ChartParams`): the odometry above (``q`` exact); a chart of
``cells x cells`` (512 x 512 bytes: 256 KiB) centred on its target in its frame ``F``, cells
``2 (reach d0 + range_reach R) / cells`` wide (``d0`` its distance to go at its first step, ``R``
the sensor range; at least one step at top speed), each open, *wall* or *stuck*; the way it planned
(its first ``2 cells`` cells: 5 KiB at 512) and the point it heads for; last step's break points;
a stall anchor and count. Each step:

1. *Mark*: the cell ``inset`` (half a cell) beyond every dangerous break point it sees is a wall
   (a cell mostly on the point's safe side stays open: a gap is charted about as wide as it is),
   and ``extend`` cells either
   side along the break for a point seen square on (not at a break's end); a point within ``link``
   cells of one seen last step shuts the cells between them (a wall driven along leaves no hole);
   the terrain is a rectangle, so a border point (``b_border``) shuts the whole half-plane beyond it.
   With the observation's terrain scan (``[observation] k_scan``: :mod:`tin_swarm_env.env.observation`)
   the point where each beam meets a dangerous break is a wall too (``inset`` on along the beam), and
   the cell behind it along the beam: a pocket's far wall is charted from its mouth, not only when driven along
   (``research/sensing_bound.md`` measures what that buys). A layout with a scan and no break
   slots (``k_breaks = 0``) is charted from the beams alone, with no wall to slide along (step 3);
   the bug search reads only the break slots, so without them APF is the fields alone. Where a chart's
   cells are narrower than ``unseen_gap`` passes (step 2), every open cell a beam passes over (from half
   a cell out to a cell short of where it ends) is marked *seen*.
2. *Plan* (A*, 8-connected, no corner cut between two shut cells; a step into a cell beside a shut
   one costs ``wall_cost`` cells more, a first step against the way it was heading up to ``turn_m``
   more, and a step onto the side it does not prefer of the line from where it started to its target
   ``side_cost`` times its length more: robot ``i`` keeps right or left by
   :func:`~tin_swarm_env.policies.chart.robot_side`, about half of each target's robots each way, so
   where a wall blocks the straight way the robots of one target split between its two ends) the least-cost way
   over open cells to the target's cell, and keep it. An open cell in a gap between shut cells on
   opposite sides (across a row, a column or a diagonal) narrower than ``unseen_gap`` passes
   (``pass_m`` = 3 body diameters) counts as a wall unless it is marked seen: such a gap is most
   often a hole between two sightings of one wall (beams far apart), while a pass that narrow on
   real hillside is one the beams have looked through. (``unseen_gap = 0``: the rule before it, an
   open cell between two shut cells counts as a wall only on a chart fine enough that a pass is at
   least ``pinch_cells`` = 2.5 cells wide.)
   It plans again only when the rest of that way may have stopped being least-cost: a cell on or beside it (in the 3 x 3
   block of one of its cells from where the robot is on) became shut; or the robot is more than a
   cell off it (pushed aside, sliding along a wall); or it stalled (step 4); or the way was longer
   than ``2 cells`` cells (kept cut there) and its chart changed or it nears the cut. A cell shut
   anywhere else only makes other ways dearer, so the way kept is still a least-cost one. It heads
   for the farthest cell of that way within ``ahead_m`` (at least 3 cells) that lies in a straight
   open line on the chart from its cell; within two cells of that point (or at it) it takes the
   next such point along the way kept, without planning.
3. *Drive*: the fields above, with the attraction turned toward that point (the height field off
   while it is not the target itself) and the break field's decay ``ChartParams.break_decay_m``
   (0.5 m: the way keeps off the walls, so the field is a cushion at the wall, and a funnel a few
   body lengths wide does not push the robot back out); where a dangerous break it faces within ``follow_engage_m``
   lies across the attraction, it slides along the break (the follow term) on the side the
   attraction leans to. The shield is unchanged.
4. *Stall*: not two body lengths (or 1.5 cells) from where it was ``stall_steps`` steps ago (twice
   that with robots near): the cells on the straight line to the point it heads for become *stuck*.
5. *No way* over open cells: it takes the way through the fewest walls instead (A* again, a wall
   cell entered, or a diagonal step past one, costing ``cells`` more; stuck cells stay shut). A
   robot whose last way went through walls first floods its chart from the target: where that
   closes short of it (a target walled in on its chart), the search over open cells is skipped
   (the same way, without searching every cell it can reach). On
   real terrain a pass narrower than about two cells (the chart's cells are sized by the distance
   to go, the passes by the hillside) is charted shut by the walls of its two sides, and a robot
   in a channel that narrow has every neighbouring cell shut: the way through the fewest walls is
   the narrowest charted gap, which it then tries. Where it stalls (step 4) the cells on its
   straight way become stuck, walls included (a wall cell never turns a stuck one back), so it
   tries the next gap. Failing that it forgets its stuck cells, then its whole chart, planning
   again after each. It never stands still for want of a way: no unreachable verdict.

*Why it terminates, and where it may not.* Each mark shuts an open cell and the chart is finite, so
between two forgettings the chart changes finitely often; while nothing on or beside its way changes,
the robot drives a fixed least-cost way: it arrives, or a break across that way comes into its slots and is marked,
or it stalls and marks the way stuck. So it meets every dead end once and never circles a charted
loop. Forgetting (step 5) gives up that argument: a robot that forgets can chart the same cells
again; ``ChartMemory.forgot`` counts it. Free-space planning also takes the way that looks shortest
on what it has seen, so a wrong first side costs the distance to where the chart shows it closed
(often the terrain's border), with no budget to turn back sooner: measured beside the bug search in
``docs/figures/apf.md``.

**Queues.** Robots that see each other keep 1.5 body diameters apart and the robot field pushes
them aside, so robots following one wall queue behind each other; one stalled in a queue turns
back after four times ``stall_steps`` (a queue dissolves: the robots behind pass it or turn too).

**Gaps.** Where two sensed break ends leave a gap at least 3 body diameters wide with the target
beyond it and nothing sensed closing it, a following robot drives through it once per search.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..world.fields import (
    FIELDS,
    FieldParams,
    asset_field,
    break_field,
    follow_field,
    height_field,
    robot_field,
    target_field,
)
from .base import DecodedObs, SafetyShield, act_dict, decode, unwrap_env
from .bug import BugMemory, BugParams, bug_update, odometry, pass_gap, sensed
from .chart import ChartMemory, ChartParams, chart_update

__all__ = ["APFPolicy", "apf_forces", "field_forces", "follow_term", "FORCES", "BugMemory", "bug_update", "pass_gap"]


FORCES = ("robot", "target", "break", "follow", "height", "asset")


def apf_forces(obs, layout, range_m, standoff_m, params: FieldParams, follow=None, step_m=1.0, guard_m=0.0):
    """Per-field body-frame forces for observations ``obs (n, d)``: a dict name -> ``(n, 2)``
    (:data:`FORCES`: ``robot``, ``target``, ``break``, ``follow``, ``height``, ``asset``; fields
    switched off are zeros; the asset field reads the layout's asset slots, guard ring radius
    ``guard_m``). ``follow = (side (n,), slot (n,))``: each robot's wall-following side (+1 the
    break on its right, -1 on its left, 0 none) and the break slot it follows (-1 none), from
    :func:`bug_update`; ``follow`` is then the wall-following term
    (:func:`~tin_swarm_env.world.fields.follow_field`, ``step_m`` the distance covered in one
    step at full speed); without it, zero."""
    d = decode(obs, layout, range_m)
    out = field_forces(d, layout, standoff_m, params, guard_m)
    if follow is not None and params.on("break") and layout.k_breaks:
        out["follow"] = follow_term(d, out["target"] + out["height"], *follow, params, step_m)
    return out


def field_forces(d: DecodedObs, layout, standoff_m, params: FieldParams, guard_m=0.0) -> dict:
    """:func:`apf_forces` from the decoded observation ``d`` (:func:`decode`), without the
    wall-following term (``follow`` is zeros)."""
    n = len(d.dist)
    zero = np.zeros((n, 2))
    out = dict.fromkeys(FORCES, zero)
    if params.on("asset") and layout.k_assets:
        out["asset"], _ = asset_field(d.a_rel, d.a_valid, guard_m, params.asset_gain, params.asset_range_m)
    has_t = d.has_t[:, None]
    if params.on("target"):
        f, _ = target_field(d.rel_t, standoff_m, params.target_gain, params.target_range_m)
        out["target"] = np.where(has_t, f, 0.0)
    if params.on("height"):
        f, _ = height_field(d.grad_z, d.dz, params.height_gain)
        out["height"] = np.where(has_t, f, 0.0)
    if params.on("robot") and layout.k_robots:
        out["robot"], _ = robot_field(d.r_rel, d.r_valid, params.robot_gain, params.robot_range_m)
    if params.on("break") and layout.k_breaks:
        out["break"], _ = break_field(d.b_rel, d.b_normal, d.b_danger, params.break_gain,
                                      params.break_range_m, params.break_decay_m)
    return out


def follow_term(d: DecodedObs, pull, side, slot, params: FieldParams, step_m: float):
    """The wall-following term ``(n, 2)`` of robots following break ``slot (n,)`` (-1 none) on
    ``side (n,)`` with attraction ``pull (n, 2)`` (:func:`~tin_swarm_env.world.fields.follow_field`)."""
    k = np.maximum(slot, 0)[:, None, None]
    side = np.where(slot >= 0, side, 0)
    rel = np.take_along_axis(d.b_rel, k, axis=1)[:, 0]
    nrm = np.take_along_axis(d.b_normal, k, axis=1)[:, 0]
    return follow_field(pull, rel, nrm, side, params.follow_hold_m, step_m)


class APFPolicy:
    """The thesis's potential-field controller as a policy: ``act(obs_dict) -> action_dict``
    and ``act_batch(obs (n, d)) -> actions (n, 2)``.

    ``fields``: any subset of ``("robot", "target", "break", "height", "asset")`` (the asset field
    acts only where the observation has asset slots: a scenario with assets); ``params``: gains and
    ranges (:class:`~tin_swarm_env.world.fields.FieldParams`), ``fields`` overriding its own.
    Without ``params``, the containment task widens the robot field's range to 1.1 times the
    arc between robots evenly spread on the standoff ring (from the scenario's robot and threat
    counts), so that robots spread around each threat instead of bunching where they arrive.

    **Memory and search** (with the break field on): see the module docstring; ``search`` picks
    the chart search, ``"chart"`` (the default), or the boundary search, ``"bug"`` (a weaker baseline); ``bug`` and ``chart`` set their
    constants (:class:`~tin_swarm_env.policies.bug.BugParams`,
    :class:`~tin_swarm_env.policies.chart.ChartParams`). :attr:`unreachable` lists the
    robots that have shown their target unreachable (they stand still).

    **Gaps**: where two sensed break ends leave a gap at least 3 body diameters wide (the edge cut
    keeps one diameter off each side) with the target beyond it and no sensed corner or break
    closing it (:func:`pass_gap`), the robot drives through it: its attraction turns toward the
    gap and through it, the two ends do not push (the edge cut still applies) and it does not
    count as blocked. A robot following a wall at ``follow_hold_m`` would otherwise walk past a
    pass narrower than twice that, and the two ends' break field would close it.
    Rows are robots: ``act_batch`` row ``i`` is robot ``i``; ``act`` maps each agent name to a row
    the first time it sees it. The memory
    grows lazily to the number of rows; :meth:`reset` clears it (call it after each env reset).

    **Crowding and edges**: the summed command is cut by
    :func:`~tin_swarm_env.policies.base.keep_clear` so that robots that
    see each other never come within 1.5 body diameters (the robot field spreads them; a
    command into the blind sector behind the robot is first turned to the edge of its field of
    view, :func:`~tin_swarm_env.policies.base.into_view`), and,
    with the break field on, so that no robot comes within one body diameter of a dangerous
    break it sees, however long its step.
    """

    def __init__(self, env, fields=FIELDS, params: FieldParams | None = None, bug: BugParams | None = None,
                 search: str = "chart", chart: ChartParams | None = None):
        base = unwrap_env(env)
        cfg = base.config
        self.shield = SafetyShield(env)
        if params is None:
            params = FieldParams()
            n_threats = cfg.targets.n
            if cfg.task == "containment" and n_threats and self.shield.standoff_m > 0:
                # spread around the ring: robots repel out to the arc spacing of an even ring
                per_ring = -(-cfg.robots.count // n_threats)
                spacing = 2 * np.pi * self.shield.standoff_m / max(per_ring, 1)
                params = FieldParams(robot_range_m=max(params.robot_range_m, 1.1 * spacing))
            if search == "chart":  # the chart search's own break-field decay (ChartParams.break_decay_m)
                params = dataclasses.replace(params, break_decay_m=(chart or ChartParams()).break_decay_m)
        self.params = FieldParams(**{**params.__dict__, "fields": tuple(fields)})
        self.bug = bug or BugParams()
        if search not in ("bug", "chart"):
            raise ValueError(f"APFPolicy: search must be 'bug' or 'chart', got {search!r}")
        self.search = search
        self.chart = chart or ChartParams()
        self.static_target = not cfg.targets.mobile
        self.layout = base.layout
        # the bug search reads the break slots; the chart search reads them or the terrain scan
        self._senses_breaks = bool(self.layout.k_breaks or (search == "chart" and self.layout.k_scan))
        self.reset()

    def reset(self):
        """Forget every robot's memory (call after each environment reset)."""
        self.memory = BugMemory.empty(0)
        self.charts = ChartMemory.empty(0, self.chart.cells, self.layout.k_breaks)
        self._rows: dict = {}

    def forget(self, rows) -> None:
        """Forget the memory of the robots in ``rows`` only (their next step is a first step, as after
        :meth:`reset`): a vector env's copy that starts a new episode while the others go on."""
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        rows = rows[(rows >= 0) & (rows < len(self.memory.side))]
        if not len(rows):
            return
        e = BugMemory.empty(len(rows))
        for f in dataclasses.fields(self.memory):
            getattr(self.memory, f.name)[rows] = getattr(e, f.name)
        m = min(len(self.charts.cell), len(self.memory.side))
        r = rows[rows < m]
        if len(r):
            c = ChartMemory.empty(len(r), self.charts.grid.shape[1], self.charts.last_ok.shape[1])
            for f in dataclasses.fields(c):
                if f.name != "work":
                    getattr(self.charts, f.name)[r] = getattr(c, f.name)

    def forces(self, obs, rows=None) -> dict:
        """Per-field forces (:func:`apf_forces`) for observations ``obs (n, d)`` of the robots in
        ``rows`` (default ``0..n-1``); advances their memory by one step."""
        return self._forces(decode(obs, self.layout, self.shield.range_m), rows)

    def _forces(self, d: DecodedObs, rows=None) -> dict:
        f = field_forces(d, self.layout, self.shield.standoff_m, self.params, self.shield.guard_m)
        if not (self.params.on("break") and self._senses_breaks):
            return f
        rows = np.arange(d.n) if rows is None else np.asarray(rows, dtype=np.int64)
        self.memory = mem = self.memory.grow(int(rows.max(initial=-1)) + 1)
        q, moved = odometry(mem, rows, d, self.shield.step_m)
        if self.search == "chart":
            return self._chart_forces(f, d, rows, q)
        pull = f["target"] + f["height"]
        g = pass_gap(d, self.shield.pass_m, self.params.follow_engage_m)
        # a robot with another one ahead toward the gap queues (the usual fields) instead
        r_d = np.sqrt(np.sum(d.r_rel ** 2, axis=-1))
        ahead = np.einsum("nkj,nj->nk", d.r_rel, g["aim"]) > 0
        queue = ((d.r_valid > 0.5) & ahead & (r_d < 2 * self.params.robot_range_m)).any(axis=-1)
        mem_gap = mem.gap[rows]
        has = g["has"] & ~queue & (mem.side[rows] != 0) & (mem_gap < 2)
        mem.gap[rows] = np.where(has, 1, np.where(mem_gap == 1, 2, mem_gap))
        if has.any():  # the two ends bounding the gap do not push (the edge cut still keeps it off them)
            danger = d.b_danger.copy()
            r = np.flatnonzero(has)
            danger[r, g["slots"][r, 0]] = danger[r, g["slots"][r, 1]] = False
            p = self.params
            f["break"], _ = break_field(d.b_rel, d.b_normal, danger, p.break_gain, p.break_range_m,
                                        p.break_decay_m)
        togo = np.abs(d.dist - self.shield.standoff_m)
        rel, nrm, side = bug_update(mem, rows, d, pull, self.params, self.bug, togo=togo, q=q, moved=moved,
                                    crowd_m=2 * self.params.robot_range_m, range_m=self.shield.range_m, gap=has,
                                    home=self.static_target, pass_m=self.shield.pass_m, step_m=self.shield.step_m,
                                    fov_deg=self.shield.fov_deg)
        f["follow"] = follow_field(pull, rel, nrm, side, self.params.follow_hold_m, self.shield.step_m)
        mag = np.sqrt(np.sum(pull * pull, axis=-1, keepdims=True))
        f["follow"] = np.where(has[:, None], mag * g["aim"] - pull, f["follow"])
        return f

    def _chart_forces(self, f, d, rows, q):
        self.charts = ch = self.charts.grow(len(self.memory.side))
        r_d = np.sqrt(np.sum(d.r_rel ** 2, axis=-1))
        crowded = ((d.r_valid > 0.5) & (r_d < 2 * self.params.robot_range_m)).any(axis=-1)
        psi = self.memory.psi[rows]
        way = chart_update(ch, rows, d, q, psi, self.chart, self.shield.range_m, self.shield.step_m,
                           2 * self.shield.edge_m, crowded, self.shield.standoff_m, self.shield.pass_m)
        detour = np.any(way != d.rel_t, axis=-1)
        wn = np.sqrt(np.sum(way * way, axis=-1, keepdims=True))
        mag = np.sqrt(np.sum(f["target"] ** 2, axis=-1, keepdims=True))
        f["target"] = np.where(detour[:, None], way / np.maximum(wn, 1e-9) * mag, f["target"])
        f["height"] = np.where(detour[:, None], 0.0, f["height"])
        # a wall across the way on the chart's way: slide along it, on the side the pull leans to
        pull = f["target"] + f["height"]
        if not self.layout.k_breaks:  # the scan alone: no break slot to slide along
            return f
        s = sensed(d, pull, self.params)  # the bug search's test of a break across the pull
        k = np.argmin(np.where(s["into"], s["dist"], np.inf), axis=-1)
        rel = np.take_along_axis(d.b_rel, k[:, None, None], axis=1)[:, 0]
        nrm = np.take_along_axis(d.b_normal, k[:, None, None], axis=1)[:, 0]
        e = np.take_along_axis(s["e"], k[:, None, None], axis=1)[:, 0]
        side = np.where(s["into"].any(axis=-1), np.where(e[:, 1] * pull[:, 0] - e[:, 0] * pull[:, 1] >= 0, 1, -1), 0)
        f["follow"] = follow_field(pull, rel, nrm, side, self.params.follow_hold_m, self.shield.step_m)
        return f

    def act_batch(self, obs, rows=None) -> np.ndarray:
        d = decode(obs, self.layout, self.shield.range_m)
        rows = np.arange(d.n) if rows is None else np.asarray(rows, dtype=np.int64)
        f = sum(self._forces(d, rows).values())
        mag = np.sqrt(np.sum(f * f, axis=-1, keepdims=True))
        a = self.shield.cut(f / np.maximum(mag, self.params.speed_saturation), d, edges=self.params.on("break"))
        if len(self.memory.side):
            a = np.where(self.memory.unreachable[rows][:, None], np.float32(0.0), a)
            self.memory.last_act[rows] = a
        return a

    @property
    def unreachable(self) -> np.ndarray:
        """``(rows,)`` bool: robots that have shown their target unreachable from where they are
        (they went round the whole boundary, or it ends on both sides); they stand still."""
        return self.memory.unreachable.copy()

    def act(self, obs: dict) -> dict:
        return act_dict(self.act_batch, obs, [self._rows.setdefault(k, len(self._rows)) for k in obs])
