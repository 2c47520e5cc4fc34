"""The field explorer's controls (:class:`~tin_swarm_env.apps.explorer.FieldExplorer`): the status
line, the check boxes' and buttons' callbacks, the timer of "continuous", and the mouse on the
heatmap (click to select or move a robot, drag a robot or a threat/target, right click to add one,
the "add robot" click). Every change of the world goes through the explorer's own methods
(``select``, ``move_robot``, ``move_threat``, ``add_threat``, ``add_robot``, ``next_step``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["ExplorerControls", "PICK_FRACTION"]

PICK_FRACTION = 0.03  # a press within this share of the heatmap's width picks a robot or a target


class ExplorerControls:
    """The widgets' and the mouse's callbacks of :class:`~tin_swarm_env.apps.explorer.FieldExplorer`
    (a mixin: it uses the explorer's figure, axes, env and world-changing methods)."""

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
