"""Rendering: a hillshaded TIN drawn once, robots stamped onto a copy each frame.

The terrain (hillshade over a height colour map, too-steep triangles white as in the thesis's
MATLAB tool, cliff edges red, other breaks brown) is drawn once with matplotlib's Agg canvas;
each frame copies that image and stamps targets (red), assets (blue) and robots (active
orange, out of battery grey, fallen black; robots that arrived have left) with a heading
tick, and optionally the edges of each robot's sensor cone, with numpy indexing: the cost
per frame grows with the robots, not with the terrain, and stays far below a world step.

Decorations (``decorations=True``, the env's ``render_decorations``): a legend (too-steep
ground, cliff edges, other breaks, robots by status, targets, assets, sensor cones when drawn)
and a scale bar drawn once into the background, and a title strip above the terrain, redrawn
only when its text changes: the scenario's name, the step, and how many robots arrived, fell
and ran out of battery. Off, a frame is the bare terrain (for training videos).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Viewer"]

ORANGE = np.array([255, 140, 0], np.uint8)
GREY = np.array([130, 130, 130], np.uint8)
BLACK = np.array([0, 0, 0], np.uint8)
RED = np.array([220, 20, 30], np.uint8)
BLUE = np.array([30, 80, 230], np.uint8)
CONE = np.array([255, 230, 120], np.uint8)


def _disc(r):
    d = np.arange(-r, r + 1)
    yy, xx = np.meshgrid(d, d, indexing="ij")
    keep = xx * xx + yy * yy <= r * r + r
    return yy[keep], xx[keep]


class Viewer:
    def __init__(self, world, width_px: int, sensor_cones: bool = False, decorations: bool = True,
                 name: str = ""):
        from matplotlib import colormaps
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection, PolyCollection
        from matplotlib.figure import Figure

        from ..terrain import ANGLE, STEEP

        tin = world.tin
        self.world = world
        self.sensor_cones = sensor_cones
        x0, y0, x1, y1 = tin.bounds
        self.bounds = (x0, y0, x1, y1)
        W = int(width_px)
        H = int(np.clip(round(W * (y1 - y0) / max(x1 - x0, 1e-9)), 120, 4 * W))
        self.size = (H, W)
        fig = Figure(figsize=(W / 100, H / 100), dpi=100)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.axis("off")
        az, alt = np.radians(315.0), np.radians(45.0)
        light = np.array([np.cos(alt) * np.sin(az), np.cos(alt) * np.cos(az), np.sin(alt)])
        shade = np.clip(tin.normals @ light, 0, 1)
        zc = tin.vertices[tin.triangles, 2].mean(axis=1)
        zr = np.ptp(zc)
        base = colormaps["gist_earth"](0.25 + 0.6 * ((zc - zc.min()) / zr if zr > 0 else np.zeros_like(zc)))[:, :3]
        col = base * (0.35 + 0.65 * shade)[:, None]
        steep = world.steep
        col[steep] = (0.8 + 0.2 * shade[steep])[:, None] * np.ones(3)
        polys = tin.vertices[tin.triangles][:, :, :2]
        ax.add_collection(PolyCollection(polys, facecolors=col, edgecolors="none", antialiased=False))
        br = world.breaks
        for kind, color, lw in ((ANGLE, (0.45, 0.3, 0.15), 0.5), (STEEP, (0.85, 0.1, 0.1), 1.2)):
            seg = br.segments[br.kinds == kind][:, :, :2]
            if len(seg):
                ax.add_collection(LineCollection(seg, colors=[color], linewidths=lw))
        if decorations:
            _legend(ax, world.params.robot.max_slope_deg, sensor_cones)
            _scale_bar(ax, x1 - x0, y1 - y0)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        self.background = np.asarray(canvas.buffer_rgba())[..., :3].copy()
        self._disc3 = _disc(3)
        self._disc5 = _disc(5)
        self._fig = None
        self.name = name
        self._title = _TitleStrip(W) if decorations else None

    def title(self, state) -> str:
        """The title strip's text for ``state``."""
        from ..world import Reason

        st = state.status
        return (f"{self.name}   step {state.step}   robots {len(st)}: arrived {int((st == Reason.ARRIVED).sum())}, "
                f"fell {int((st == Reason.FELL).sum())}, battery {int((st == Reason.BATTERY).sum())}")

    def to_px(self, xy):
        x0, y0, x1, y1 = self.bounds
        H, W = self.size
        c = (xy[..., 0] - x0) / (x1 - x0) * (W - 1)
        r = (1 - (xy[..., 1] - y0) / (y1 - y0)) * (H - 1)
        return np.rint(r).astype(np.int64), np.rint(c).astype(np.int64)

    def _stamp(self, img, r, c, color, disc):
        if len(r) == 0:
            return
        dr, dc = disc
        rr = (r[:, None] + dr[None]).ravel()
        cc = (c[:, None] + dc[None]).ravel()
        H, W = self.size
        ok = (rr >= 0) & (rr < H) & (cc >= 0) & (cc < W)
        col = np.broadcast_to(color, (len(r), 3)) if color.ndim == 1 else color
        img[rr[ok], cc[ok]] = np.repeat(col, len(dr), axis=0)[ok]

    def _lines(self, img, a, b, color, n=24):
        if len(a) == 0:
            return
        t = np.linspace(0, 1, n)
        p = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
        r, c = self.to_px(p.reshape(-1, 2))
        H, W = self.size
        ok = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        img[r[ok], c[ok]] = color

    def frame(self, state) -> np.ndarray:
        """An ``(H, W, 3)`` uint8 picture of ``state``."""
        from ..world import Reason

        img = self.background.copy()
        P = self.world.params
        pos, h = state.positions, state.headings
        if self.sensor_cones:
            act = state.status == Reason.NONE
            half = np.radians(P.sensor.fov_deg) / 2
            for s in (-half, half):
                a = pos[act]
                d = P.sensor.range_m * np.column_stack([np.cos(h[act] + s), np.sin(h[act] + s)])
                self._lines(img, a, a + d, CONE)
        if len(state.targets):
            self._stamp(img, *self.to_px(state.targets.positions), RED, self._disc5)
        if len(state.assets):
            self._stamp(img, *self.to_px(state.assets.positions), BLUE, self._disc5)
        shown = state.status != Reason.ARRIVED  # robots the task took off the terrain are not drawn
        pos, h, status = pos[shown], h[shown], state.status[shown]
        colors = np.where((status == Reason.NONE)[:, None], ORANGE,
                          np.where((status == Reason.BATTERY)[:, None], GREY, BLACK)).astype(np.uint8)
        r, c = self.to_px(pos)
        self._stamp(img, r, c, colors, self._disc3)
        x0, y0, x1, y1 = self.bounds
        px_m = (x1 - x0) / self.size[1]
        tick = 7 * px_m * np.column_stack([np.cos(h), np.sin(h)])
        self._lines(img, pos, pos + tick, BLACK, n=8)
        if self._title is not None:
            img = np.concatenate([self._title.render(self.title(state)), img], axis=0)
        return img

    def show(self, img):
        """Show a frame in a matplotlib window (``render_mode="human"``)."""
        import matplotlib.pyplot as plt

        if self._fig is None or not plt.fignum_exists(self._fig.number):
            self._fig, ax = plt.subplots(figsize=(self.size[1] / 100, self.size[0] / 100), dpi=100)
            ax.axis("off")
            self._im = ax.imshow(img)
            self._fig.tight_layout(pad=0)
        else:
            self._im.set_data(img)
        self._fig.canvas.draw_idle()
        plt.pause(0.001)

    def close(self):
        if self._fig is not None:
            import matplotlib.pyplot as plt

            plt.close(self._fig)
            self._fig = None


def _legend(ax, max_slope_deg, sensor_cones):
    """What each colour means, in the terrain's top right corner."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def dot(color, label, marker="o"):
        return Line2D([], [], ls="none", marker=marker, ms=5, mfc=color, mec=color, label=label)

    h = [Patch(fc=(0.92, 0.92, 0.92), ec="0.5", lw=0.5, label=f"too steep (> {max_slope_deg:.0f} deg)"),
         Line2D([], [], color=(0.85, 0.1, 0.1), lw=1.2, label="cliff edge / steep break"),
         Line2D([], [], color=(0.45, 0.3, 0.15), lw=0.8, label="slope break"),
         dot(ORANGE / 255, "robot"), dot(GREY / 255, "robot, battery empty"), dot(BLACK / 255, "robot, fell"),
         dot(RED / 255, "target / threat"), dot(BLUE / 255, "asset")]
    if sensor_cones:
        h.append(Line2D([], [], color=CONE / 255, lw=1.0, label="sensor cone"))
    ax.legend(handles=h, loc="upper right", fontsize=6, framealpha=0.8, borderpad=0.4, labelspacing=0.3,
              handlelength=1.4)


def _scale_bar(ax, width_m, height_m):
    """A bar of a round length (1, 2 or 5 times a power of ten, at most a fifth of the width)."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    top = 0.2 * width_m
    p = 10.0 ** np.floor(np.log10(top))
    length = max(m * p for m in (1, 2, 5) if m * p <= top)
    bar = AnchoredSizeBar(ax.transData, length, f"{length:g} m", loc="lower left", pad=0.4, sep=3,
                          size_vertical=0.008 * height_m, color="black", frameon=True, fontproperties={"size": 7})
    bar.patch.set_alpha(0.8)
    ax.add_artist(bar)


class _TitleStrip:
    """A white strip of text, ``W`` pixels wide, rendered by Agg when its text changes."""

    HEIGHT_PX = 20

    def __init__(self, width_px: int):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self._fig = Figure(figsize=(width_px / 100, self.HEIGHT_PX / 100), dpi=100, facecolor="white")
        self._text = self._fig.text(0.01, 0.5, "", va="center", ha="left", fontsize=8)
        self._canvas = FigureCanvasAgg(self._fig)
        self._last = (None, None)

    def render(self, text: str) -> np.ndarray:
        """``(HEIGHT_PX, W, 3)`` uint8."""
        if self._last[0] != text:
            self._text.set_text(text)
            self._canvas.draw()
            self._last = (text, np.asarray(self._canvas.buffer_rgba())[..., :3].copy())
        return self._last[1]
