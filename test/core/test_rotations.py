"""Rotation representations: SciPy as the oracle, round trips, singular cases, bad input."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinematics_node.core import InvalidInputError, rotations

RNG = np.random.default_rng(7)
R_RANDOM = Rotation.random(200, random_state=3).as_matrix()


def _near_pi_and_zero():
    axes = RNG.normal(size=(8, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.array([0.0, 1e-10, 1e-6, np.pi - 1e-9, np.pi, np.pi - 1e-5, 1e-3, np.pi])
    return Rotation.from_rotvec(axes * angles[:, None]).as_matrix()


ALL_R = np.concatenate(
    (R_RANDOM, _near_pi_and_zero(), np.eye(3)[None], np.diag([1.0, -1, -1])[None])
)


def test_quaternion_matches_scipy_up_to_sign_and_round_trips():
    q = rotations.quaternion_from_matrix(ALL_R)
    q_ref = Rotation.from_matrix(ALL_R).as_quat()  # (x, y, z, w) too
    sign = np.sign(np.sum(q * q_ref, axis=1))[:, None]
    np.testing.assert_allclose(q, sign * q_ref, atol=1e-12)
    assert np.all(q[:, 3] >= 0)
    np.testing.assert_allclose(rotations.matrix_from_quaternion(q), ALL_R, atol=1e-12)


def test_matrix_from_quaternion_normalises_and_refuses_zero():
    q = np.array([0.1, -0.2, 0.3, 0.9])
    np.testing.assert_allclose(
        rotations.matrix_from_quaternion(5 * q), Rotation.from_quat(q).as_matrix(), atol=1e-14
    )
    # components whose sum of squares overflows: the same rotation (it was the identity)
    for scale in (1e160, 1e300):
        np.testing.assert_allclose(
            rotations.matrix_from_quaternion(scale * q),
            Rotation.from_quat(q).as_matrix(),
            atol=1e-14,
        )
    with pytest.raises(InvalidInputError, match="zero norm"):
        rotations.matrix_from_quaternion([0, 0, 0, 0])
    with pytest.raises(InvalidInputError, match="non-finite"):
        rotations.matrix_from_quaternion([0, 0, np.nan, 1])
    with pytest.raises(InvalidInputError, match="shape"):
        rotations.matrix_from_quaternion([0, 0, 1])


def test_quaternion_product_composes_rotations():
    a, b = Rotation.random(2, random_state=5)
    qa, qb = a.as_quat(), b.as_quat()
    np.testing.assert_allclose(
        rotations.matrix_from_quaternion(rotations.quaternion_multiply(qa, qb)),
        a.as_matrix() @ b.as_matrix(),
        atol=1e-14,
    )


def test_axis_angle_round_trip():
    axis, angle = rotations.axis_angle_from_matrix(ALL_R)
    assert np.all((angle >= 0) & (angle <= np.pi + 1e-15))
    np.testing.assert_allclose(rotations.matrix_from_axis_angle(axis, angle), ALL_R, atol=1e-9)
    # Rodrigues formula of the seed slides: v' = v cos θ + (r × v) sin θ + (1 − cos θ)(rᵀv) r
    r = np.array([1.0, 2.0, 2.0]) / 3.0
    th, v = 0.7, np.array([0.3, -1.0, 2.0])
    expected = v * np.cos(th) + np.cross(r, v) * np.sin(th) + (1 - np.cos(th)) * (r @ v) * r
    np.testing.assert_allclose(rotations.matrix_from_axis_angle(r, th) @ v, expected, atol=1e-15)


def test_rpy_matches_scipy_extrinsic_xyz():
    rpy = rotations.rpy_from_matrix(R_RANDOM)
    np.testing.assert_allclose(rpy, Rotation.from_matrix(R_RANDOM).as_euler("xyz"), atol=1e-10)
    np.testing.assert_allclose(rotations.matrix_from_rpy(rpy), R_RANDOM, atol=1e-12)
    assert np.all(np.abs(rpy[:, 1]) <= np.pi / 2)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
def test_rpy_singular_case_sets_yaw_zero_and_stays_exact(pitch):
    R = rotations.matrix_from_rpy([0.4, pitch, -1.1])
    roll, p, yaw = rotations.rpy_from_matrix(R)
    assert yaw == 0.0
    assert p == pytest.approx(pitch, abs=1e-8)
    np.testing.assert_allclose(rotations.matrix_from_rpy([roll, p, yaw]), R, atol=1e-12)


@pytest.mark.parametrize(
    "name, seq",
    [("zxz", "ZXZ"), ("zyz", "ZYZ")],
)
def test_euler_matches_scipy_intrinsic(name, seq):
    to = getattr(rotations, f"euler_{name}_from_matrix")
    back = getattr(rotations, f"matrix_from_euler_{name}")
    ang = to(R_RANDOM)
    np.testing.assert_allclose(ang, Rotation.from_matrix(R_RANDOM).as_euler(seq), atol=1e-10)
    np.testing.assert_allclose(back(ang), R_RANDOM, atol=1e-12)
    assert np.all((ang[:, 1] >= 0) & (ang[:, 1] <= np.pi))


@pytest.mark.parametrize("name", ["zxz", "zyz"])
@pytest.mark.parametrize("theta", [0.0, np.pi])
def test_euler_singular_cases_are_exact(name, theta):
    to = getattr(rotations, f"euler_{name}_from_matrix")
    back = getattr(rotations, f"matrix_from_euler_{name}")
    R = back([0.8, theta, 0.3])
    phi, th, psi = to(R)
    assert psi == 0.0
    assert th == pytest.approx(theta, abs=1e-8)
    np.testing.assert_allclose(back([phi, th, psi]), R, atol=1e-12)


def test_zxz_matches_seed_closed_form():
    """Entries of R_ZX'Z'' from De Luca's slide, e.g. r13 = sφ sθ, r32 = sθ cψ, r33 = cθ."""
    phi, th, psi = 0.3, 1.1, -0.6
    R = rotations.matrix_from_euler_zxz([phi, th, psi])
    s, c = np.sin, np.cos
    assert R[0, 2] == pytest.approx(s(phi) * s(th))
    assert R[1, 2] == pytest.approx(-c(phi) * s(th))
    assert R[2, 1] == pytest.approx(s(th) * c(psi))
    assert R[0, 0] == pytest.approx(c(phi) * c(psi) - s(phi) * c(th) * s(psi))
