"""The terrain scan's per-robot code: K beams from a robot, each reading the distance to the first
dangerous break it crosses (the observation's ``scan`` part, :mod:`tin_swarm_env.env.observation`).

One robot's scan is a ``(K, 3)`` scratch ``b``: per beam its best distance so far and its unit
direction in the world frame. :func:`scan_start` sets every beam to the range ``R`` and its
direction, the heading's ``(cos, sin)`` turned by the beam's bearing (``units``, the bearings'
``(cos, sin)``, :meth:`~tin_swarm_env.env.observation.ObsLayout.scan_units`: four multiplications a
beam, no libm call); :func:`scan_contact` crosses one dangerous break segment with the beams of its
wedge only (:func:`beam_span`, ~1 beam of 32); the scan is the minimum over the crossings, so the
same bits in any order of the contacts. The observation encoder runs it over a robot's contact list
(:func:`~tin_swarm_env.env.observation.scan_beams`); the vector env's sensing pass runs
:func:`scan_wedges` over the dangerous contacts it gathers (:func:`~.sense_kernels.break_row`): the
same wedges and crossings on the same numbers, so the same bits.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["ANGLE_ERROR", "SPAN_MARGIN", "approx_angle", "beam_span", "crossing", "scan_start", "scan_contact",
           "scan_wedges", "wedge_spans"]

ANGLE_ERROR = 1e-3  # rad: a bound on how far :func:`approx_angle` is off (2e-4 at worst: tests/env/test_observation.py)
SPAN_MARGIN = 0.02  # rad: :func:`beam_span` takes the beams this close to the wedge too


@njit(cache=True, inline="always")
def approx_angle(x, y):
    """``atan2(y, x)`` within :data:`ANGLE_ERROR` (a polynomial on the octant, no libm call) where ``|x|`` or
    ``|y|`` is at least 1e-300 (nearer the origin it is no angle: :func:`beam_span` takes such a point as at the
    robot and reads every beam): where the exact angle is not needed, only which beams are near it.
    No branch: every case is a selection, so a loop over many points runs several at a time."""
    ax = abs(x)
    ay = abs(y)
    a = min(ax, ay) / max(ax, ay, 1e-300)
    s = a * a
    r = ((-0.0464964749 * s + 0.15931422) * s - 0.327622764) * s * a + a
    r = 0.5 * math.pi - r if ay > ax else r
    r = math.pi - r if x < 0.0 else r
    return -r if y < 0.0 else r


@njit(cache=True, inline="always")
def beam_span(ax, ay, bx, by, c, s, K):
    """``(lo, hi)``: the scan beams ``lo..hi`` (taken mod ``K``, ``-K <= lo <= hi < 2 K``; beam ``k`` at
    bearing ``k step``, ``step = 2 pi / K``, from the heading ``(c, s) = (cos, sin)``) that can cross
    the segment ``a -> b`` (ends relative to the robot): every beam within :data:`SPAN_MARGIN` of the
    wedge of directions the segment subtends, found by :func:`approx_angle` in the body frame.
    ``(0, K - 1)`` (every beam) where the wedge is ill-defined: an end within ~1e-6 (L + 1) m of the
    robot (``L`` the segment's length), or a wedge within two steps of a half-turn (the robot next
    to the segment). The margin is far above what the angle's error (:data:`ANGLE_ERROR`), the
    crossing's tolerance (1e-12 of the segment: < 1e-6 rad at that distance) and rounding can turn a
    beam by, so no beam outside ``lo..hi`` passes :func:`scan_beams`' exact test. No libm call: a few
    multiplications and three divisions; no branch (every case computed, the one that applies
    selected: :func:`wedge_spans` runs it over many segments at a time)."""
    step = 2.0 * math.pi / K
    tiny2 = 2e-12 * ((bx - ax) ** 2 + (by - ay) ** 2 + 1.0)  # >= (1e-6 (L + 1))^2
    at_robot = (ax * ax + ay * ay < tiny2) | (bx * bx + by * by < tiny2)
    fa = approx_angle(c * ax + s * ay, c * ay - s * ax)
    fb = approx_angle(c * bx + s * by, c * by - s * bx)
    swap = ax * by - ay * bx < 0.0  # b comes first counter-clockwise
    f0 = fb if swap else fa
    f1 = fa if swap else fb
    span = f1 - f0
    span = span + 2.0 * math.pi if span < 0.0 else span
    lo = math.ceil((f0 - SPAN_MARGIN) * (K / (2.0 * math.pi)))
    hi = math.floor((f0 + span + SPAN_MARGIN) * (K / (2.0 * math.pi)))
    every = at_robot | (span > math.pi - 2.0 * step) | (hi - lo + 1 >= K)
    return (0 if every else int(lo)), (K - 1 if every else int(hi))


@njit(cache=True, inline="always")
def wedge_spans(geo, nc, c, s, K, spans):
    """:func:`beam_span` of the ``nc`` segments ``geo[:, j] = (wx, wy, ex, ey)`` (``w -> w + e`` relative to
    the robot) to ``spans (2, nc)``: a loop with no branch, which the compiler runs several segments at a
    time where divisions by zero are not checked (``error_model="numpy"``, :func:`~.sense_kernels.break_row`)."""
    for j in range(nc):
        wx = geo[0, j]
        wy = geo[1, j]
        lo, hi = beam_span(wx, wy, wx + geo[2, j], wy + geo[3, j], c, s, K)
        spans[0, j] = lo
        spans[1, j] = hi


@njit(cache=True, inline="always")
def crossing(dx, dy, ex, ey, wx, wy, best):
    """Where the beam ``(dx, dy)`` from the robot crosses the segment ``w -> w + e`` (relative to the
    robot) if nearer than ``best``, else ``best``: ``t`` of ``t d = w + u e`` when ``-1e-12 <= u <= 1 +
    1e-12`` and ``0 <= t < best``. A crossing clearly missed (``u`` or ``t`` outside by a margin, told
    by multiplications) is refused before the divisions; what is left is decided by the two
    quotients, so the answer is the quotients' test bit for bit."""
    den = dx * ey - dy * ex  # beam x segment
    if abs(den) < 1e-12:
        return best  # parallel: it runs along the break, never into it
    nt = wx * ey - wy * ex
    nu = wx * dy - wy * dx
    ad = abs(den)
    if den < 0.0:
        nt = -nt
        nu = -nu
    lim = best * ad * (1.0 + 1e-9)
    if nt < -1e-200 * ad or (nt > lim and lim > 1e-280) or nu < -2e-12 * ad or nu > 1.000001 * ad:
        return best  # t < 0, t >= best, u < -1e-12 or u > 1 + 1e-12, each by a margin over the rounding
    t = (wx * ey - wy * ex) / den  # along the beam
    u = (wx * dy - wy * dx) / den  # along the segment
    if -1e-12 <= u <= 1.0 + 1e-12 and 0.0 <= t < best:  # (a beam through a shared end meets one)
        return t
    return best



@njit(cache=True, inline="always")
def scan_start(b, c, s, units, R, K):
    """Every beam of the scratch ``b (K, 3)``: best ``R``, direction the heading ``(c, s)`` turned by
    the beam's bearing ``units[k] = (cos, sin)``."""
    for k in range(K):
        b[k, 0] = R
        b[k, 1] = c * units[k, 0] - s * units[k, 1]
        b[k, 2] = s * units[k, 0] + c * units[k, 1]


@njit(cache=True, inline="always")
def scan_contact(b, wx, wy, ex, ey, c, s, K):
    """One dangerous segment ``w -> w + e`` (relative to the robot) crossed with the beams of its
    wedge (:func:`beam_span`), each beam's best kept as the nearer (:func:`crossing`)."""
    lo, hi = beam_span(wx, wy, wx + ex, wy + ey, c, s, K)
    for kk in range(lo, hi + 1):
        k = kk + K if kk < 0 else (kk - K if kk >= K else kk)
        b[k, 0] = crossing(b[k, 1], b[k, 2], ex, ey, wx, wy, b[k, 0])


@njit(cache=True, inline="always")
def scan_wedges(b, geo, nc, pairs, c, s, K, spans):
    """:func:`scan_contact` over the ``nc`` dangerous segments ``geo[:, j] = (wx, wy, ex, ey)`` (``w -> w + e``
    relative to the robot), the same crossings in three passes: every wedge (:func:`wedge_spans`, to ``spans
    (2, nc)`` scratch), then each wedge's at most two beams written as ``(beam, j)`` to ``pairs ((2 nc + 2, 2)``
    scratch; a wider wedge, rare, crossed at once by :func:`scan_contact`), then every pair's :func:`crossing`.
    Each beam's best is the minimum over its crossings, so the same bits in any order; in passes no branch
    waits on a wedge (computed long before it is read), which the beam loop of :func:`scan_contact` did per
    contact."""
    wedge_spans(geo, nc, c, s, K, spans)
    p = 0
    for j in range(nc):
        lo = spans[0, j]
        hi = spans[1, j]
        if hi - lo > 1:
            scan_contact(b, geo[0, j], geo[1, j], geo[2, j], geo[3, j], c, s, K)
            continue
        k = lo + K if lo < 0 else (lo - K if lo >= K else lo)  # (lo, lo + 1), of which hi - lo + 1 count
        pairs[p, 0] = k
        pairs[p, 1] = j
        pairs[p + 1, 0] = k + 1 if k + 1 < K else k + 1 - K
        pairs[p + 1, 1] = j
        p += hi - lo + 1
    for q in range(p):
        k = pairs[q, 0]
        j = pairs[q, 1]
        b[k, 0] = crossing(b[k, 1], b[k, 2], geo[2, j], geo[3, j], geo[0, j], geo[1, j], b[k, 0])
