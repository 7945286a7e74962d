"""Paden–Kahan subproblems, vectorised over any leading axes (the building blocks of closed-form IK).

Every function works on arrays with vectors along the last axis (shape (..., 3)) and broadcasts over
the leading axes, so one call solves a subproblem for many targets and branches at once. Axes are
unit vectors k through the origin: callers subtract a point r on the axis first (a point x rotated
about the axis through r by θ is r + R(k, θ)(x − r)). Angles in rad, lengths in whatever unit the
points use (m in this package).

The subproblems (Murray, Li & Sastry, *A Mathematical Introduction to Robotic Manipulation*, §3.2.2;
subproblem 4 in the form of Elias & Wen, *IK-Geo*, arXiv 2211.05737):

* SP1  R(k, θ) p = q                              one θ
* SP2  R(k₁, θ₁) R(k₂, θ₂) p = q                  up to two (θ₁, θ₂)
* SP3  ‖R(k, θ) p − q‖ = δ                        up to two θ
* SP4  hᵀ R(k, θ) p = d                           up to two θ

SP3 and SP4 reduce to the scalar equation a cos θ + b sin θ = c (`solve_trig`). Each solver reports,
per element, whether a real solution exists (`ok`) and whether the angle is undetermined (`free`:
the point lies on the axis, a singular configuration). A free angle takes the caller's `default`,
so results are always finite, never NaN. Where the discriminant is negative by no more than the
round-off tolerance the solution is taken at the tangent point (both branches equal).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: |cos| may exceed 1 by this much from round-off and still count as the tangent solution.
TANGENT_TOLERANCE = 1e-9


def dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """aᵀb of 3-vectors (last axis; written out, as a NumPy reduction over 3 elements is slow)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """a × b along the last axis (faster than np.cross on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def norm(a: FloatArray) -> FloatArray:
    """Euclidean norm of 3-vectors (last axis)."""
    return np.sqrt(dot(a, a))


def rotate(k: FloatArray, theta: FloatArray, x: FloatArray) -> FloatArray:
    """R(k, θ) x by Rodrigues' formula: x cos θ + (k × x) sin θ + k (kᵀx)(1 − cos θ) (MR eq. 3.51)."""
    c = np.cos(theta)[..., None]
    s = np.sin(theta)[..., None]
    return x * c + cross(k, x) * s + k * (dot(k, x)[..., None] * (1.0 - c))


def rotate_about(k: FloatArray, r: FloatArray, theta: FloatArray, x: FloatArray) -> FloatArray:
    """The point x turned by θ about the line through r with unit direction k: r + R(k, θ)(x − r)."""
    return r + rotate(k, theta, x - r)


def solve_trig(
    a: FloatArray, b: FloatArray, c: FloatArray, default: FloatArray, eps: float
) -> tuple[FloatArray, BoolArray, BoolArray]:
    """Both θ with a cos θ + b sin θ = c.

    With ρ = √(a² + b²) and φ = atan2(b, a): θ = φ ± arccos(c / ρ). When ρ ≤ eps the left side
    does not depend on θ: every θ solves it if |c| ≤ eps (`free`, θ = default), none otherwise.

    Returns:
        theta (..., 2) the two branches (equal at the tangent point), ok (...), free (...).
    """
    rho = np.hypot(a, b)
    free = rho <= eps
    safe = np.where(free, 1.0, rho)
    x = c / safe
    ok = np.where(free, np.abs(c) <= eps, np.abs(x) <= 1.0 + TANGENT_TOLERANCE)
    phi = np.arctan2(b, a)
    d = np.arccos(np.clip(x, -1.0, 1.0))
    theta = np.stack((phi + d, phi - d), axis=-1)
    theta = np.where(free[..., None], default[..., None], theta)
    return theta, ok, free


def sp1(
    k: FloatArray, p: FloatArray, q: FloatArray, default: FloatArray, eps: float
) -> tuple[FloatArray, BoolArray]:
    """SP1: θ with R(k, θ) p = q (p, q relative to a point on the axis).

    With p′ = p − k kᵀp and q′ = q − k kᵀq the projections onto the plane normal to k,
    θ = atan2(kᵀ(p′ × q′), p′ᵀq′). Free (θ = default) when p′ or q′ is shorter than eps (the point
    lies on the axis). Assumes the data are consistent (kᵀp = kᵀq, ‖p′‖ = ‖q′‖); the caller's
    forward-kinematics check rejects branches where they are not.

    Returns:
        theta (...), free (...).
    """
    pp = p - k * dot(k, p)[..., None]
    qp = q - k * dot(k, q)[..., None]
    free = (norm(pp) <= eps) | (norm(qp) <= eps)
    theta = np.arctan2(dot(k, cross(pp, qp)), dot(pp, qp))
    return np.where(free, default, theta), free


def sp2(
    k1: FloatArray,
    k2: FloatArray,
    p: FloatArray,
    q: FloatArray,
    default1: FloatArray,
    default2: FloatArray,
    eps: float,
) -> tuple[FloatArray, FloatArray, BoolArray, BoolArray]:
    """SP2: (θ₁, θ₂) with R(k₁, θ₁) R(k₂, θ₂) p = q, for axes k₁, k₂ that are not parallel.

    The middle point z = R(k₂, θ₂) p = R(k₁, −θ₁) q keeps k₂ᵀz = k₂ᵀp and k₁ᵀz = k₁ᵀq, so
    z = α k₁ + β k₂ + γ (k₁ × k₂) with (Murray–Li–Sastry eq. 3.36–3.38, c = k₁ᵀk₂)
        α = (c k₂ᵀp − k₁ᵀq) / (c² − 1),   β = (c k₁ᵀq − k₂ᵀp) / (c² − 1),
        γ² = (‖p‖² − α² − β² − 2αβc) / ‖k₁ × k₂‖².
    Then θ₂ = SP1(k₂, p → z) and θ₁ = SP1(k₁, R(k₂, θ₂) p → q).

    Returns:
        theta1 (..., 2), theta2 (..., 2) for γ = ±√γ², ok (...) a real solution exists,
        free (..., 2) one of the two angles is undetermined (it then takes its default).
    """
    c = dot(k1, k2)
    k12 = cross(k1, k2)
    den = c * c - 1.0
    kp, kq = dot(k2, p), dot(k1, q)
    alpha = (c * kp - kq) / den
    beta = (c * kq - kp) / den
    n2 = dot(k12, k12)
    g2 = (dot(p, p) - alpha * alpha - beta * beta - 2.0 * alpha * beta * c) / n2
    scale = np.maximum(dot(p, p), eps * eps)
    ok = g2 >= -TANGENT_TOLERANCE * scale
    gamma = np.sqrt(np.maximum(g2, 0.0))
    sign = np.array((1.0, -1.0))
    # (..., 2, 3): the two candidate middle points.
    z = (alpha[..., None] * k1 + beta[..., None] * k2)[..., None, :] + (gamma[..., None] * sign)[
        ..., None
    ] * k12[..., None, :]
    k1b, k2b = k1[..., None, :], k2[..., None, :]
    pb, qb = p[..., None, :], q[..., None, :]
    theta2, free2 = sp1(k2b, pb, z, default2[..., None], eps)
    theta1, free1 = sp1(k1b, rotate(k2b, theta2, pb), qb, default1[..., None], eps)
    return theta1, theta2, ok, free1 | free2


def sp3(
    k: FloatArray, p: FloatArray, q: FloatArray, delta: FloatArray, default: FloatArray, eps: float
) -> tuple[FloatArray, BoolArray, BoolArray]:
    """SP3: θ with ‖R(k, θ) p − q‖ = δ (p, q relative to a point on the axis).

    With p′, q′ the projections normal to k and δ′² = δ² − (kᵀ(p − q))²,
    ‖R p′ − q′‖² = δ′² gives q′ᵀ R(k, θ) p′ = (‖p′‖² + ‖q′‖² − δ′²)/2, i.e.
    a cos θ + b sin θ = c with a = p′ᵀq′, b = kᵀ(p′ × q′) (Murray–Li–Sastry eq. 3.41).

    Returns:
        theta (..., 2), ok (...), free (...).
    """
    pp = p - k * dot(k, p)[..., None]
    qp = q - k * dot(k, q)[..., None]
    dk = dot(k, p - q)
    c = 0.5 * (dot(pp, pp) + dot(qp, qp) - (delta * delta - dk * dk))
    return solve_trig(dot(pp, qp), dot(k, cross(pp, qp)), c, default, eps)


def sp4(
    k: FloatArray, p: FloatArray, h: FloatArray, d: FloatArray, default: FloatArray, eps: float
) -> tuple[FloatArray, BoolArray, BoolArray]:
    """SP4: θ with hᵀ R(k, θ) p = d (p relative to a point on the axis, h a unit vector).

    R(k, θ) p = k kᵀp + cos θ (p − k kᵀp) + sin θ (k × p), so
    a cos θ + b sin θ = c with a = hᵀ(p − k kᵀp), b = hᵀ(k × p), c = d − (hᵀk)(kᵀp).

    Returns:
        theta (..., 2), ok (...), free (...).
    """
    kp = dot(k, p)
    a = dot(h, p - k * kp[..., None])
    b = dot(h, cross(k, p))
    return solve_trig(a, b, d - dot(h, k) * kp, default, eps)


__all__ = [
    "TANGENT_TOLERANCE",
    "cross",
    "dot",
    "norm",
    "rotate",
    "rotate_about",
    "solve_trig",
    "sp1",
    "sp2",
    "sp3",
    "sp4",
]
