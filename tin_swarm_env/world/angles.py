"""Angle wrapping for the compiled kernels, bit for bit equal to Python's float modulo.

:func:`wrap_pi` returns ``(a + pi) % (2 pi) - pi`` (the bearing and heading wrap of
:mod:`.sensing`, :mod:`.locomotion` and their numpy/Python references) without the ``fmod``
call that numba's float ``%`` makes, for ``|a + pi| < 4 pi`` (every bearing and heading
difference of two wrapped angles). Why it is exact: ``fmod(x, C)`` is the exact remainder; for
``0 <= x < C`` it is ``x``, for ``C <= x < 2 C`` it is ``x - C``, which floating point computes
exactly (Sterbenz: ``C/2 <= x <= 2 C``), and for ``-C < x < 0`` it is ``x``, which Python's modulo
then moves to ``x + C`` (the same rounded sum computed here). Anything else (larger angles, NaN,
inf) goes through ``%`` itself.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["TWO_PI", "wrap_pi"]

TWO_PI = 2 * math.pi


@njit(cache=True, inline="always")
def wrap_pi(a):
    """``(a + pi) % (2 * pi) - pi``, bit for bit: in [-pi, pi] (pi only where ``x + 2 pi`` rounds up)."""
    x = a + math.pi
    if -TWO_PI < x < 2.0 * TWO_PI:  # written as selects (no data-dependent branch): see the module docstring
        m = x - TWO_PI if x >= TWO_PI else x
        m = m + TWO_PI if m < 0.0 else m
        return m - math.pi
    return x % TWO_PI - math.pi
