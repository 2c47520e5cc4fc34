"""What the field explorer (:class:`~tin_swarm_env.apps.explorer.FieldExplorer`) shows: the field
the selected robot feels, built from exactly what its observation holds
(:func:`tin_swarm_env.world.fields.fields_at`), the cost-to-go to its target, and the drawing: the
TIN in 3D, the field as a surface and a heatmap with force arrows, and the PNG with the
whole-terrain cost-to-go map (:data:`COST_MAP_PX` cells across).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..world.fields import fields_at

__all__ = ["ExplorerView", "COST_MAP_PX"]

COST_MAP_PX = 121  # cells across the whole-terrain cost-to-go map of the PNG


class ExplorerView:
    """The field and the drawing of :class:`~tin_swarm_env.apps.explorer.FieldExplorer` (a mixin: it
    reads the explorer's env, policy, selected robot and grid, and draws on its axes)."""

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
