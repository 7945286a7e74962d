"""Scalar fast path for the pose error of one configuration (plain Python floats, no NumPy).

`se3.log` is vectorised NumPy; for a single 4×4 its per-call overhead (~30–50 µs) would dominate an
IK iteration. These functions compute the same quantities with the `math` module. Poses are passed
as 12 floats: the rotation row-major, then the position (the layout of `Kernel.fk_jacobian_scalar`).

Numerics follow `so3.log` / `se3.log`: the rotation vector comes from the quaternion (Shepperd's
method), so it stays accurate near θ = 0 and θ = π; the V⁻¹ coefficient uses its series below
θ = 1e-2. Tests compare these against `se3.log` and `so3.log`, including θ ≈ 0 and θ ≈ π.
"""

from __future__ import annotations

from math import atan2, sqrt, tan

Pose12 = tuple[float, ...]


def relative_pose(T_base_cur: Pose12, T_base_tgt: Pose12) -> Pose12:
    """T_cur_tgt = T_base_cur⁻¹ T_base_tgt = [[R_cᵀR_t, R_cᵀ(p_t − p_c)], [0, 1]] (MR eq. 3.64)."""
    a00, a01, a02, a10, a11, a12, a20, a21, a22, ax, ay, az = T_base_cur
    b00, b01, b02, b10, b11, b12, b20, b21, b22, bx, by, bz = T_base_tgt
    dx, dy, dz = bx - ax, by - ay, bz - az
    return (
        a00 * b00 + a10 * b10 + a20 * b20,
        a00 * b01 + a10 * b11 + a20 * b21,
        a00 * b02 + a10 * b12 + a20 * b22,
        a01 * b00 + a11 * b10 + a21 * b20,
        a01 * b01 + a11 * b11 + a21 * b21,
        a01 * b02 + a11 * b12 + a21 * b22,
        a02 * b00 + a12 * b10 + a22 * b20,
        a02 * b01 + a12 * b11 + a22 * b21,
        a02 * b02 + a12 * b12 + a22 * b22,
        a00 * dx + a10 * dy + a20 * dz,
        a01 * dx + a11 * dy + a21 * dz,
        a02 * dx + a12 * dy + a22 * dz,
    )


def so3_log(R: Pose12) -> tuple[float, float, float, float]:
    """Rotation vector φ = ω̂θ (θ ∈ [0, π]) of the rotation in the first 9 entries, and θ [rad].

    Same method and axis-sign convention at θ = π as `so3.log`: quaternion by Shepperd's method
    with w ≥ 0, then θ = 2 atan2(‖ε‖, w) and φ = (θ/‖ε‖) ε, with the limit 2/w as ‖ε‖ → 0.
    """
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = R[:9]
    tr = m00 + m11 + m22
    # Largest of the four pivots 4x², 4y², 4z², 4w² (minus 0) picks the well-conditioned formula.
    p0, p1, p2, p3 = 1.0 + 2.0 * m00 - tr, 1.0 + 2.0 * m11 - tr, 1.0 + 2.0 * m22 - tr, 1.0 + tr
    if p3 >= p0 and p3 >= p1 and p3 >= p2:
        r = sqrt(max(p3, 0.0))
        s = 0.5 / r
        x, y, z, w = (m21 - m12) * s, (m02 - m20) * s, (m10 - m01) * s, 0.5 * r
    elif p0 >= p1 and p0 >= p2:
        r = sqrt(max(p0, 0.0))
        s = 0.5 / r
        x, y, z, w = 0.5 * r, (m10 + m01) * s, (m02 + m20) * s, (m21 - m12) * s
    elif p1 >= p2:
        r = sqrt(max(p1, 0.0))
        s = 0.5 / r
        x, y, z, w = (m10 + m01) * s, 0.5 * r, (m21 + m12) * s, (m02 - m20) * s
    else:
        r = sqrt(max(p2, 0.0))
        s = 0.5 / r
        x, y, z, w = (m02 + m20) * s, (m21 + m12) * s, 0.5 * r, (m10 - m01) * s
    norm = sqrt(x * x + y * y + z * z + w * w)
    if w < 0.0:
        norm = -norm
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    sn = sqrt(x * x + y * y + z * z)
    theta = 2.0 * atan2(sn, w)
    # θ/‖ε‖ → 2/w as ‖ε‖ → 0 (cubic term of atan2 below 1e-18 there); w ≈ 1 in that branch.
    factor = 2.0 / w if sn < 1e-9 else theta / sn
    return x * factor, y * factor, z * factor, theta


def se3_log(T: Pose12) -> tuple[float, float, float, float, float, float, float]:
    """Exponential coordinates (ω̂θ, vθ) of T (MR §3.3.3.2) and the rotation angle θ [rad].

    ρ = V⁻¹ p with V⁻¹ = I − ½[φ] + d [φ]², d = 1/θ² − cot(θ/2)/(2θ) (→ 1/12 as θ → 0).
    """
    wx, wy, wz, theta = so3_log(T)
    px, py, pz = T[9], T[10], T[11]
    if theta < 1e-2:
        t2 = theta * theta
        d = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    else:
        d = 1.0 / (theta * theta) - 0.5 / (theta * tan(0.5 * theta))
    # c1 = φ × p, c2 = φ × (φ × p)
    c1x, c1y, c1z = wy * pz - wz * py, wz * px - wx * pz, wx * py - wy * px
    c2x, c2y, c2z = wy * c1z - wz * c1y, wz * c1x - wx * c1z, wx * c1y - wy * c1x
    return (
        wx,
        wy,
        wz,
        px - 0.5 * c1x + d * c2x,
        py - 0.5 * c1y + d * c2y,
        pz - 0.5 * c1z + d * c2z,
        theta,
    )
