"""SO(3)/SE(3) toolkit: group identities, exp∘log round trips near θ = 0 and π, seed examples."""

import numpy as np
import pytest

from kinematics_node.core import se3, so3

RNG = np.random.default_rng(20261121)


def random_rotvecs(n, angles):
    axes = RNG.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return axes * np.asarray(angles)[:, None]


ANGLES = np.concatenate(
    (
        [0.0, 1e-300, 1e-12, 1e-8, 1e-5, 1e-3, 1e-2, 0.1, 1.0, 2.0, 3.0],
        [np.pi - 1e-3, np.pi - 1e-6, np.pi - 1e-9, np.pi],
        RNG.uniform(0, np.pi, 30),
    )
)


def test_hat_vee_and_cross_product():
    w, x = RNG.normal(size=(2, 50, 3))
    np.testing.assert_allclose(so3.hat(w) @ x[..., None], np.cross(w, x)[..., None], atol=1e-15)
    np.testing.assert_allclose(so3.vee(so3.hat(w)), w, atol=0)
    V = RNG.normal(size=(20, 6))
    np.testing.assert_allclose(se3.vee(se3.hat(V)), V, atol=0)


def test_so3_exp_is_a_rotation_and_matches_scipy():
    from scipy.spatial.transform import Rotation

    phi = random_rotvecs(len(ANGLES), ANGLES)
    R = so3.exp(phi)
    np.testing.assert_allclose(
        R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-15
    )
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    np.testing.assert_allclose(R, Rotation.from_rotvec(phi).as_matrix(), atol=1e-15)


def test_so3_log_round_trip_including_zero_and_pi():
    phi = random_rotvecs(len(ANGLES), ANGLES)
    back = so3.log(so3.exp(phi))
    theta = np.linalg.norm(phi, axis=1)
    at_pi = np.isclose(theta, np.pi, atol=1e-7)
    # Away from π the rotation vector is unique; at π, ±ω̂π are the same rotation.
    np.testing.assert_allclose(back[~at_pi], phi[~at_pi], atol=1e-12, rtol=0)
    np.testing.assert_allclose(so3.exp(back), so3.exp(phi), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(back[at_pi], axis=1), theta[at_pi], atol=1e-7)


def test_so3_log_tiny_angle_keeps_relative_precision():
    phi = np.array([3e-10, -1e-10, 2e-10])
    np.testing.assert_allclose(so3.log(so3.exp(phi)), phi, rtol=1e-6)


def test_se3_exp_log_round_trip_and_group_identities():
    phi = random_rotvecs(len(ANGLES), ANGLES)
    rho = RNG.normal(size=phi.shape)
    xi = np.concatenate((phi, rho), axis=1)
    T = se3.exp(xi)
    back = se3.log(T)
    np.testing.assert_allclose(se3.exp(back), T, atol=1e-11)
    theta = np.linalg.norm(phi, axis=1)
    regular = theta < np.pi - 1e-6
    np.testing.assert_allclose(back[regular], xi[regular], atol=1e-9)
    # exp of a twist and of its matrix agree with SciPy's general matrix exponential.
    from scipy.linalg import expm

    for x in xi[::5]:
        np.testing.assert_allclose(se3.exp(x), expm(se3.hat(x)), atol=1e-12)
    Ti = se3.inverse(T)
    np.testing.assert_allclose(T @ Ti, np.broadcast_to(np.eye(4), T.shape), atol=1e-12)


def test_se3_pure_translation():
    T = se3.exp([0, 0, 0, 1.0, -2.0, 3.0])
    np.testing.assert_allclose(T, [[1, 0, 0, 1], [0, 1, 0, -2], [0, 0, 1, 3], [0, 0, 0, 1]], atol=0)


def test_adjoint_identities():
    T1 = se3.exp(RNG.normal(size=6))
    T2 = se3.exp(RNG.normal(size=6))
    np.testing.assert_allclose(se3.adjoint(T1) @ se3.adjoint(T2), se3.adjoint(T1 @ T2), atol=1e-12)
    np.testing.assert_allclose(
        np.linalg.inv(se3.adjoint(T1)), se3.adjoint(se3.inverse(T1)), atol=1e-12
    )
    # T exp([V]) T⁻¹ = exp([Ad_T V]) (MR prop. 3.29 generalised)
    V = RNG.normal(size=6)
    np.testing.assert_allclose(
        T1 @ se3.exp(V) @ se3.inverse(T1), se3.exp(se3.transform_twist(T1, V)), atol=1e-11
    )


def test_power_is_frame_invariant():
    T_ab = se3.exp(RNG.normal(size=6))
    V_b = RNG.normal(size=6)
    F_a = RNG.normal(size=6)
    V_a = se3.transform_twist(T_ab, V_b)
    F_b = se3.transform_wrench(T_ab, F_a)
    assert V_a @ F_a == pytest.approx(V_b @ F_b, rel=1e-12)


# --------------------------------------------------------------- seed 003 worked examples
def test_seed_screw_example_T_ab_after_pi():
    """Screw with pitch 5 mm/rad; {b} at (0, 4, −2) mm: S_a, S_b and T_ab' at θ = π (seed 003)."""
    T_ab = np.array([[0, 0, 1, 0], [1, 0, 0, 4], [0, 1, 0, -2], [0, 0, 0, 1.0]])
    S_a = se3.screw_axis(q=[0, 0, 0], s_hat=[0, 0, 1], h=5.0)
    np.testing.assert_allclose(S_a, [0, 0, 1, 0, 0, 5])
    S_b = se3.transform_twist(se3.inverse(T_ab), S_a)
    np.testing.assert_allclose(S_b, [0, 1, 0, 0, 5, -4], atol=1e-15)
    expected = np.array([[0, 0, -1, 0], [-1, 0, 0, -4], [0, 1, 0, 5 * np.pi - 2], [0, 0, 0, 1]])
    np.testing.assert_allclose(T_ab @ se3.exp(S_b * np.pi), expected, atol=1e-12)
    np.testing.assert_allclose(se3.exp(S_a * np.pi) @ T_ab, expected, atol=1e-12)


def test_seed_car_example():
    """Car {b} at (4, 1, 0) turning with radius 2: S_b = (0,0,1,0,2,0), S_s = (0,0,1,1,−2,0)."""
    S_b = se3.screw_axis(q=[-2, 0, 0], s_hat=[0, 0, 1], h=0.0)
    S_s = se3.screw_axis(q=[2, 1, 0], s_hat=[0, 0, 1], h=0.0)
    np.testing.assert_allclose(S_b, [0, 0, 1, 0, 2, 0], atol=0)
    np.testing.assert_allclose(S_s, [0, 0, 1, 1, -2, 0], atol=0)
    T_sb = np.eye(4)
    T_sb[:3, 3] = (4, 1, 0)
    np.testing.assert_allclose(se3.transform_twist(T_sb, S_b), S_s, atol=1e-15)
    # A quarter turn: T_sb' = exp([S_s]π/2) T_sb = T_sb exp([S_b]π/2); the car ends at (2, 3, 0).
    th = np.pi / 2
    T1 = se3.exp(S_s * th) @ T_sb
    np.testing.assert_allclose(T1, T_sb @ se3.exp(S_b * th), atol=1e-12)
    np.testing.assert_allclose(T1[:3, 3], [2, 3, 0], atol=1e-12)


def test_seed_apple_wrench():
    """3 N apple at r = (L1 + L2, 0, 0): F_f = (0, 0, −3(L1 + L2), 0, −3, 0) (seed 003)."""
    L = 0.7
    F_apple = np.array([0, 0, 0, 0, -3.0, 0])  # wrench in a frame at the apple, aligned with {f}
    T_apple_f = np.eye(4)
    T_apple_f[:3, 3] = (-L, 0, 0)  # {f} seen from the apple frame
    F_f = se3.transform_wrench(T_apple_f, F_apple)
    np.testing.assert_allclose(F_f, [0, 0, -3 * L, 0, -3, 0], atol=1e-15)
