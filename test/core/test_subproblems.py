"""Paden–Kahan subproblems: vectorised solvers recover known angles; the scalar twin agrees."""

import math

import numpy as np
import pytest

from kinematics_node.core.ik import subproblems as sp
from kinematics_node.core.ik.closed_form import geometry as scalar

N = 2000


def unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def wrapped_distance(a, b):
    return np.abs((a - b + np.pi) % (2 * np.pi) - np.pi)


def test_rotate_is_rodrigues_and_keeps_the_axis():
    rng = np.random.default_rng(1)
    k, x = unit(rng, N), rng.normal(size=(N, 3))
    t = rng.uniform(-4, 4, N)
    y = sp.rotate(k, t, x)
    np.testing.assert_allclose(np.linalg.norm(y, axis=1), np.linalg.norm(x, axis=1), rtol=1e-13)
    np.testing.assert_allclose(sp.dot(k, y), sp.dot(k, x), atol=1e-13)
    # Compare with the matrix exponential of θ[k] (scipy's Rotation as an independent oracle).
    from scipy.spatial.transform import Rotation

    ref = Rotation.from_rotvec(k * t[:, None]).apply(x)
    np.testing.assert_allclose(y, ref, atol=1e-13)


def test_sp1_recovers_the_angle():
    rng = np.random.default_rng(2)
    k, p = unit(rng, N), rng.normal(size=(N, 3))
    t = rng.uniform(-np.pi, np.pi, N)
    theta, free = sp.sp1(k, p, sp.rotate(k, t, p), np.zeros(N), 1e-9)
    assert not free.any()
    assert wrapped_distance(theta, t).max() < 1e-10


def test_sp1_point_on_the_axis_is_free_and_takes_the_default():
    k = np.array([[0.0, 0.0, 1.0]])
    theta, free = sp.sp1(k, np.array([[0, 0, 2.0]]), np.array([[0, 0, 2.0]]), np.array([0.7]), 1e-9)
    assert free[0] and theta[0] == 0.7


def test_sp2_has_the_angles_among_its_two_branches():
    rng = np.random.default_rng(3)
    k1, k2, p = unit(rng, N), unit(rng, N), rng.normal(size=(N, 3))
    t1, t2 = rng.uniform(-np.pi, np.pi, (2, N))
    q = sp.rotate(k1, t1, sp.rotate(k2, t2, p))
    a, b, ok, free = sp.sp2(k1, k2, p, q, np.zeros(N), np.zeros(N), 1e-9)
    assert ok.all() and not free.any()
    hit = (wrapped_distance(a, t1[:, None]) < 1e-7) & (wrapped_distance(b, t2[:, None]) < 1e-7)
    assert hit.any(axis=1).all()
    # Both branches solve the equation.
    back = sp.rotate(k1[:, None], a, sp.rotate(k2[:, None], b, p[:, None]))
    assert np.abs(back - q[:, None]).max() < 1e-8


def test_sp2_without_a_real_solution_says_so():
    k1, k2 = np.array([[0.0, 0, 1]]), np.array([[1.0, 0, 0]])
    # R(z)R(x) keeps |z-component| ≤ ‖p‖ but the middle point needs kᵀz = 1 and 0.9 at once: use a
    # target whose z-component the x-rotation of p cannot produce together with the z-rotation.
    p = np.array([[0.0, 0.0, 1.0]])
    q = np.array([[1.0, 0.0, 0.0]])  # ‖p‖ = ‖q‖, reachable
    _, _, ok, _ = sp.sp2(k1, k2, p, q, np.zeros(1), np.zeros(1), 1e-9)
    assert ok.all()
    k2 = np.array([[0.0, np.sqrt(0.5), np.sqrt(0.5)]])  # 45° from z: R(k2) p stays within 90° of k2
    q = np.array([[0.0, 0.0, -1.0]])
    _, _, ok, _ = sp.sp2(k1, k2, p, q, np.zeros(1), np.zeros(1), 1e-9)
    assert not ok.any()


def test_sp3_and_sp4_recover_the_angle_or_report_unreachable():
    rng = np.random.default_rng(4)
    k, p, q, h = unit(rng, N), rng.normal(size=(N, 3)), rng.normal(size=(N, 3)), unit(rng, N)
    t = rng.uniform(-np.pi, np.pi, N)
    delta = np.linalg.norm(sp.rotate(k, t, p) - q, axis=1)
    th, ok, free = sp.sp3(k, p, q, delta, np.zeros(N), 1e-12)
    assert ok.all() and not free.any()
    assert (wrapped_distance(th, t[:, None]).min(axis=1) < 1e-6).all()
    th, ok, _ = sp.sp3(k, p, q, delta + 10.0, np.zeros(N), 1e-12)
    assert not ok.any()
    d = sp.dot(h, sp.rotate(k, t, p))
    th, ok, free = sp.sp4(k, p, h, d, np.zeros(N), 1e-9)
    assert ok.all()
    assert (wrapped_distance(th, t[:, None]).min(axis=1) < 1e-6).all()
    _, ok, _ = sp.sp4(k, p, h, np.linalg.norm(p, axis=1) + 1.0, np.zeros(N), 1e-9)
    assert not ok.any()


def test_solve_trig_free_when_the_left_side_is_constant():
    th, ok, free = sp.solve_trig(
        np.zeros(2), np.zeros(2), np.array([0.0, 1.0]), np.full(2, 0.3), 1e-12
    )
    assert free.all() and ok.tolist() == [True, False] and np.all(th == 0.3)


def test_scalar_twin_agrees_with_the_vectorised_subproblems():
    rng = np.random.default_rng(5)
    for _ in range(200):
        k1, k2, h = unit(rng, 3)
        p, q = rng.normal(size=(2, 3))
        t = rng.uniform(-np.pi, np.pi)
        tk = lambda v: tuple(float(x) for x in v)  # noqa: E731
        # SP1
        qq = sp.rotate(k1[None], np.array([t]), p[None])[0]
        a, _ = scalar.sp1(tk(k1), tk(p), tk(qq), 0.0, 1e-9)
        b, _ = sp.sp1(k1[None], p[None], qq[None], np.zeros(1), 1e-9)
        assert a == pytest.approx(b[0], abs=1e-12)
        # SP2
        s_out = scalar.sp2(tk(k1), tk(k2), tk(p), tk(qq), 0.0, 0.0, 1e-9)
        v1, v2, ok, _ = sp.sp2(
            k1[None], k2[None], p[None], qq[None], np.zeros(1), np.zeros(1), 1e-9
        )
        assert ok[0] and len(s_out) == 2
        for i, (x1, x2, _) in enumerate(s_out):
            assert (x1, x2) == pytest.approx((v1[0, i], v2[0, i]), abs=1e-12)
        # SP3, SP4
        delta = float(np.linalg.norm(qq - q)) * rng.uniform(0.5, 1.5)
        (a1, a2), oka, _ = scalar.sp3(tk(k1), tk(p), tk(q), delta, 0.0, 1e-12)
        th, okv, _ = sp.sp3(k1[None], p[None], q[None], np.array([delta]), np.zeros(1), 1e-12)
        assert oka == bool(okv[0])
        if oka:
            assert (a1, a2) == pytest.approx(tuple(th[0]), abs=1e-12)
        d = float(h @ qq) * rng.uniform(0.5, 1.5)
        (a1, a2), oka, _ = scalar.sp4(tk(k1), tk(p), tk(h), d, 0.0, 1e-9)
        th, okv, _ = sp.sp4(k1[None], p[None], h[None], np.array([d]), np.zeros(1), 1e-9)
        assert oka == bool(okv[0])
        if oka:
            assert (a1, a2) == pytest.approx(tuple(th[0]), abs=1e-12)
    assert math.isclose(scalar.norm((3.0, 4.0, 0.0)), 5.0)
