"""The potential fields: hand-computed values and forces = -grad(potential)."""

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from tin_swarm_env.world.fields import (
    FieldParams,
    break_field,
    facing,
    follow_field,  # noqa: E402
    height_field,
    robot_field,
    target_field,
)


def test_robot_field_hand_values():
    # one robot 1 m east, range 4, gain 2: |F| = 2 (1 - 1/4)^2 = 1.125, pointing west
    f, u = robot_field(np.array([[[1.0, 0.0]]]), np.array([[1.0]]), 2.0, 4.0)
    np.testing.assert_allclose(f, [[-1.125, 0.0]])
    assert u[0] == pytest.approx(2 * 4 / 3 * 0.75 ** 3)
    # beyond range, or an invalid slot: nothing
    f, u = robot_field(np.array([[[5.0, 0.0], [0.0, 1.0]]]), np.array([[1.0, 0.0]]), 2.0, 4.0)
    np.testing.assert_allclose(f, [[0.0, 0.0]])
    assert u[0] == 0


def test_target_field_hand_values():
    # goal 30 m north, range 10: saturated attraction of gain 1.5
    f, u = target_field(np.array([[0.0, 30.0]]), 0.0, 1.5, 10.0)
    np.testing.assert_allclose(f, [[0.0, 1.5]])
    assert u[0] == pytest.approx(1.5 * (30 - 5))
    # inside the quadratic zone: |F| = gain * e / range
    f, _ = target_field(np.array([[4.0, 0.0]]), 0.0, 1.0, 10.0)
    np.testing.assert_allclose(f, [[0.4, 0.0]])
    # inside the standoff it repels: threat 20 m east, standoff 25 -> e = -5, |F| = 0.5 west
    f, _ = target_field(np.array([[20.0, 0.0]]), 25.0, 1.0, 10.0)
    np.testing.assert_allclose(f, [[-0.5, 0.0]])
    # on the ring: no force
    f, _ = target_field(np.array([[0.0, -25.0]]), 25.0, 1.0, 10.0)
    np.testing.assert_allclose(f, [[0.0, 0.0]], atol=1e-15)


def test_break_field_hand_values_and_only_from_the_safe_side():
    # break 2 m east, normal (toward safety) west: |F| = 4 exp(-2/2.5) west
    rel = np.array([[[2.0, 0.0]]])
    n = np.array([[[-1.0, 0.0]]])
    f, _ = break_field(rel, n, np.array([[1.0]]), 4.0, 15.0, 2.5)
    np.testing.assert_allclose(f, [[-4 * math.exp(-0.8), 0.0]])
    # the same break seen from its unsafe side (normal pointing away from the robot): nothing
    f, _ = break_field(rel, -n, np.array([[1.0]]), 4.0, 15.0, 2.5)
    np.testing.assert_allclose(f, [[0.0, 0.0]])
    # a bend between traversable planes (valid = danger = 0): nothing
    f, _ = break_field(rel, n, np.array([[0.0]]), 4.0, 15.0, 2.5)
    np.testing.assert_allclose(f, [[0.0, 0.0]])


def test_height_field_hand_values():
    # ground rising north at tan = 0.2; target 10 m higher: pull uphill with 0.5 * 10/20 * 0.2
    f, _ = height_field(np.array([[0.0, 0.2]]), np.array([10.0]), 0.5)
    np.testing.assert_allclose(f, [[0.0, 0.05]])
    f, _ = height_field(np.array([[0.0, 0.2]]), np.array([-10.0]), 0.5)
    np.testing.assert_allclose(f, [[0.0, -0.05]])  # target lower: downhill
    f, _ = height_field(np.zeros((1, 2)), np.array([10.0]), 0.5)
    np.testing.assert_allclose(f, [[0.0, 0.0]])  # level ground


def fd_grad(U, p, h=1e-6):
    g = np.zeros(2)
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        g[k] = (U(p + e) - U(p - e)) / (2 * h)
    return g


pts = st.tuples(st.floats(-30, 30), st.floats(-30, 30))


@given(pts, st.lists(pts, min_size=1, max_size=4), st.floats(0.5, 3), st.floats(2, 20))
def test_robot_force_is_minus_the_gradient(p, others, gain, rng_m):
    p = np.array(p)
    q = np.array(others)

    def U(x):
        return robot_field((q - x)[None], np.ones((1, len(q))), gain, rng_m)[1][0]

    d = np.hypot(*(q - p).T)
    assume(not (np.any(np.abs(d - rng_m) < 1e-3) or np.any(d < 1e-3)))  # the kink at the range, the singular point
    f = robot_field((q - p)[None], np.ones((1, len(q))), gain, rng_m)[0][0]
    np.testing.assert_allclose(f, -fd_grad(U, p), atol=1e-5)


@given(pts, pts, st.floats(0, 30), st.floats(0.5, 3), st.floats(2, 20))
def test_target_force_is_minus_the_gradient(p, t, standoff, gain, rng_m):
    p, t = np.array(p), np.array(t)
    d = np.hypot(*(t - p))
    assume(d >= 1e-2)  # the singular point at the target
    f = target_field((t - p)[None], standoff, gain, rng_m)[0][0]
    np.testing.assert_allclose(f, -fd_grad(lambda x: target_field((t - x)[None], standoff, gain, rng_m)[1][0], p),
                               atol=1e-5)


@given(st.floats(-20, 20), st.floats(0.05, 14), st.floats(0.5, 5), st.floats(0.5, 5))
def test_break_force_is_minus_the_gradient_on_the_safe_side(x, y, gain, decay):
    # a long break along the x axis, safe side y > 0; the robot at (x, y)
    a, b = np.array([-100.0, 0.0]), np.array([100.0, 0.0])
    n = np.array([[[0.0, 1.0]]])

    def rel(pt):
        u = np.clip((pt - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
        return (a + u * (b - a) - pt)[None, None]

    p = np.array([x, y])
    f = break_field(rel(p), n, np.ones((1, 1)), gain, 15.0, decay)[0][0]
    g = fd_grad(lambda q: break_field(rel(q), n, np.ones((1, 1)), gain, 15.0, decay)[1][0], p)
    np.testing.assert_allclose(f, -g, atol=1e-5)


@given(st.floats(-30, 30), st.floats(-1, 1), st.floats(-1, 1), st.floats(0.1, 2))
def test_height_force_is_minus_the_gradient(z_t, gx, gy, gain):
    # a plane z = gx x + gy y; the potential is gain * f(z(p) - z_t)
    def U(p):
        z = gx * p[0] + gy * p[1]
        return height_field(np.array([[gx, gy]]), np.array([z_t - z]), gain)[1][0]

    p = np.array([3.0, -2.0])
    z = gx * p[0] + gy * p[1]
    f = height_field(np.array([[gx, gy]]), np.array([z_t - z]), gain)[0][0]
    np.testing.assert_allclose(f, -fd_grad(U, p), atol=1e-5)


def test_facing_hand_values():
    # a break 2 m east whose safe side is west (normal (-1, 0)): the robot is on its safe side;
    # the same break with the normal east is seen from behind; an invalid slot never faces
    rel = np.array([[[2.0, 0.0], [2.0, 0.0], [2.0, 0.0], [0.0, 0.0]]])
    nrm = np.array([[[-1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]]])
    valid = np.array([[1.0, 1.0, 0.0, 1.0]])
    np.testing.assert_array_equal(facing(rel, nrm, valid), [[True, False, False, True]])  # on the break: faces


def test_field_params_validate():
    with pytest.raises(ValueError, match="unknown field"):
        FieldParams(fields=("robot", "wind"))
    with pytest.raises(ValueError, match="break_decay_m"):
        FieldParams(break_decay_m=0)


def test_fields_on_a_grid_are_minus_the_gradient_of_their_potential():
    from tin_swarm_env.terrain import Tin
    from tin_swarm_env.world.fields import fields_at

    # a tilted plane (rising east at 0.1) with a cliff-free TIN; robots, a target, height
    xy = np.array([[0, 0], [200, 0], [200, 200], [0, 200], [100, 100]], float)
    tin = Tin.from_points(np.column_stack([xy, 0.1 * xy[:, 0]]))
    gx, gy = np.meshgrid(np.linspace(60, 140, 161), np.linspace(60, 140, 161))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    params = FieldParams(robot_range_m=15.0)
    out = fields_at(pts, params, robots=[[100.0, 100.0], [120.0, 90.0]], target=[130.0, 120.0], standoff_m=10.0,
                    tin=tin, z_target=13.0)
    assert set(out) == {"robot", "target", "height", "total"}
    f, u = out["total"]
    U = u.reshape(gx.shape)
    h = 0.5
    dUdy, dUdx = np.gradient(U, h, h)
    F = f.reshape(*gx.shape, 2)
    # compare away from the kinks (robot centres, range circles, the target's standoff ring)
    d1 = np.hypot(gx - 100, gy - 100)
    d2 = np.hypot(gx - 120, gy - 90)
    dt = np.hypot(gx - 130, gy - 120)
    # (point sources are cone-like at their centres: finite differences need room there)
    smooth = (np.abs(d1 - 15) > 1.5) & (np.abs(d2 - 15) > 1.5) & (d1 > 8) & (d2 > 8) & \
        (np.abs(dt - 10) > 1.5) & (np.abs(dt - 20) > 1.5) & (dt > 8)
    smooth[:2] = smooth[-2:] = False
    smooth[:, :2] = smooth[:, -2:] = False
    err = np.hypot(F[..., 0] + dUdx, F[..., 1] + dUdy)
    assert smooth.mean() > 0.5
    np.testing.assert_array_less(err[smooth], 2e-3, err_msg=str(np.argwhere(smooth & (err > 2e-3))[:5]))
    np.testing.assert_allclose(F[..., 0][smooth], -dUdx[smooth], atol=2e-3)
    np.testing.assert_allclose(F[..., 1][smooth], -dUdy[smooth], atol=2e-3)
    # switching a field off removes it
    off = fields_at(pts, FieldParams(fields=("target",)), robots=[[100.0, 100.0]], target=[130.0, 120.0])
    assert set(off) == {"target", "total"}


def test_break_field_on_a_grid_pushes_back_from_a_cliff_edge():
    from tin_swarm_env.terrain import Tin
    from tin_swarm_env.world.fields import fields_at

    xs, zs = [0.0, 100.0, 101.0, 200.0], [50.0, 50.0, 0.0, 0.0]
    tin = Tin.from_points(np.array([(x, y, z) for x, z in zip(xs, zs) for y in (0.0, 100.0)]))
    br = tin.breaks(max_slope_deg=30, break_angle_deg=None)
    out = fields_at([[95.0, 50.0], [60.0, 50.0]], FieldParams(), breaks=br)
    f = out["break"][0]
    assert f[0, 0] < -0.5 and abs(f[0, 1]) < 1e-9  # 5 m from the edge: pushed west, hard
    # 40 m away the border (west, 60 m off) and the cliff are both beyond the 15 m range
    np.testing.assert_allclose(f[1], [0.0, 0.0])


def test_follow_field_hand_values():
    # break 5 m east (normal west), hold 5 m, step 0 -> straight along it: north for side +1
    rel, n, pull = np.array([[5.0, 0.0]]), np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]])
    np.testing.assert_allclose(pull + follow_field(pull, rel, n, np.array([1]), 5.0, 0.0), [[0.0, 1.0]], atol=1e-12)
    np.testing.assert_allclose(pull + follow_field(pull, rel, n, np.array([-1]), 5.0, 0.0), [[0.0, -1.0]],
                               atol=1e-12)
    np.testing.assert_allclose(follow_field(pull, rel, n, np.array([0]), 5.0, 0.0), [[0.0, 0.0]])
    # 10 m away: turned toward the break by 1 rad; a 2 m step at 10 m adds asin(0.1)
    b = 1 + math.asin(0.1)
    np.testing.assert_allclose(pull + follow_field(pull, 2 * rel, n, np.array([1]), 5.0, 2.0),
                               [[math.sin(b), math.cos(b)]], atol=1e-12)
