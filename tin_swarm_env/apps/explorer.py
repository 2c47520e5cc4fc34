"""The field explorer: the thesis's MATLAB tool (4.1, figures 4.1-4.3) rebuilt with matplotlib.

Top: the TIN in 3D, too-steep triangles white and safe ones grey, robots (orange), the
selected robot (ringed), threats/targets (red) and assets (blue) on it. Bottom: the potential
field felt by the selected robot, as a surface (left) and as a heatmap with force arrows
(right). The thesis's controls, all on the figure:

==========================  ==================================================================
control                     what it does
==========================  ==================================================================
check boxes (fields)        switch each field (robot, target, break, height, asset) on or off
"cost-to-go" check box      overlay contours of the selected robot's target's cost-to-go
                            (:func:`tin_swarm_env.terrain.cost_to_go`, metres of drivable path)
"continuous" check box      run: a timer takes a step every 100 ms until unchecked
"next step" / "reset"       one APF step for every live robot / the episode from its seed
"add robot" button          the next left click on the heatmap places a new robot
heatmap, left click         on a robot: select it (its field is shown); elsewhere: move the
                            selected robot there
heatmap, left drag          drag a robot or a threat/target to a new place
heatmap, right click        add a threat/target there
==========================  ==================================================================

It drives the env through its public API only. The env's agent set is fixed for an episode,
so every change of the world restarts the episode from the current state: moving a robot or a
threat and adding a threat reset the env with the current positions (reset options
``robot_positions``, ``headings``, ``target_positions``), so an added or moved threat is
assigned to robots (``i mod m``) and felt; **adding a robot makes a new env with n + 1 robots**
and resets it the same way (the status line under the figure says so). Robots that fell or
arrived are left out of a restart. A change that would put something off traversable ground
is refused (the status line says why).

The field shown is exactly what the selected robot's observation holds
(:func:`tin_swarm_env.world.fields.fields_at`): its assigned target (with the task's standoff),
the robots in its robot slots, the terrain breaks in its break slots, the assets in its asset
slots, and the height field toward its target's height, on a grid around it; with
``robot=None`` the field is drawn over the whole terrain with every robot and every break as a
source and the first target.

Works in a desktop window (``FieldExplorer("ramp").show()``), in Jupyter with ipympl
(``%matplotlib widget``), and headless: ``tin-swarm explore ramp --png out.png [--cost-to-go]``
(:meth:`FieldExplorer.save_png`) draws a picture without the controls (they do nothing in a
file): the TIN, the selected robot's field (surface and heatmap with its colour bar) and the
cost-to-go to its target over the whole terrain (:data:`COST_MAP_PX` cells across) with a
colour bar in metres. The field heatmap covers the robot's neighbourhood only (1.2 sensor
ranges around it: what it feels); the cost-to-go map is a separate panel over the terrain's
bounds.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..env import parallel_env
from ..errors import ArgumentError, PlacementError
from ..policies import APFPolicy
from ..scenario.config import MAX_CYCLES, MAX_ROBOTS
from ..world.fields import FIELDS
from .args import check_args, opt
from .explorer_controls import ExplorerControls
from .explorer_view import COST_MAP_PX, ExplorerView
from .run import fields_problem

__all__ = ["FieldExplorer", "Args", "explore", "COST_MAP_PX"]


class FieldExplorer(ExplorerControls, ExplorerView):
    """Interactive potential-field explorer over a scenario (see the module docstring)."""

    def __init__(self, scenario="ramp", robot: int | None = 0, fields=FIELDS, n_robots=None, seed=0,
                 grid: int = 41, figsize=(10, 9), cost_to_go: bool = False):
        import matplotlib.pyplot as plt
        from matplotlib.widgets import Button, CheckButtons

        self.env = parallel_env(scenario=scenario, n_robots=n_robots)
        self.fields = list(fields)
        self.robot = robot
        self.seed = seed
        self.grid = grid
        self.show_cost_to_go = bool(cost_to_go)
        self.status = "ready"
        self.policy = APFPolicy(self.env, fields=tuple(self.fields))
        self.obs, _ = self.env.reset(seed=seed)
        self.field_values = None  # (grid, grid) potential of the last drawing
        self.field_forces = None  # (grid, grid, 2)
        self.cost_values = None  # (grid, grid) m, the cost-to-go overlay of the last drawing (None: off)
        self._drag = None  # (kind, index, press xy) while a mouse button is held on a robot/target
        self._armed = None  # "robot": the next left click adds a robot
        self.fig = plt.figure(figsize=figsize)
        self.ax3d = self.fig.add_axes((0.05, 0.50, 0.70, 0.44), projection="3d")
        self.ax_surf = self.fig.add_axes((0.02, 0.07, 0.42, 0.40), projection="3d")
        self.ax_heat = self.fig.add_axes((0.50, 0.09, 0.35, 0.36))
        self.ax_heat_cbar = self.fig.add_axes((0.86, 0.09, 0.012, 0.36))
        self.checks = CheckButtons(self.fig.add_axes((0.80, 0.72, 0.18, 0.22)), list(FIELDS),
                                   [f in self.fields for f in FIELDS])
        self.checks.on_clicked(self.toggle)
        self.run_check = CheckButtons(self.fig.add_axes((0.80, 0.60, 0.18, 0.11)), ["continuous", "cost-to-go"],
                                      [False, self.show_cost_to_go])
        self.run_check.on_clicked(self._on_run_check)
        self.btn_next = Button(self.fig.add_axes((0.80, 0.53, 0.085, 0.05)), "next step")
        self.btn_next.on_clicked(lambda event: self.next_step())
        self.btn_reset = Button(self.fig.add_axes((0.895, 0.53, 0.085, 0.05)), "reset")
        self.btn_reset.on_clicked(lambda event: self.reset())
        self.btn_add = Button(self.fig.add_axes((0.80, 0.47, 0.18, 0.05)), "add robot")
        self.btn_add.on_clicked(lambda event: self._arm("robot"))
        self.widget_axes = [w.ax for w in (self.checks, self.run_check, self.btn_next, self.btn_reset, self.btn_add)]
        self.ax_cost = self.ax_cost_cbar = None  # the PNG's whole-terrain cost-to-go panel (save_png)
        self._status_text = self.fig.text(0.02, 0.01, "", fontsize=8)
        self.fig.canvas.mpl_connect("button_press_event", self._on_press)
        self.fig.canvas.mpl_connect("motion_notify_event", self._on_motion)
        self.fig.canvas.mpl_connect("button_release_event", self._on_release)
        self._timer = None
        self._tin_drawn = False
        self.redraw()

    # -- state changes --------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """Whether "continuous" is on (the timer steps the swarm)."""
        return bool(self.run_check.get_status()[0])

    def toggle(self, name: str):
        """Switch a field on or off (the check box callback)."""
        if name in self.fields:
            self.fields.remove(name)
        else:
            self.fields.append(name)
        self.policy = APFPolicy(self.env, fields=tuple(self.fields))
        self.redraw()

    def next_step(self, draw: bool = True):
        """Every live robot takes one APF step with the fields that are on."""
        if not self.env.agents:
            self._say("the episode is over: reset")
            return
        self.obs, *_ = self.env.step(self.policy.act(self.obs))
        if draw:
            self.redraw()

    def reset(self):
        """The episode from the seed (the robot set stays as it is now)."""
        self.obs, _ = self.env.reset(seed=self.seed)
        self.policy.reset()
        self._say(f"reset (seed {self.seed})")
        self.redraw()

    def select(self, robot: int | None):
        """Show the field felt by ``robot`` (None: every robot over the whole terrain)."""
        if robot is not None and not 0 <= robot < self.env.n:
            raise ArgumentError(f"robot {robot}: the episode has robots 0..{self.env.n - 1}")
        self.robot = robot
        self._say("showing all robots" if robot is None else f"selected robot_{robot}")
        self.redraw()

    def move_robot(self, xy, robot: int | None = None):
        """Put ``robot`` (default: the selected one) at ``xy``; the episode restarts from the
        current positions (refused off traversable ground)."""
        i = self.robot if robot is None else robot
        if i is None:
            return
        pos = self.env.world_state.positions.copy()
        pos[i] = xy
        self._restart(pos, what=f"moved robot_{i}", select=i)

    def move_threat(self, k: int, xy):
        """Put threat/target ``k`` at ``xy``; the episode restarts from the current positions."""
        tg = self.env.world_state.targets.positions.copy()
        tg[k] = xy
        self._restart(targets=tg, what=f"moved target {k}")

    def add_threat(self, xy):
        """Add a threat/target at ``xy``; the episode restarts from the current positions and the
        robots are assigned the targets anew (``i mod m``), so the new one is felt."""
        tg = self.env.world_state.targets.positions
        self._restart(targets=np.vstack([tg, np.asarray(xy, float)[None]]), what="added a target")

    def add_robot(self, xy, heading_rad: float = 0.0):
        """Add a robot at ``xy``. The env's agent set is fixed, so this makes a new env with
        one robot more (the robots still on the terrain plus the new one, last) and resets it
        with the current positions, headings and targets. The new robot is selected."""
        self._restart(new_robot=(np.asarray(xy, float), heading_rad), what="added a robot", select=-1)

    def _restart(self, positions=None, targets=None, new_robot=None, what="", select=None):
        """Reset with the current robots and targets, changed by ``positions (n, 2)`` (every
        current row), ``targets (m, 2)`` and ``new_robot (xy, heading)``. The robots still on
        the terrain are kept, in order (fallen and arrived ones are left out); a new env is
        made when their number differs from the env's. ``select``: the row (old numbering; -1
        the new robot) to select afterwards."""
        s = self.env.world_state
        keep = s.present
        pos = (s.positions if positions is None else np.asarray(positions, float))[keep]
        head = s.headings[keep]
        if new_robot is not None:
            pos, head = np.vstack([pos, new_robot[0][None]]), np.append(head, new_robot[1])
        opts = {"robot_positions": pos, "headings": head,
                "target_positions": s.targets.positions.copy() if targets is None else np.asarray(targets, float)}
        env = self.env if len(pos) == self.env.n else parallel_env(scenario=self.env.config, n_robots=len(pos))
        try:
            obs, _ = env.reset(seed=self.seed, options=opts)
        except PlacementError as exc:
            self._say(f"refused: {exc}")
            self.redraw()
            return
        new_index = np.cumsum(keep) - 1  # old row -> new row (for kept rows)
        sel = self.robot if select is None else select
        if sel is not None:
            sel = len(pos) - 1 if sel == -1 else (int(new_index[sel]) if keep[sel] else 0)
        restarted = env is not self.env
        self.env, self.obs, self.robot = env, obs, sel
        self.policy = APFPolicy(env, fields=tuple(self.fields))
        how = (f"a new env with {env.n} robots (an env's agent set is fixed), reset from the current positions"
               if restarted else "the episode restarted from the current positions")
        self._say(f"{what}: {how}")
        self.redraw()

    def show(self):
        import matplotlib.pyplot as plt

        plt.show()

    def close(self):
        import matplotlib.pyplot as plt

        if self._timer is not None:
            self._timer.stop()
        plt.close(self.fig)


# -- tin-swarm explore -------------------------------------------------------------------------------

def _robot_problem(s: str) -> str | None:
    t = s.strip().lower()
    return None if t == "all" or (t.isdigit() and t.isascii()) else "give a robot index >= 0 or 'all'"


def _png_problem(path: str | None) -> str | None:
    return None if path is None or path.lower().endswith(".png") else "the picture is written as PNG: give a .png path"


@dataclasses.dataclass
class Args:
    """``tin-swarm explore``: every option, its help and what it accepts (checked when built)."""

    scenario: str = opt("ramp", "built-in scenario name or a .toml path")
    png: str | None = opt(None, "draw into this .png file instead of opening a window", check=_png_problem)
    robot: str = opt("0", "robot index whose field is shown, or 'all' (every robot and break a source)",
                     check=_robot_problem)
    fields: str | None = opt(None, "fields switched on, comma-separated, e.g. robot,target,break (default: all of "
                             + ",".join(FIELDS) + ")", check=fields_problem)
    robots: int | None = opt(None, "number of robots (default: the scenario's)", lo=1, hi=MAX_ROBOTS)
    steps: int = opt(0, "APF steps to take before drawing (at most the scenario's max_cycles)", lo=0, hi=MAX_CYCLES)
    seed: int = opt(0, "reset seed", lo=0)
    cost_to_go: bool = opt(False, "overlay contours of the selected robot's target's cost-to-go (m of drivable path)",
                           flag=True)

    def __post_init__(self):
        check_args(self)

    @property
    def robot_index(self) -> int | None:
        """``--robot`` as an index, None for ``all``."""
        return None if self.robot.strip().lower() == "all" else int(self.robot)


def explore(a: Args) -> int:
    """``tin-swarm explore``: the explorer after ``a.steps`` APF steps, in a window or into ``a.png``."""
    import matplotlib

    from .._atomic import atomic_path, check_outputs
    from ..scenario.config import load_scenario
    from .run import parse_fields

    fields = parse_fields(a.fields, FIELDS)
    robot = a.robot_index
    cfg = load_scenario(a.scenario)
    n = a.robots or cfg.robots.count
    if a.steps > cfg.max_cycles:
        raise ArgumentError(f"--steps {a.steps}: the episode ends after the scenario's max_cycles = {cfg.max_cycles} "
                            "steps")
    if robot is not None and robot >= n:
        raise ArgumentError(f"--robot {robot}: the scenario has robots 0..{n - 1}")
    check_outputs({"--png": a.png}, scenarios=(a.scenario,))
    if a.png:
        matplotlib.use("Agg")
    ex = FieldExplorer(a.scenario, robot=robot, fields=fields, n_robots=a.robots, seed=a.seed,
                       cost_to_go=a.cost_to_go)
    for _ in range(a.steps):
        ex.next_step(draw=False)
    ex.redraw()
    if a.png:
        with atomic_path(a.png) as tmp:
            ex.save_png(tmp)
        print(f"wrote {a.png}")
        ex.close()
    else:
        ex.show()
    return 0
