"""Rendering: a hillshaded TIN drawn once, robots stamped onto a copy each frame.

The terrain (hillshade over a height colour map, too-steep triangles light grey as in the
thesis's MATLAB tool, cliff edges red, other breaks brown) is drawn once with matplotlib's Agg
canvas; each frame copies that image and stamps targets, assets and robots with numpy indexing
(the cost per frame grows with the robots, not with the terrain, and stays far below a world
step). Robots by status: active (orange disc with a heading tick), arrived (a cyan ring: they
stay drawn where they arrived), out of battery (grey disc), fallen (black cross); optionally the
edges of each robot's sensor cone.

Every colour a frame can hold is in :data:`PALETTE` (255 colours: the marker colours of
:data:`COLORS`, a grey ramp for text, and the terrain's :data:`HEIGHT_BINS` height colours x
:data:`SHADE_LEVELS` hillshade levels, to which the terrain's triangles are rounded), so a GIF
quantized to it (:mod:`tin_swarm_env.apps.media`) keeps every legend colour exactly.

Decorations (``decorations=True``, the env's ``render_decorations``): a legend, a scale bar, a
title strip above the terrain (the scenario's name, the step, how many robots arrived, fell,
ran out of battery and are active -- on the episode's last frame the still active ones are
counted as timed out) and a height colour bar (m) below it. The legend lists only what the
frame can show: too-steep ground, cliff edges and slope breaks when the terrain has them,
robots, targets and assets when there are any, and arrived / battery-empty / fallen robots from
the first frame that has one (the background is redrawn then, a handful of times per episode).
Off, a frame is the bare terrain (for training videos).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Viewer", "COLORS", "PALETTE", "HEIGHT_BINS", "SHADE_LEVELS"]

# One home for the frame colours: name -> RGB (the legend, the stamps and the GIF palette use these).
COLORS = {
    "robot": (255, 140, 0),  # active (orange)
    "arrived": (0, 220, 255),  # cyan ring
    "battery": (128, 128, 128),  # grey disc
    "fell": (0, 0, 0),  # black cross
    "target": (190, 0, 255),  # violet disc with a white ring
    "asset": (30, 80, 230),  # blue
    "cliff": (220, 20, 20),  # cliff edges / steep breaks
    "slope_break": (115, 75, 40),  # other breaks (brown)
    "cone": (255, 230, 120),  # sensor cone edges
    "white": (255, 255, 255),
}
HEIGHT_BINS = 14  # terrain height colours (the colour bar's steps)
SHADE_LEVELS = 12  # hillshade levels of each height colour and of too-steep grey
_GREYS = 16  # grey ramp for text and the legend's frame
_AMBIENT = 0.35  # hillshade: colour x (_AMBIENT + (1 - _AMBIENT) x shade level)


def _height_colors() -> np.ndarray:
    """``(HEIGHT_BINS, 3)`` float: the unshaded colour of each height bin (gist_earth 0.25-0.85)."""
    from matplotlib import colormaps

    return colormaps["gist_earth"](0.25 + 0.6 * (np.arange(HEIGHT_BINS) + 0.5) / HEIGHT_BINS)[:, :3]


def _shade_factors() -> np.ndarray:
    return _AMBIENT + (1 - _AMBIENT) * np.linspace(0, 1, SHADE_LEVELS)


def _steep_greys() -> np.ndarray:
    return 0.8 + 0.2 * np.linspace(0, 1, SHADE_LEVELS)


def _build_palette() -> np.ndarray:
    marks = np.array(list(COLORS.values()), float)
    greys = np.repeat(np.linspace(0, 255, _GREYS)[:, None], 3, axis=1)
    steep = np.repeat(255 * _steep_greys()[:, None], 3, axis=1)
    terrain = 255 * (_height_colors()[:, None, :] * _shade_factors()[None, :, None]).reshape(-1, 3)
    pal = np.rint(np.vstack([marks, greys, steep, terrain])).astype(np.uint8)
    _, first = np.unique(pal, axis=0, return_index=True)
    pal = pal[np.sort(first)]
    assert len(pal) <= 255, len(pal)  # index 255 stays free (the GIF writer's transparent index)
    return pal


PALETTE = _build_palette()  # (<= 255, 3) uint8: every colour a frame holds


def _rgb(name) -> np.ndarray:
    return np.array(COLORS[name], np.uint8)


def _disc(r):
    d = np.arange(-r, r + 1)
    yy, xx = np.meshgrid(d, d, indexing="ij")
    keep = xx * xx + yy * yy <= r * r + r
    return yy[keep], xx[keep]


def _ring(r_in, r_out):
    d = np.arange(-r_out, r_out + 1)
    yy, xx = np.meshgrid(d, d, indexing="ij")
    q = xx * xx + yy * yy
    keep = (q > r_in * r_in + r_in) & (q <= r_out * r_out + r_out)
    return yy[keep], xx[keep]


def _cross(r):
    d = np.arange(-r, r + 1)
    yy = np.concatenate([d, d, d[:-1], d[1:]])  # two diagonals, thickened by one pixel
    xx = np.concatenate([d, -d, d[1:], -d[:-1]])
    return yy, xx


class Viewer:
    def __init__(self, world, width_px: int, sensor_cones: bool = False, decorations: bool = True,
                 name: str = ""):
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
        shade = np.rint(np.clip(tin.normals @ light, 0, 1) * (SHADE_LEVELS - 1)).astype(int)
        zc = tin.vertices[tin.triangles, 2].mean(axis=1)
        self.z_range = (float(zc.min()), float(zc.max()))
        zr = np.ptp(zc)
        hbin = np.minimum((HEIGHT_BINS * (zc - zc.min()) / zr).astype(int), HEIGHT_BINS - 1) if zr > 0 \
            else np.zeros(len(zc), int)
        col = _height_colors()[hbin] * _shade_factors()[shade][:, None]
        steep = world.steep
        col[steep] = _steep_greys()[shade[steep]][:, None] * np.ones(3)
        col = np.rint(255 * col) / 255  # exactly the palette's colours
        polys = tin.vertices[tin.triangles][:, :, :2]
        ax.add_collection(PolyCollection(polys, facecolors=col, edgecolors="none", antialiased=False))
        br = world.breaks
        self._static = []  # legend entries of what the terrain has
        if steep.any():
            self._static.append("steep")
        for kind, key, lw in ((ANGLE, "slope_break", 0.6), (STEEP, "cliff", 1.2)):
            seg = br.segments[br.kinds == kind][:, :, :2]
            if len(seg):
                ax.add_collection(LineCollection(seg, colors=[_rgb(key) / 255], linewidths=lw, antialiased=False))
                self._static.append(key)
        self._max_slope_deg = world.params.robot.max_slope_deg
        self._ax, self._canvas = ax, FigureCanvasAgg(fig)
        self._decorations = decorations
        if decorations:
            _scale_bar(ax, x1 - x0, y1 - y0)
        self._background = (None, None)  # (legend entries, the background image with that legend)
        self._disc3 = _disc(3)
        self._disc5 = _disc(5)
        self._ring_target = _ring(5, 6)
        self._ring_arrived = _ring(2, 4)
        self._cross = _cross(3)
        self._fig = None
        self.name = name
        self._title = _TitleStrip(W) if decorations else None
        self._colorbar = _height_colorbar(W, *self.z_range) if decorations else None

    def background(self, entries: tuple = ()) -> np.ndarray:
        """``(H, W, 3)`` uint8: the terrain (with the legend of ``entries`` when decorated)."""
        key = tuple(entries) if self._decorations else ()
        if self._background[0] != key:  # one kept: the legend changes a few times per episode
            old = self._ax.get_legend()
            if old is not None:
                old.remove()
            if key:
                _legend(self._ax, key, self._max_slope_deg)
            self._canvas.draw()
            self._background = (key, np.asarray(self._canvas.buffer_rgba())[..., :3].copy())
        return self._background[1]

    def legend_entries(self, state) -> tuple:
        """What the legend of a frame of ``state`` lists (see the module docstring)."""
        from ..world import Reason

        st = state.status
        out = list(self._static) + ["robot"]
        out += [k for k, r in (("arrived", Reason.ARRIVED), ("battery", Reason.BATTERY), ("fell", Reason.FELL))
                if (st == r).any()]
        if len(state.targets):
            out.append("target")
        if len(state.assets):
            out.append("asset")
        if self.sensor_cones:
            out.append("cone")
        return tuple(out)

    def counts(self, state, final: bool = False) -> dict:
        """Robots by status: arrived, fell, battery-empty, and active (``final``: timed out)."""
        from ..world import Reason

        st = state.status
        n = {k: int((st == r).sum()) for k, r in (("arrived", Reason.ARRIVED), ("fell", Reason.FELL),
                                                     ("battery-empty", Reason.BATTERY))}
        n["timed out" if final else "active"] = int((st == Reason.NONE).sum())
        return n

    def title(self, state, final: bool = False) -> str:
        """The title strip's text for ``state`` (``final``: the episode's last frame)."""
        c = ", ".join(f"{k} {v}" for k, v in self.counts(state, final).items())
        return f"{self.name}   step {state.step}   robots {len(state.status)}: {c}"

    def to_px(self, xy):
        x0, y0, x1, y1 = self.bounds
        H, W = self.size
        c = (xy[..., 0] - x0) / (x1 - x0) * (W - 1)
        r = (1 - (xy[..., 1] - y0) / (y1 - y0)) * (H - 1)
        return np.rint(r).astype(np.int64), np.rint(c).astype(np.int64)

    def _stamp(self, img, r, c, color, shape):
        if len(r) == 0:
            return
        dr, dc = shape
        rr = (r[:, None] + dr[None]).ravel()
        cc = (c[:, None] + dc[None]).ravel()
        H, W = self.size
        ok = (rr >= 0) & (rr < H) & (cc >= 0) & (cc < W)
        img[rr[ok], cc[ok]] = color

    def _lines(self, img, a, b, color, n=24):
        if len(a) == 0:
            return
        t = np.linspace(0, 1, n)
        p = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
        r, c = self.to_px(p.reshape(-1, 2))
        H, W = self.size
        ok = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        img[r[ok], c[ok]] = color

    def frame(self, state, final: bool = False) -> np.ndarray:
        """An ``(H, W, 3)`` uint8 picture of ``state`` (``final``: the episode's last frame, whose
        title counts the robots still active as timed out)."""
        from ..world import Reason

        img = self.background(self.legend_entries(state)).copy()
        P = self.world.params
        pos, h, st = state.positions, state.headings, state.status
        if self.sensor_cones:
            act = st == Reason.NONE
            half = np.radians(P.sensor.fov_deg) / 2
            for s in (-half, half):
                a = pos[act]
                d = P.sensor.range_m * np.column_stack([np.cos(h[act] + s), np.sin(h[act] + s)])
                self._lines(img, a, a + d, _rgb("cone"))
        if len(state.targets):
            r, c = self.to_px(state.targets.positions)
            self._stamp(img, r, c, _rgb("white"), self._ring_target)
            self._stamp(img, r, c, _rgb("target"), self._disc5)
        if len(state.assets):
            self._stamp(img, *self.to_px(state.assets.positions), _rgb("asset"), self._disc5)
        for key, reason, shape in (("arrived", Reason.ARRIVED, self._ring_arrived),
                                   ("fell", Reason.FELL, self._cross), ("battery", Reason.BATTERY, self._disc3),
                                   ("robot", Reason.NONE, self._disc3)):
            m = st == reason
            self._stamp(img, *self.to_px(pos[m]), _rgb(key), shape)
        on = (st == Reason.NONE) | (st == Reason.BATTERY)  # a heading tick on robots still standing
        x0, y0, x1, y1 = self.bounds
        px_m = (x1 - x0) / self.size[1]
        tick = 7 * px_m * np.column_stack([np.cos(h[on]), np.sin(h[on])])
        self._lines(img, pos[on], pos[on] + tick, _rgb("fell"), n=8)
        if self._title is not None:
            img = np.concatenate([self._title.render(self.title(state, final)), img, self._colorbar], axis=0)
        return img

    def show(self, img):
        """Show a frame in a matplotlib window (``render_mode="human"``)."""
        import matplotlib.pyplot as plt

        if self._fig is None or not plt.fignum_exists(self._fig.number):
            self._fig, ax = plt.subplots(figsize=(img.shape[1] / 100, img.shape[0] / 100), dpi=100)
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


_LABELS = {"steep": "too steep (> {:.0f} deg)", "cliff": "cliff edge / steep break", "slope_break": "slope break",
           "robot": "robot", "arrived": "robot, arrived", "battery": "robot, battery empty", "fell": "robot, fell",
           "target": "target / threat", "asset": "asset", "cone": "sensor cone"}


def _legend(ax, entries, max_slope_deg):
    """What each colour of ``entries`` means, in the terrain's top right corner (opaque: the
    legend's pixels keep the palette's colours)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def mark(key, marker, **kw):
        c = _rgb(key) / 255
        return Line2D([], [], ls="none", marker=marker, ms=5, mfc=kw.pop("mfc", c), mec=c, label=_LABELS[key], **kw)

    make = {"steep": lambda: Patch(fc=(0.92, 0.92, 0.92), ec="0.5", lw=0.5,
                                   label=_LABELS["steep"].format(max_slope_deg)),
            "cliff": lambda: Line2D([], [], color=_rgb("cliff") / 255, lw=1.2, label=_LABELS["cliff"]),
            "slope_break": lambda: Line2D([], [], color=_rgb("slope_break") / 255, lw=0.8,
                                          label=_LABELS["slope_break"]),
            "robot": lambda: mark("robot", "o"), "arrived": lambda: mark("arrived", "o", mfc="none", mew=1.5),
            "battery": lambda: mark("battery", "o"), "fell": lambda: mark("fell", "x", mew=1.5),
            "target": lambda: mark("target", "o"), "asset": lambda: mark("asset", "s"),
            "cone": lambda: Line2D([], [], color=_rgb("cone") / 255, lw=1.0, label=_LABELS["cone"])}
    ax.legend(handles=[make[k]() for k in entries], loc="upper right", fontsize=6, framealpha=1.0, borderpad=0.4,
              labelspacing=0.3, handlelength=1.4)


def _scale_bar(ax, width_m, height_m):
    """A bar of a round length (1, 2 or 5 times a power of ten, at most a fifth of the width)."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    top = 0.2 * width_m
    p = 10.0 ** np.floor(np.log10(top))
    length = max(m * p for m in (1, 2, 5) if m * p <= top)
    bar = AnchoredSizeBar(ax.transData, length, f"{length:g} m", loc="lower left", pad=0.4, sep=3,
                          size_vertical=0.008 * height_m, color="black", frameon=True, fontproperties={"size": 7})
    ax.add_artist(bar)


COLORBAR_HEIGHT_PX = 34  # the height colour bar strip under the terrain


def _height_colorbar(width_px: int, z0: float, z1: float) -> np.ndarray:
    """``(COLORBAR_HEIGHT_PX, W, 3)`` uint8: a white strip with the terrain's height colours
    (:data:`HEIGHT_BINS` steps from ``z0`` to ``z1`` m, unshaded) as a labelled colour bar."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colorbar import Colorbar
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_px / 100, COLORBAR_HEIGHT_PX / 100), dpi=100, facecolor="white")
    cax = fig.add_axes((0.22, 0.55, 0.56, 0.3))
    z1 = z1 if z1 > z0 else z0 + 1.0
    edges = np.linspace(z0, z1, HEIGHT_BINS + 1)
    cmap = ListedColormap(np.rint(255 * _height_colors()) / 255)
    cb = Colorbar(cax, cmap=cmap, norm=BoundaryNorm(edges, HEIGHT_BINS), orientation="horizontal",
                      ticks=np.linspace(z0, z1, 5), format="%.0f")
    cb.ax.tick_params(labelsize=6, length=2, pad=1)
    cb.outline.set_linewidth(0.5)
    fig.text(0.21, 0.7, "height (m)", ha="right", va="center", fontsize=7)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


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
