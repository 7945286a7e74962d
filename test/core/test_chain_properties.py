"""Properties of the PoE model: finite differences, adjoint relations, batching, seed examples."""

import numpy as np
import pytest
from kin_testing import random_q

from kinematics_node.core import SerialChain, se3


def _fd_world_jacobian(chain, q, h=1e-6):
    """Central differences of FK: linear part d p / dq, angular part vee(dR Rᵀ)."""
    J = np.zeros((6, chain.dof))
    for i in range(chain.dof):
        dq = np.zeros(chain.dof)
        dq[i] = h
        Tp, Tm = chain.fk(q + dq), chain.fk(q - dq)
        J[3:, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h)
        W = dR @ chain.fk(q)[:3, :3].T
        J[:3, i] = (W[2, 1], W[0, 2], W[1, 0])
    return J


def test_jacobian_columns_equal_central_finite_differences(real_arm):
    chain, _ = real_arm
    for q in random_q(chain, np.random.default_rng(21), 5):
        np.testing.assert_allclose(
            chain.jacobian(q, "world"), _fd_world_jacobian(chain, q), atol=1e-8
        )


def test_space_body_world_relations(real_arm):
    chain, _ = real_arm
    for q in random_q(chain, np.random.default_rng(22), 10):
        T = chain.fk(q)
        Js, Jb, Jw = (chain.jacobian(q, f) for f in ("space", "body", "world"))
        np.testing.assert_allclose(Js, se3.adjoint(T) @ Jb, atol=1e-12)  # J_s = Ad_T J_b
        shift = np.eye(6)
        shift[3:, :3] = -se3.so3.hat(T[:3, 3])  # v_tip = v_s + ω × p = v_s − [p] ω
        np.testing.assert_allclose(Jw, shift @ Js, atol=1e-12)


def test_poe_formula_with_S_and_B(real_arm):
    """T(θ) = e^{[S1]θ1}⋯e^{[Sn]θn} M = M e^{[B1]θ1}⋯e^{[Bn]θn} (MR eqs. 4.14, 4.16)."""
    chain, _ = real_arm
    assert not chain.S.flags.writeable and not chain.M.flags.writeable
    np.testing.assert_allclose(chain.B, se3.adjoint(se3.inverse(chain.M)) @ chain.S, atol=1e-12)
    for q in random_q(chain, np.random.default_rng(23), 5):
        Ts, Tb = np.eye(4), chain.M.copy()
        for k in range(chain.dof):
            Ts = Ts @ se3.exp(chain.S[:, k] * q[k])
            Tb = Tb @ se3.exp(chain.B[:, k] * q[k])
        np.testing.assert_allclose(chain.fk(q), Ts @ chain.M, atol=1e-12)
        np.testing.assert_allclose(chain.fk(q), Tb, atol=1e-12)
    np.testing.assert_allclose(chain.fk(np.zeros(chain.dof)), chain.M, atol=1e-15)


def test_batched_equals_looped(real_arm):
    chain, _ = real_arm
    Q = random_q(chain, np.random.default_rng(24), 17)
    T, J = chain.fk_jacobian(Q, "body")
    for i, q in enumerate(Q):
        Ti, Ji = chain.fk_jacobian(q, "body")
        np.testing.assert_allclose(T[i], Ti, atol=1e-13)
        np.testing.assert_allclose(J[i], Ji, atol=1e-13)
    # lists and tuples take the same path as arrays
    np.testing.assert_allclose(chain.fk(list(Q[0])), chain.fk(Q[0]), atol=0)


def test_twist_statics_and_power(real_arm):
    chain, _ = real_arm
    rng = np.random.default_rng(25)
    q = random_q(chain, rng)
    qdot = rng.normal(size=chain.dof)
    F = rng.normal(size=6)
    for frame in ("space", "body", "world"):
        V = chain.twist(q, qdot, frame)
        tau = chain.joint_torques(q, F, frame)
        assert V @ F == pytest.approx(qdot @ tau, rel=1e-12)  # power balance
    # the world twist's linear part is the velocity of the tip origin
    h = 1e-6
    v_fd = (chain.fk(q + h * qdot)[:3, 3] - chain.fk(q - h * qdot)[:3, 3]) / (2 * h)
    np.testing.assert_allclose(chain.twist(q, qdot)[3:], v_fd, atol=1e-7)


def test_analytic_rpy_jacobian_matches_finite_differences(real_arm):
    from kinematics_node.core.rotations import rpy_from_matrix

    chain, _ = real_arm
    q = random_q(chain, np.random.default_rng(26))
    JA = chain.analytic_jacobian_rpy(q)
    h = 1e-6
    for i in range(chain.dof):
        dq = np.zeros(chain.dof)
        dq[i] = h
        d = (
            rpy_from_matrix(chain.fk(q + dq)[:3, :3]) - rpy_from_matrix(chain.fk(q - dq)[:3, :3])
        ) / (2 * h)
        np.testing.assert_allclose(JA[:3, i], d, atol=1e-6)


# ------------------------------------------------------------------ seed worked examples
def test_scara_dh_table_matches_seed_closed_form():
    """De Luca's SCARA (RRPR) DH table and its direct kinematics ⁰A₄ (seed 001)."""
    a1, a2, d1, d4 = 0.35, 0.30, 0.40, -0.12
    table = [
        {"a": a1, "alpha": 0, "d": d1, "theta": 0, "type": "R"},
        {"a": a2, "alpha": 0, "d": 0, "theta": 0, "type": "R"},
        {"a": 0, "alpha": 0, "d": 0, "theta": 0, "type": "P"},
        {"a": 0, "alpha": np.pi, "d": d4, "theta": 0, "type": "R"},
    ]
    chain = SerialChain.from_dh(table)
    assert chain.joint_types == ("continuous", "continuous", "prismatic", "continuous")
    rng = np.random.default_rng(27)
    for q1, q2, q3, q4 in rng.uniform(-2, 2, (20, 4)):
        c1, s1, c12, s12 = np.cos(q1), np.sin(q1), np.cos(q1 + q2), np.sin(q1 + q2)
        c124, s124 = np.cos(q1 + q2 + q4), np.sin(q1 + q2 + q4)
        expected = np.array(
            [
                [c124, s124, 0, a1 * c1 + a2 * c12],
                [s124, -c124, 0, a1 * s1 + a2 * s12],
                [0, 0, -1, d1 + q3 + d4],
                [0, 0, 0, 1],
            ]
        )
        np.testing.assert_allclose(chain.fk([q1, q2, q3, q4]), expected, atol=1e-12)


def test_stanford_arm_space_jacobian_columns_from_seed_notes():
    """MLS Example 3.9 (seed 004): ξ₂' = (l0 sθ1, −l0 cθ1, 0, −cθ1, −sθ1, 0) in (v, ω) order."""
    l0, l1 = 0.5, 0.3
    q_ = {1: [0, 0, l0], 2: [0, 0, l0], 4: [0, l1, l0], 5: [0, l1, l0], 6: [0, l1, l0]}
    w_ = {1: [0, 0, 1], 2: [-1, 0, 0], 4: [0, 0, 1], 5: [-1, 0, 0], 6: [0, 1, 0]}
    S = np.zeros((6, 6))
    for k in (1, 2, 4, 5, 6):
        S[:, k - 1] = se3.screw_axis(q_[k], w_[k], 0.0)  # our (ω, v) order
    S[:, 2] = (0, 0, 0, 0, 1, 0)  # prismatic along y
    M = np.eye(4)
    M[:3, 3] = (0, l1, l0)
    chain = SerialChain.from_poe(S, M)
    rng = np.random.default_rng(28)
    for th in rng.uniform(-1.5, 1.5, (10, 6)):
        Js = chain.jacobian(th, "space")
        c1, s1, c2, s2 = np.cos(th[0]), np.sin(th[0]), np.cos(th[1]), np.sin(th[1])
        np.testing.assert_allclose(Js[:, 1], [-c1, -s1, 0, l0 * s1, -l0 * c1, 0], atol=1e-12)
        np.testing.assert_allclose(Js[:, 2], [0, 0, 0, -s1 * c2, c1 * c2, -s2], atol=1e-12)
        np.testing.assert_allclose(Js[:, 0], S[:, 0], atol=0)  # J_s1 = S_1


def test_planar_3r_closed_form_and_singularity():
    from kinematics_node.core import is_near_singular, manipulability

    L = (0.5, 0.4, 0.2)
    table = [{"a": a, "alpha": 0, "d": 0, "theta": 0, "type": "R"} for a in L]
    chain = SerialChain.from_dh(table)
    q = np.array([0.3, -0.7, 1.1])
    x = sum(L[i] * np.cos(q[: i + 1].sum()) for i in range(3))
    y = sum(L[i] * np.sin(q[: i + 1].sum()) for i in range(3))
    np.testing.assert_allclose(chain.fk(q)[:2, 3], (x, y), atol=1e-14)
    J = chain.jacobian(q, "world")[[3, 4, 2]]  # planar rows (vx, vy, ωz)
    # det of the planar Jacobian of a 3R arm = L1 L2 sin q2 (classic closed form)
    assert np.linalg.det(J) == pytest.approx(L[0] * L[1] * np.sin(q[1]), rel=1e-12)
    straight = chain.jacobian(np.zeros(3), "world")
    assert manipulability(straight[[3, 4]], "full") == pytest.approx(0.0, abs=1e-15)
    assert is_near_singular(straight[[2, 3, 4]], "full")
    assert not is_near_singular(J, "full")
