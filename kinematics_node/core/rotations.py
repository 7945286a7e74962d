"""Rotation representations and conversions, vectorised over leading axes.

Conventions (stated once here, and in docs/conventions.md):

* quaternion: (x, y, z, w), scalar last, as in ROS messages and SciPy; returned with w ≥ 0.
* axis-angle: unit axis r and angle θ; a rotation vector is φ = rθ (see `so3`).
* roll-pitch-yaw (ψ, θ, φ) = rotations about the *fixed* X, Y, Z axes:
  R = R_Z(φ) R_Y(θ) R_X(ψ) (De Luca, "Minimal representations", RPY slide). URDF `rpy` is this.
* ZX'Z'' Euler (φ, θ, ψ): R = R_Z(φ) R_X'(θ) R_Z''(ψ) about *moving* axes; ZY'Z'' likewise.

Inverse problems return the solution branch with cos θ ≥ 0 (RPY) or sin θ ≥ 0 (ZXZ/ZYZ). At the
singular cases (RPY θ = ±π/2, Euler θ ∈ {0, π}) only a sum or difference of the outer angles is
defined; the last angle is then set to 0 and the first carries the whole rotation, which is exact.

Hand-written rather than `scipy.spatial.transform.Rotation` because these are called per message at
100 Hz and per IK iteration, where SciPy's object construction costs more than the arithmetic, and
because the singular cases must follow the slides' conventions. SciPy is the test oracle.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import so3
from ._checks import as_float_array, check_finite, check_trailing_shape
from .exceptions import InvalidInputError

FloatArray = NDArray[np.float64]

#: |cos θ| (RPY) or |sin θ| (Euler) below which the inverse problem is treated as singular.
SINGULAR_TOLERANCE = 1e-9

quaternion_from_matrix = so3.quaternion_from_matrix


def matrix_from_quaternion(quaternion: ArrayLike, *, normalize: bool = True) -> FloatArray:
    """Rotation matrix of a quaternion (x, y, z, w).

    The rule, as in the ComputeIK service and tf2: any finite non-zero quaternion is normalised
    first (so (0, 0, 0, 2) is the identity); a zero quaternion, which has no direction, is refused.

    Raises:
        InvalidInputError: wrong shape, non-finite entries or a norm below 1e-9.
    """
    q = as_float_array(quaternion, "quaternion")
    check_trailing_shape(q, (4,), "quaternion")
    check_finite(q, "quaternion")
    # the norm of q scaled by its largest component: a sum of squares overflows for components
    # above ~1e154 (to inf, and q / inf is the zero quaternion, read as the identity)
    s = np.max(np.abs(q), axis=-1, keepdims=True)
    unit = q / np.where(s > 0, s, 1.0)
    u = np.linalg.norm(unit, axis=-1, keepdims=True)
    if np.any(s * u < 1e-9):
        raise InvalidInputError(
            "quaternion (x, y, z, w) has zero norm; give any non-zero quaternion (it is normalised)"
        )
    if normalize:
        q = unit / u
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def quaternion_multiply(q1: ArrayLike, q2: ArrayLike) -> FloatArray:
    """Hamilton product q1 * q2 of (x, y, z, w) quaternions (De Luca, unit quaternion slide)."""
    a, b = np.asarray(q1, dtype=np.float64), np.asarray(q2, dtype=np.float64)
    e1, n1, e2, n2 = a[..., :3], a[..., 3:], b[..., :3], b[..., 3:]
    eps = n1 * e2 + n2 * e1 + np.cross(e1, e2)
    eta = n1 * n2 - np.sum(e1 * e2, axis=-1, keepdims=True)
    return np.concatenate((eps, eta), axis=-1)


def matrix_from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> FloatArray:
    """R(θ, r) = r rᵀ + (I − r rᵀ) cos θ + [r] sin θ for a unit axis r (normalised here)."""
    r = as_float_array(axis, "axis")
    check_trailing_shape(r, (3,), "axis")
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise InvalidInputError("rotation axis has zero norm")
    th = np.asarray(angle, dtype=np.float64)[..., None]
    return so3.exp(r / n * th)


def axis_angle_from_matrix(R: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """(unit axis r, angle θ ∈ [0, π]) of R. For θ = 0 the axis is undefined; (0, 0, 1) is returned."""
    phi = so3.log(R)
    theta = np.linalg.norm(phi, axis=-1)
    safe = np.where(theta > 0, theta, 1.0)[..., None]
    axis = np.where(theta[..., None] > 0, phi / safe, np.array([0.0, 0.0, 1.0]))
    return axis, theta


def _rx(a: FloatArray) -> FloatArray:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack(
        (np.stack((o, z, z), -1), np.stack((z, c, -s), -1), np.stack((z, s, c), -1)), -2
    )


def _ry(a: FloatArray) -> FloatArray:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack(
        (np.stack((c, z, s), -1), np.stack((z, o, z), -1), np.stack((-s, z, c), -1)), -2
    )


def _rz(a: FloatArray) -> FloatArray:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack(
        (np.stack((c, -s, z), -1), np.stack((s, c, z), -1), np.stack((z, z, o), -1)), -2
    )


def _angles(angles: ArrayLike, name: str) -> FloatArray:
    a = as_float_array(angles, name)
    check_trailing_shape(a, (3,), name)
    check_finite(a, name)
    return a


def matrix_from_rpy(rpy: ArrayLike) -> FloatArray:
    """R = R_Z(yaw) R_Y(pitch) R_X(roll) for rpy = (roll, pitch, yaw) about fixed axes."""
    a = _angles(rpy, "rpy")
    return _rz(a[..., 2]) @ _ry(a[..., 1]) @ _rx(a[..., 0])


def rpy_from_matrix(R: ArrayLike) -> FloatArray:
    """(roll, pitch, yaw) with pitch ∈ [−π/2, π/2] (De Luca, RPY inverse problem).

    θ = atan2(−r31, √(r32² + r33²)); ψ = atan2(r32, r33); φ = atan2(r21, r11). At θ = ±π/2 only
    ψ ∓ φ (roll ∓ yaw) is defined: yaw is set to 0 and roll = atan2(±r12, r22) carries the
    rotation.
    """
    M = np.asarray(R, dtype=np.float64)
    c = np.hypot(M[..., 2, 1], M[..., 2, 2])
    pitch = np.arctan2(-M[..., 2, 0], c)
    singular = c < SINGULAR_TOLERANCE
    roll = np.arctan2(M[..., 2, 1], M[..., 2, 2])
    yaw = np.arctan2(M[..., 1, 0], M[..., 0, 0])
    # Singular: R = R_Y(±π/2) R_X(ψ ∓ φ) … with φ = 0: r12 = sθ sψ, r22 = cψ.
    s = np.sign(-M[..., 2, 0])
    roll_sing = np.arctan2(s * M[..., 0, 1], M[..., 1, 1])
    roll = np.where(singular, roll_sing, roll)
    yaw = np.where(singular, 0.0, yaw)
    return np.stack((roll, pitch, yaw), axis=-1)


def matrix_from_euler_zxz(angles: ArrayLike) -> FloatArray:
    """R = R_Z(φ) R_X'(θ) R_Z''(ψ) for ZX'Z'' Euler angles (φ, θ, ψ) (De Luca, Euler slide)."""
    a = _angles(angles, "euler_zxz")
    return _rz(a[..., 0]) @ _rx(a[..., 1]) @ _rz(a[..., 2])


def euler_zxz_from_matrix(R: ArrayLike) -> FloatArray:
    """ZX'Z'' angles (φ, θ, ψ) with θ ∈ [0, π]: θ = atan2(√(r13² + r23²), r33),
    φ = atan2(r13, −r23), ψ = atan2(r31, r32). Singular (sin θ = 0): ψ = 0, φ from r21, r11.
    """
    M = np.asarray(R, dtype=np.float64)
    s = np.hypot(M[..., 0, 2], M[..., 1, 2])
    theta = np.arctan2(s, M[..., 2, 2])
    phi = np.arctan2(M[..., 0, 2], -M[..., 1, 2])
    psi = np.arctan2(M[..., 2, 0], M[..., 2, 1])
    singular = s < SINGULAR_TOLERANCE
    # θ = 0: R = R_Z(φ + ψ); θ = π: R = R_Z(φ) R_X(π) R_Z(ψ) = R_Z(φ − ψ) diag(1, −1, −1).
    phi = np.where(singular, np.arctan2(M[..., 1, 0], M[..., 0, 0]), phi)
    psi = np.where(singular, 0.0, psi)
    return np.stack((phi, theta, psi), axis=-1)


def matrix_from_euler_zyz(angles: ArrayLike) -> FloatArray:
    """R = R_Z(φ) R_Y'(θ) R_Z''(ψ) for ZY'Z'' Euler angles (φ, θ, ψ)."""
    a = _angles(angles, "euler_zyz")
    return _rz(a[..., 0]) @ _ry(a[..., 1]) @ _rz(a[..., 2])


def euler_zyz_from_matrix(R: ArrayLike) -> FloatArray:
    """ZY'Z'' angles (φ, θ, ψ) with θ ∈ [0, π]: θ = atan2(√(r13² + r23²), r33),
    φ = atan2(r23, r13), ψ = atan2(r32, −r31). Singular (sin θ = 0): ψ = 0, φ from r21, r11.
    """
    M = np.asarray(R, dtype=np.float64)
    s = np.hypot(M[..., 0, 2], M[..., 1, 2])
    theta = np.arctan2(s, M[..., 2, 2])
    phi = np.arctan2(M[..., 1, 2], M[..., 0, 2])
    psi = np.arctan2(M[..., 2, 1], -M[..., 2, 0])
    singular = s < SINGULAR_TOLERANCE
    # θ = 0: R = R_Z(φ + ψ); θ = π: R = R_Z(φ − ψ) diag(−1, 1, −1), so the first column flips sign.
    flip = np.where(M[..., 2, 2] < 0, -1.0, 1.0)
    phi = np.where(singular, np.arctan2(flip * M[..., 1, 0], flip * M[..., 0, 0]), phi)
    psi = np.where(singular, 0.0, psi)
    return np.stack((phi, theta, psi), axis=-1)
