"""The field explorer: the thesis's MATLAB tool (4.1, figures 4.1-4.3) rebuilt with matplotlib.

Top: the TIN in 3D, too-steep triangles white and safe ones grey, robots (orange) and
threats/targets (red) on it. Bottom: the potential field felt by the selected robot, as a
surface (left) and as a heatmap with force arrows (right). Check boxes switch each of the four
fields on and off; buttons take the next step, run continuously (a timer; interactive backends
only) and reset. Clicking on the heatmap moves the selected robot there (left button) or adds a
threat/target there (right button).

Works in a desktop window (``FieldExplorer("ramp").show()``), in Jupyter with ipympl
(``%matplotlib widget``), and headless: ``tin-swarm explore ramp --png out.png`` draws the same
views into a file (Agg).

It drives the env through its public API only: moving a robot or adding a threat resets the
episode with the current positions (reset options ``robot_positions``, ``headings``,
``target_positions``), so an added threat is assigned to robots (``i mod m``) and felt.

The field shown is what the selected robot feels (:func:`tin_swarm_env.world.fields.fields_at`):
its own target (with the task's standoff), the robots it currently sees, the dangerous terrain
breaks within its sensor range, and the height field toward its target's height, evaluated on a
grid around it; with ``robot=None`` the field is drawn over the whole terrain with every robot
as a source and the first target.
"""

from __future__ import annotations

import numpy as np

from ..env import parallel_env
from ..errors import PlacementError
from ..policies import APFPolicy
from ..world.fields import FIELDS, fields_at

__all__ = ["FieldExplorer"]


class FieldExplorer:
    """Interactive potential-field explorer over a scenario (see the module docstring)."""

    def __init__(self, scenario="ramp", robot: int | None = 0, fields=FIELDS, n_robots=None, seed=0,
                 grid: int = 41, figsize=(10, 9)):
        import matplotlib.pyplot as plt
        from matplotlib.widgets import Button, CheckButtons

        self.env = parallel_env(scenario=scenario, n_robots=n_robots)
        self.fields = list(fields)
        self.robot = robot
        self.seed = seed
        self.grid = grid
        self.policy = APFPolicy(self.env, fields=tuple(self.fields))
        self.obs, _ = self.env.reset(seed=seed)
        self.field_values = None  # (grid, grid) potential of the last drawing
        self.field_forces = None  # (grid, grid, 2)
        self.fig = plt.figure(figsize=figsize)
        self.ax3d = self.fig.add_axes((0.05, 0.50, 0.70, 0.44), projection="3d")
        self.ax_surf = self.fig.add_axes((0.02, 0.05, 0.42, 0.42), projection="3d")
        self.ax_heat = self.fig.add_axes((0.50, 0.07, 0.35, 0.38))
        ax_chk = self.fig.add_axes((0.80, 0.70, 0.18, 0.20))
        self.checks = CheckButtons(ax_chk, list(FIELDS), [f in self.fields for f in FIELDS])
        self.checks.on_clicked(self.toggle)
        ax_run = self.fig.add_axes((0.80, 0.62, 0.18, 0.06))
        self.run_check = CheckButtons(ax_run, ["continuous"], [False])
        self.run_check.on_clicked(self._toggle_run)
        self.btn_next = Button(self.fig.add_axes((0.80, 0.55, 0.085, 0.05)), "next step")
        self.btn_next.on_clicked(lambda event: self.next_step())
        self.btn_reset = Button(self.fig.add_axes((0.895, 0.55, 0.085, 0.05)), "reset")
        self.btn_reset.on_clicked(lambda event: self.reset())
        self.fig.canvas.mpl_connect("button_press_event", self._on_click)
        self._timer = None
        self._tin_drawn = False
        self.redraw()

    # -- state changes --------------------------------------------------------------------
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
            return
        self.obs, *_ = self.env.step(self.policy.act(self.obs))
        if draw:
            self.redraw()

    def reset(self):
        self.obs, _ = self.env.reset(seed=self.seed)
        self.redraw()

    def move_robot(self, xy):
        """Put the selected robot at ``xy`` (ignored outside or on too-steep ground); the
        episode restarts from the current positions."""
        if self.robot is None:
            return
        pos = self.env.world_state.positions.copy()
        pos[self.robot] = xy
        self._replace(robot_positions=pos)

    def add_threat(self, xy):
        """Add a threat/target at ``xy`` (ignored outside or on too-steep ground); the episode
        restarts from the current positions and robots are assigned the targets anew."""
        tg = self.env.world_state.targets.positions
        self._replace(target_positions=np.vstack([tg, np.asarray(xy, float)[None]]))

    def _replace(self, **options):
        """Reset the env with the current robots and targets, changed by ``options``."""
        s = self.env.world_state
        opts = {"robot_positions": s.positions.copy(), "headings": s.headings.copy(),
                "target_positions": s.targets.positions.copy(), **options}
        try:
            self.obs, _ = self.env.reset(options=opts)
        except PlacementError:
            return
        self.redraw()

    def _toggle_run(self, label):
        if self._timer is None:
            self._timer = self.fig.canvas.new_timer(interval=100)
            self._timer.add_callback(self.next_step)
        if self.run_check.get_status()[0]:
            self._timer.start()
        else:
            self._timer.stop()

    def _on_click(self, event):
        if event.inaxes is not self.ax_heat or event.xdata is None:
            return
        if event.button == 1:
            self.move_robot((event.xdata, event.ydata))
        elif event.button == 3:
            self.add_threat((event.xdata, event.ydata))

    # -- the field -----------------------------------------------------------------------------
    def compute_field(self):
        """The selected robot's field on a grid: ``(X, Y, potential, force)``."""
        env, w, s = self.env, self.env.world, self.env.world_state
        pol = self.policy
        R = w.params.sensor.range_m
        x0, y0, x1, y1 = w.tin.bounds
        if self.robot is None:
            gx, gy = np.linspace(x0, x1, self.grid), np.linspace(y0, y1, self.grid)
            robots = s.positions[s.present]
            target = s.targets.positions[0] if len(s.targets) else None
        else:
            i = self.robot
            c = s.positions[i]
            half = 1.2 * R
            gx = np.linspace(max(x0, c[0] - half), min(x1, c[0] + half), self.grid)
            gy = np.linspace(max(y0, c[1] - half), min(y1, c[1] + half), self.grid)
            seen = env.sensed().robots
            robots = s.positions[seen.target[seen.observer == i]]
            k = env.target_assignment[i]
            target = s.targets.positions[k] if k >= 0 and len(s.targets) else None
        X, Y = np.meshgrid(gx, gy)
        pts = np.column_stack([X.ravel(), Y.ravel()])
        z_t = None
        if target is not None:
            tt = w.tin.locate(np.asarray(target)[None])
            z_t = float(w.tin.height_in(np.asarray(target)[None], tt)[0])
        out = fields_at(pts, pol.params, robots=robots, target=target, standoff_m=pol.standoff_m,
                        breaks=w.breaks, tin=w.tin, z_target=z_t)
        f, u = out["total"]
        return X, Y, u.reshape(X.shape), f.reshape(*X.shape, 2)

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

    def redraw(self):
        env, s = self.env, self.env.world_state
        if not self._tin_drawn:
            self._draw_tin()
        ax = self.ax3d
        for a in getattr(self, "_dyn", []):
            a.remove()
        self._dyn = []
        on = s.present
        lift = 0.5
        self._dyn.append(ax.scatter(s.positions[on, 0], s.positions[on, 1], s.heights[on] + lift, c="orange",
                                    s=12, depthshade=False))
        if len(s.targets):
            tz = env.world.tin.height_in(s.targets.positions, s.targets.tri_idx)
            self._dyn.append(ax.scatter(s.targets.positions[:, 0], s.targets.positions[:, 1], tz + lift, c="red",
                                        s=40, marker="*", depthshade=False))
        X, Y, U, F = self.compute_field()
        self.field_values, self.field_forces = U, F
        self.ax_surf.clear()
        self.ax_surf.plot_surface(X, Y, U, cmap="viridis", linewidth=0, antialiased=False)
        self.ax_surf.set_title("potential (surface)")
        h = self.ax_heat
        h.clear()
        h.imshow(U, origin="lower", extent=(X.min(), X.max(), Y.min(), Y.max()), cmap="viridis", aspect="auto")
        step = max(1, self.grid // 15)
        h.quiver(X[::step, ::step], Y[::step, ::step], F[::step, ::step, 0], F[::step, ::step, 1], color="white",
                 scale=None)
        if self.robot is not None:
            h.plot(*s.positions[self.robot], "o", color="orange", mec="k")
        h.plot(s.positions[on, 0], s.positions[on, 1], ".", color="orange", ms=3)
        if len(s.targets):
            h.plot(s.targets.positions[:, 0], s.targets.positions[:, 1], "r*", ms=10)
        h.set_xlim(X.min(), X.max())
        h.set_ylim(Y.min(), Y.max())
        who = "all robots" if self.robot is None else f"robot_{self.robot}"
        h.set_title(f"field felt by {who}: {', '.join(self.fields) or 'none'} (step {env.steps})", fontsize=9)
        self.fig.canvas.draw_idle()

    def show(self):
        import matplotlib.pyplot as plt

        plt.show()

    def close(self):
        import matplotlib.pyplot as plt

        plt.close(self.fig)
