"""The terrain scan's per-robot code (world/scan_kernels.py): beam directions turned by the heading,
and one segment crossed with the beams of its wedge, on hand-built cases with exact answers. (The
wedge against every beam on random segments: tests/env/test_observation.py; break_row against the
list path: tests/world/test_sense_kernels.py.)"""

import math

import numpy as np
import pytest

from tin_swarm_env.env.observation import ObsLayout
from tin_swarm_env.world.scan_kernels import scan_contact, scan_start


@pytest.mark.parametrize("heading", [0.0, 0.7, -2.5, math.pi])
def test_scan_start_sets_every_beam_to_the_range_along_the_heading_turned_by_its_bearing(heading):
    K = 8
    b = np.full((K, 3), np.nan)
    scan_start(b, math.cos(heading), math.sin(heading), ObsLayout(k_scan=K).scan_units(), 60.0, K)
    ang = heading + 2 * np.pi * np.arange(K) / K
    assert (b[:, 0] == 60.0).all()
    np.testing.assert_allclose(b[:, 1], np.cos(ang), atol=1e-15)
    np.testing.assert_allclose(b[:, 2], np.sin(ang), atol=1e-15)


def test_scan_contact_crosses_only_the_beams_of_its_wedge_and_keeps_the_nearer():
    """Heading east, 4 beams (east, north, west, south): a wall x = 10 (y -5..5) is met by the east
    beam at 10; a wall y = 7 (x -1..1) by the north beam at 7; a farther wall x = 20 leaves the east
    beam at 10 (the nearer kept); the west and south beams meet nothing."""
    K = 4
    b = np.empty((K, 3))
    scan_start(b, 1.0, 0.0, ObsLayout(k_scan=K).scan_units(), 60.0, K)
    scan_contact(b, 20.0, -5.0, 0.0, 10.0, 1.0, 0.0, K)  # x = 20, from (20, -5) up 10
    assert b[0, 0] == 20.0
    scan_contact(b, 10.0, -5.0, 0.0, 10.0, 1.0, 0.0, K)  # x = 10
    scan_contact(b, -1.0, 7.0, 2.0, 0.0, 1.0, 0.0, K)  # y = 7
    assert b[:, 0].tolist() == [10.0, 7.0, 60.0, 60.0]
    scan_contact(b, 30.0, -5.0, 0.0, 10.0, 1.0, 0.0, K)  # farther again: no change
    assert b[0, 0] == 10.0
