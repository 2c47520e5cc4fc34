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
from ..scenario.config import MAX_ROBOTS
from ..world.fields import FIELDS, fields_at
from .args import check_args, opt
from .run import fields_problem

__all__ = ["FieldExplorer", "Args", "explore"]

PICK_FRACTION = 0.03  # a press within this share of the heatmap's width picks a robot or a target
COST_MAP_PX = 121  # cells across the whole-terrain cost-to-go map of the PNG


class FieldExplorer:
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

    def _say(self, text: str):
        self.status = text
        self._status_text.set_text(text)

    def _arm(self, what):
        self._armed = what
        self._say("click on the heatmap to place the new robot")
        self.fig.canvas.draw_idle()

    def _on_run_check(self, label):
        if label == "cost-to-go":
            self.show_cost_to_go = bool(self.run_check.get_status()[1])
            self.redraw()
            return
        if self._timer is None:
            self._timer = self.fig.canvas.new_timer(interval=100)
            self._timer.add_callback(self._tick)
        if self.running:
            self._timer.start()
        else:
            self._timer.stop()

    def _tick(self):
        """The timer's callback: one step while "continuous" is on."""
        if self.running:
            self.next_step()

    # -- mouse ----------------------------------------------------------------------------------
    def _pick(self, xy):
        """``("robot", i)`` or ``("target", k)`` under ``xy`` on the heatmap, else None."""
        x0, x1 = self.ax_heat.get_xlim()
        tol = PICK_FRACTION * abs(x1 - x0)
        s = self.env.world_state
        best = None
        for kind, pts, ok in (("robot", s.positions, s.present),
                              ("target", s.targets.positions, np.ones(len(s.targets), bool))):
            if not ok.any():
                continue
            d = np.where(ok, np.hypot(*(pts - xy).T), np.inf)
            j = int(np.argmin(d))
            if d[j] <= tol and (best is None or d[j] < best[2]):
                best = (kind, j, d[j])
        return None if best is None else best[:2]

    def _on_press(self, event):
        if event.inaxes is not self.ax_heat or event.xdata is None:
            return
        xy = np.array([event.xdata, event.ydata])
        if event.button == 3:
            self.add_threat(xy)
        elif event.button == 1:
            if self._armed == "robot":
                self._armed = None
                self.add_robot(xy)
                return
            hit = self._pick(xy)
            self._drag = (*hit, xy) if hit else None
            if hit is None:
                self.move_robot(xy)

    def _on_motion(self, event):
        if self._drag is None or event.inaxes is not self.ax_heat or event.xdata is None:
            return
        self._drag_marker(event.xdata, event.ydata)

    def _on_release(self, event):
        if self._drag is None:
            return
        kind, j, start = self._drag
        self._drag = None
        self._drag_marker(None, None)
        xy = np.array([event.xdata, event.ydata]) if event.inaxes is self.ax_heat and event.xdata is not None \
            else start
        moved = np.hypot(*(xy - start)) > 1e-9
        if kind == "robot" and not moved:
            self.select(j)
        elif kind == "robot":
            self.move_robot(xy, j)
        elif moved:
            self.move_threat(j, xy)

    def _drag_marker(self, x, y):
        """The ghost that follows the mouse while dragging (removed with ``x`` None)."""
        m = getattr(self, "_ghost", None)
        if m is not None:
            m.remove()
            self._ghost = None
        if x is not None:
            self._ghost = self.ax_heat.plot([x], [y], "o", mfc="none", mec="white", ms=12)[0]
        self.fig.canvas.draw_idle()

    # -- the field -----------------------------------------------------------------------------
    def sensed_sources(self, i: int) -> dict:
        """What robot ``i``'s observation holds, in world coordinates: ``robots (k, 2)`` in its
        robot slots, ``breaks`` (a :class:`~tin_swarm_env.terrain.Breaks` of its break slots),
        ``assets (a, 2)`` in its asset slots and its assigned ``target (2,)`` (None)."""
        env, s = self.env, self.env.world_state
        seen, lay, n = env.sensed(), env.layout, env.n
        r_idx = seen.robots.nearest(n, lay.k_robots)[0][i]
        b_idx = seen.breaks.nearest(n, lay.k_breaks)[0][i]
        a_idx = seen.assets.nearest(n, lay.k_assets)[0][i]
        br = env.world.breaks
        b = b_idx[b_idx >= 0]
        breaks = type(br)(**{f.name: getattr(br, f.name)[b] for f in dataclasses.fields(br)})
        k = env.target_assignment[i]
        target = s.targets.positions[k] if k >= 0 and len(s.targets) else None
        return {"robots": s.positions[r_idx[r_idx >= 0]], "breaks": breaks,
                "assets": s.assets.positions[a_idx[a_idx >= 0]], "target": target}

    def _grid(self):
        x0, y0, x1, y1 = self.env.tin.bounds
        if self.robot is None:
            return np.linspace(x0, x1, self.grid), np.linspace(y0, y1, self.grid)
        c = self.env.world_state.positions[self.robot]
        half = 1.2 * self.env.world.params.sensor.range_m
        return (np.linspace(max(x0, c[0] - half), min(x1, c[0] + half), self.grid),
                np.linspace(max(y0, c[1] - half), min(y1, c[1] + half), self.grid))

    def compute_field(self):
        """The selected robot's field on a grid: ``(X, Y, potential, force)``."""
        w, s = self.env.world, self.env.world_state
        if self.robot is None:
            src = {"robots": s.positions[s.present], "breaks": w.breaks, "assets": s.assets.positions,
                   "target": s.targets.positions[0] if len(s.targets) else None}
        else:
            src = self.sensed_sources(self.robot)
        X, Y = np.meshgrid(*self._grid())
        pts = np.column_stack([X.ravel(), Y.ravel()])
        z_t = None
        if src["target"] is not None:
            z_t = float(w.tin.height_at(np.asarray(src["target"])[None])[0])
        pol = self.policy
        out = fields_at(pts, pol.params, robots=src["robots"], target=src["target"], standoff_m=pol.shield.standoff_m,
                        breaks=src["breaks"], tin=w.tin, z_target=z_t, assets=src["assets"], guard_m=pol.shield.guard_m)
        f, u = out["total"]
        return X, Y, u.reshape(X.shape), f.reshape(*X.shape, 2)

    def _target_index(self) -> int:
        """The selected robot's assigned target (target 0 for ``robot=None``; -1: none)."""
        if not len(self.env.world_state.targets):
            return -1
        return 0 if self.robot is None else int(self.env.target_assignment[self.robot])

    def target_of_selected(self):
        """``(2,)`` the selected robot's assigned target (the first target for ``robot=None``), or None."""
        k = self._target_index()
        return None if k < 0 else self.env.world_state.targets.positions[k]

    def compute_cost_to_go(self, X, Y):
        """``(grid, grid)`` m: the drivable-path distance to the selected robot's target over the
        grid (``inf`` where it cannot be reached), or None without a target. It is the env's own
        field (:attr:`~tin_swarm_env.env.TinSwarmEnv.target_fields`, the reward's metric), built
        at the target's position at reset: a mobile target has moved on since."""
        k = self._target_index()
        if k < 0:
            return None
        field = self.env.target_fields[k]
        return field.distance_at(np.column_stack([X.ravel(), Y.ravel()])).reshape(X.shape)

    # -- drawing ----------------------------------------------------------------------------
    def _draw_tin(self):
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        w = self.env.world
        tin = w.tin
        ax = self.ax3d
        ax.clear()
        shade = np.clip(tin.normals @ np.array([-0.4, 0.4, 0.82]), 0.3, 1.0)
        col = np.where(w.steep[:, None], np.ones(3), 0.55 * np.ones(3)) * shade[:, None]
        col[w.steep] = 0.85 + 0.15 * shade[w.steep][:, None]
        ax.add_collection3d(Poly3DCollection(tin.vertices[tin.triangles], facecolors=col, edgecolors="none"))
        x0, y0, x1, y1 = tin.bounds
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        z = tin.vertices[:, 2]
        ax.set_zlim(z.min(), z.max() + 1e-6 + 0.3 * (x1 - x0 + y1 - y0) / 20)
        ax.set_title(f"{self.env.config.name}: white = too steep (> {w.params.robot.max_slope_deg:.0f} deg)")
        self._tin_drawn = True

    def _draw_entities_3d(self):
        env, s, ax = self.env, self.env.world_state, self.ax3d
        for a in getattr(self, "_dyn", []):
            a.remove()
        self._dyn = []
        on = s.present
        lift = 0.5
        tin = env.tin
        self._dyn.append(ax.scatter(s.positions[on, 0], s.positions[on, 1], s.heights[on] + lift, c="orange",
                                    s=12, depthshade=False))
        if self.robot is not None:
            p = s.positions[self.robot]
            self._dyn.append(ax.scatter([p[0]], [p[1]], [s.heights[self.robot] + lift], facecolors="none",
                                        edgecolors="k", s=60, depthshade=False))
        for ent, color, mark in ((s.targets, "red", "*"), (s.assets, "blue", "s")):
            if len(ent):
                z = tin.height_in(ent.positions, ent.tri_idx)
                self._dyn.append(ax.scatter(ent.positions[:, 0], ent.positions[:, 1], z + lift, c=color, s=40,
                                            marker=mark, depthshade=False))

    def redraw(self):
        env, s = self.env, self.env.world_state
        if not self._tin_drawn or getattr(self, "_drawn_tin", None) is not env.tin:
            self._draw_tin()
            self._drawn_tin = env.tin
        self._draw_entities_3d()
        X, Y, U, F = self.compute_field()
        self.field_values, self.field_forces = U, F
        self.ax_surf.clear()
        self.ax_surf.plot_surface(X, Y, U, cmap="viridis", linewidth=0, antialiased=False)
        self.ax_surf.set_title("potential (surface)")
        h = self.ax_heat
        h.clear()
        self._ghost = None
        im = h.imshow(U, origin="lower", extent=(X.min(), X.max(), Y.min(), Y.max()), cmap="viridis", aspect="auto")
        self.ax_heat_cbar.clear()
        self.fig.colorbar(im, cax=self.ax_heat_cbar).set_label("potential", fontsize=7)
        self.ax_heat_cbar.tick_params(labelsize=6)
        step = max(1, self.grid // 15)
        h.quiver(X[::step, ::step], Y[::step, ::step], F[::step, ::step, 0], F[::step, ::step, 1], color="white",
                 scale=None)
        self.cost_values = self.compute_cost_to_go(X, Y) if self.show_cost_to_go else None
        if self.cost_values is not None and np.isfinite(self.cost_values).any():
            cs = h.contour(X, Y, np.where(np.isfinite(self.cost_values), self.cost_values, np.nan), levels=10,
                           colors="magenta", linewidths=0.8)
            h.clabel(cs, fontsize=6, fmt="%.0f m")
        on = s.present
        h.plot(s.positions[on, 0], s.positions[on, 1], ".", color="orange", ms=3)
        if self.robot is not None:
            h.plot(*s.positions[self.robot], "o", color="orange", mec="k")
        if len(s.targets):
            h.plot(s.targets.positions[:, 0], s.targets.positions[:, 1], "r*", ms=10)
        if len(s.assets):
            h.plot(s.assets.positions[:, 0], s.assets.positions[:, 1], "bs", ms=6)
        h.set_xlim(X.min(), X.max())
        h.set_ylim(Y.min(), Y.max())
        who = "all robots" if self.robot is None else f"robot_{self.robot}"
        ctg = ", cost-to-go (m, magenta)" if self.cost_values is not None else ""
        h.set_title(f"field felt by {who}: {', '.join(self.fields) or 'none'}{ctg} (step {env.steps})", fontsize=8)
        self._status_text.set_text(f"{env.n} robots, {len(s.targets)} target{'' if len(s.targets) == 1 else 's'}, step {env.steps}: {self.status}")
        self.fig.canvas.draw_idle()

    def cost_to_go_map(self, cells: int = COST_MAP_PX):
        """``(X, Y, C)``: the cost-to-go (m) to the selected robot's target on a grid over the
        whole terrain (``cells`` across the longer side; ``inf`` where unreachable), or None
        without a target."""
        x0, y0, x1, y1 = self.env.tin.bounds
        long = max(x1 - x0, y1 - y0)
        nx, ny = (max(2, round(cells * (b - a) / long)) for a, b in ((x0, x1), (y0, y1)))
        X, Y = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
        C = self.compute_cost_to_go(X, Y)
        return None if C is None else (X, Y, C)

    def save_png(self, path):
        """Write the picture (PNG) without the controls: they are taken off the figure (the
        explorer is no longer interactive afterwards) and the cost-to-go over the whole terrain
        takes their place, with a colour bar (m); see the module docstring."""
        for ax in self.widget_axes:
            ax.remove()
        self.widget_axes = []
        self.ax3d.set_position((0.0, 0.52, 0.52, 0.44))
        self.ax_cost = self.fig.add_axes((0.58, 0.55, 0.30, 0.38))
        self.ax_cost_cbar = self.fig.add_axes((0.90, 0.55, 0.012, 0.38))
        self._draw_cost_map()
        self.fig.savefig(path, format="png")

    def _draw_cost_map(self):
        from matplotlib import colormaps

        ax, s = self.ax_cost, self.env.world_state
        x0, y0, x1, y1 = self.env.tin.bounds
        got = self.cost_to_go_map()
        k = self._target_index()
        if got is None:
            ax.text(0.5, 0.5, "no target: no cost-to-go", ha="center", va="center", transform=ax.transAxes)
            self.ax_cost_cbar.set_visible(False)
        else:
            X, Y, C = got
            cmap = colormaps["magma_r"].with_extremes(bad=(0.85, 0.85, 0.85))
            im = ax.imshow(np.where(np.isfinite(C), C, np.nan), origin="lower", extent=(x0, x1, y0, y1), cmap=cmap,
                           aspect="equal", interpolation="nearest")
            self.fig.colorbar(im, cax=self.ax_cost_cbar).set_label("cost-to-go (m of drivable path)", fontsize=7)
            self.ax_cost_cbar.tick_params(labelsize=6)
            g = s.targets.positions[k]
            ax.plot(*g, "*", color="cyan", mec="k", ms=12)
        on = s.present
        ax.plot(s.positions[on, 0], s.positions[on, 1], ".", color="orange", ms=3)
        if self.robot is not None:
            ax.plot(*s.positions[self.robot], "o", color="orange", mec="k")
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.tick_params(labelsize=6)
        who = "the first target" if self.robot is None else f"robot_{self.robot}'s target"
        ax.set_title(f"cost-to-go to {who} (grey: unreachable)", fontsize=8)

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
    steps: int = opt(0, "APF steps to take before drawing", lo=0)
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
    n = a.robots or load_scenario(a.scenario).robots.count
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
