"""SO(3): skew matrices, exponential and logarithm, vectorised over leading axes.

Exponential coordinates are rotation vectors φ = ω̂θ ∈ R³ (Modern Robotics §3.2.3). Every function
accepts arrays with any number of leading batch axes, e.g. (3,) or (N, 3) for vectors and (3, 3) or
(N, 3, 3) for matrices. Inputs are not validated here; public entry points validate once.

Numerics: the Rodrigues coefficients are written with `numpy.sinc`, which is exact at θ = 0 and needs
no small-angle branch; the logarithm goes through the quaternion (Shepperd's method), which stays
accurate near θ = 0 and near θ = π where the trace formula loses all precision.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def hat(omega: ArrayLike) -> FloatArray:
    """[ω]: the 3×3 skew-symmetric matrix with [ω] x = ω × x (MR eq. 3.30)."""
    w = np.asarray(omega, dtype=np.float64)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def vee(W: ArrayLike) -> FloatArray:
    """Inverse of `hat`: the vector ω of a skew-symmetric [ω] (the antisymmetric part is used)."""
    M = np.asarray(W, dtype=np.float64)
    return 0.5 * np.stack(
        (M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]),
        axis=-1,
    )


def exp(phi: ArrayLike) -> FloatArray:
    """R = exp([φ]) = I + (sin θ/θ)[φ] + ((1 − cos θ)/θ²)[φ]², θ = ‖φ‖ (Rodrigues, MR eq. 3.51)."""
    p = np.asarray(phi, dtype=np.float64)
    theta = np.linalg.norm(p, axis=-1)[..., None, None]
    a = np.sinc(theta / np.pi)  # sin θ / θ
    b = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2  # (1 − cos θ)/θ² = ½ (sin(θ/2)/(θ/2))²
    K = hat(p)
    return np.eye(3) + a * K + b * (K @ K)


def quaternion_from_matrix(R: ArrayLike) -> FloatArray:
    """Unit quaternion (x, y, z, w) of a rotation matrix, w ≥ 0, by Shepperd's method.

    Order is scalar-last, as in ROS messages and `scipy.spatial.transform.Rotation`.
    """
    M = np.asarray(R, dtype=np.float64)
    m00, m11, m22 = M[..., 0, 0], M[..., 1, 1], M[..., 2, 2]
    tr = m00 + m11 + m22
    # Four candidate formulas; pick per element the one with the largest (well-conditioned) pivot.
    pivots = np.stack(
        (1.0 + 2.0 * m00 - tr, 1.0 + 2.0 * m11 - tr, 1.0 + 2.0 * m22 - tr, 1.0 + tr), -1
    )
    k = np.argmax(pivots, axis=-1)
    r = np.sqrt(np.maximum(np.take_along_axis(pivots, k[..., None], -1)[..., 0], 0.0))
    s = 0.5 / np.where(r > 0, r, 1.0)
    d21, d02, d10 = (
        M[..., 2, 1] - M[..., 1, 2],
        M[..., 0, 2] - M[..., 2, 0],
        M[..., 1, 0] - M[..., 0, 1],
    )
    s21, s02, s10 = (
        M[..., 2, 1] + M[..., 1, 2],
        M[..., 0, 2] + M[..., 2, 0],
        M[..., 1, 0] + M[..., 0, 1],
    )
    cand = np.stack(
        (
            np.stack((0.5 * r, s10 * s, s02 * s, d21 * s), -1),
            np.stack((s10 * s, 0.5 * r, s21 * s, d02 * s), -1),
            np.stack((s02 * s, s21 * s, 0.5 * r, d10 * s), -1),
            np.stack((d21 * s, d02 * s, d10 * s, 0.5 * r), -1),
        ),
        -2,
    )
    q = np.take_along_axis(cand, k[..., None, None], -2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0.0, -q, q)


def quaternion_from_rows(m: Sequence[float]) -> tuple[float, float, float, float]:
    """`quaternion_from_matrix` of one rotation given as 9 floats, row-major: (x, y, z, w), w ≥ 0.

    The same Shepperd's method (largest pivot) in a few float operations, with no array: about
    1 µs against tens of µs for the array routine on a single matrix. For hot paths (the node's
    pose publishing); `m` is not checked.
    """
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m[:9]
    tr = m00 + m11 + m22
    pivots = (1.0 + 2.0 * m00 - tr, 1.0 + 2.0 * m11 - tr, 1.0 + 2.0 * m22 - tr, 1.0 + tr)
    k = max(range(4), key=pivots.__getitem__)
    r = math.sqrt(max(pivots[k], 0.0))
    s = 0.5 / r if r > 0 else 0.5
    if k == 0:
        q = (0.5 * r, (m10 + m01) * s, (m02 + m20) * s, (m21 - m12) * s)
    elif k == 1:
        q = ((m10 + m01) * s, 0.5 * r, (m21 + m12) * s, (m02 - m20) * s)
    elif k == 2:
        q = ((m02 + m20) * s, (m21 + m12) * s, 0.5 * r, (m10 - m01) * s)
    else:
        q = ((m21 - m12) * s, (m02 - m20) * s, (m10 - m01) * s, 0.5 * r)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[3] < 0.0:
        n = -n
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def rows_from_quaternion(x: float, y: float, z: float, w: float) -> tuple[float, ...]:
    """The rotation of a non-zero quaternion (x, y, z, w), normalised first, as 9 floats,
    row-major: `rotations.matrix_from_quaternion` of one quaternion in a few float operations,
    without its checks and arrays (~1 µs against ~50 µs), for the node's per-request path.
    `x, y, z, w` are not checked; the caller refuses non-finite and zero quaternions."""
    n = math.hypot(x, y, z, w)  # (no overflow for huge components, unlike a sum of squares)
    x, y, z, w = x / n, y / n, z / n, w / n
    s = 2.0
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    # fmt: off
    return (
        1.0 - (yy + zz), xy - wz, xz + wy,
        xy + wz, 1.0 - (xx + zz), yz - wx,
        xz - wy, yz + wx, 1.0 - (xx + yy),
    )
    # fmt: on


def log(R: ArrayLike) -> FloatArray:
    """Rotation vector φ = ω̂θ with θ ∈ [0, π] such that exp([φ]) = R (MR §3.2.3.3).

    Computed from the quaternion: θ = 2 atan2(‖ε‖, η). At θ = π the axis sign is arbitrary (both
    ±ω̂π give R) and either may be returned: which one depends on the branch of Shepperd's method
    that extracted the quaternion. exp(log(R)) = R holds in both cases.
    """
    q = quaternion_from_matrix(R)
    v, w = q[..., :3], q[..., 3]
    s = np.linalg.norm(v, axis=-1)
    theta = 2.0 * np.arctan2(s, w)
    # θ/s → 2/w as s → 0 (atan2(s, w) = s/w − (s/w)³/3 + …; the cubic term is below 1e-18 there).
    small = s < 1e-9
    factor = np.where(small, 2.0 / np.where(small, w, 1.0), theta / np.where(small, 1.0, s))
    return v * factor[..., None]
