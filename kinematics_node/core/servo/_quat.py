"""Unit quaternions (x, y, z, w) on plain floats, for the servo's per-period pose arithmetic.

`so3.exp`/`so3.log` work on arrays of any batch shape and cost tens of µs on one rotation; these
cost about 1 µs. Inputs are not checked (the servo only passes finite values it computed).
"""

from __future__ import annotations

import math

Quat = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]


def mul(a: Quat, b: Quat) -> Quat:
    """Hamilton product a ⊗ b (the rotation b, then a, as R_a R_b)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def conj(q: Quat) -> Quat:
    """The inverse rotation."""
    return (-q[0], -q[1], -q[2], q[3])


def normalized(q: Quat) -> Quat:
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def from_rotvec(x: float, y: float, z: float) -> Quat:
    """exp of the rotation vector φ = (x, y, z) [rad]: (sin(θ/2) φ/θ, cos(θ/2)), θ = ‖φ‖."""
    theta = math.sqrt(x * x + y * y + z * z)
    half = 0.5 * theta
    s = math.sin(half) / theta if theta > 1e-8 else 0.5 - theta * theta / 48.0
    return (x * s, y * s, z * s, math.cos(half))


def to_rotvec(q: Quat) -> Vec3:
    """log: the rotation vector φ with θ = ‖φ‖ ∈ [0, π] (the shorter way round)."""
    x, y, z, w = q
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    f = 2.0 * math.atan2(s, w) / s if s > 1e-12 else 2.0 / w
    return (x * f, y * f, z * f)
