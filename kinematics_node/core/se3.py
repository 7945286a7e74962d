"""SE(3): homogeneous transforms, twists, exponential and logarithm, adjoint, wrenches.

Twists, screw axes and exponential coordinates are ordered (ω, v) as in Modern Robotics; wrenches
are (m, f). All functions are vectorised over leading axes; none validates its input (the public
entry points do that once).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import so3

FloatArray = NDArray[np.float64]


def make_transform(R: ArrayLike, p: ArrayLike) -> FloatArray:
    """T = [[R, p], [0, 1]] from a rotation (..., 3, 3) and a position (..., 3)."""
    Rm, pv = np.asarray(R, dtype=np.float64), np.asarray(p, dtype=np.float64)
    shape = np.broadcast_shapes(Rm.shape[:-2], pv.shape[:-1])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = Rm
    T[..., :3, 3] = pv
    T[..., 3, 3] = 1.0
    return T


def inverse(T: ArrayLike) -> FloatArray:
    """T⁻¹ = [[Rᵀ, −Rᵀp], [0, 1]] (MR eq. 3.64)."""
    Tm = np.asarray(T, dtype=np.float64)
    Rt = np.swapaxes(Tm[..., :3, :3], -1, -2)
    return make_transform(Rt, -(Rt @ Tm[..., :3, 3:4])[..., 0])


def hat(twist: ArrayLike) -> FloatArray:
    """[V] = [[[ω], v], [0, 0]] ∈ se(3) for V = (ω, v) (MR eq. 3.70)."""
    V = np.asarray(twist, dtype=np.float64)
    out = np.zeros(V.shape[:-1] + (4, 4))
    out[..., :3, :3] = so3.hat(V[..., :3])
    out[..., :3, 3] = V[..., 3:]
    return out


def vee(M: ArrayLike) -> FloatArray:
    """Inverse of `hat`: (ω, v) of a 4×4 element of se(3)."""
    A = np.asarray(M, dtype=np.float64)
    return np.concatenate((so3.vee(A[..., :3, :3]), A[..., :3, 3]), axis=-1)


def _v_coefficients(theta: FloatArray) -> tuple[FloatArray, FloatArray]:
    """b = (1 − cos θ)/θ² and c = (θ − sin θ)/θ³, accurate for every θ ≥ 0."""
    b = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2
    small = theta < 1e-2
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    # Series below θ = 1e-2, where θ − sin θ cancels; truncation error < θ⁶/362880 ≈ 3e-18.
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0, (t - np.sin(t)) / t**3)
    return b, c


def exp(xi: ArrayLike) -> FloatArray:
    """T = exp([ξ]) for exponential coordinates ξ = Sθ = (ω̂θ, vθ) (MR eq. 3.88, any θ).

    p = (I + ((1 − cos θ)/θ²)[φ] + ((θ − sin θ)/θ³)[φ]²) ρ with φ = ω̂θ, ρ = vθ; for φ = 0 this is
    the pure translation p = ρ (MR eq. 3.89).
    """
    X = np.asarray(xi, dtype=np.float64)
    phi, rho = X[..., :3], X[..., 3:]
    theta = np.linalg.norm(phi, axis=-1)[..., None, None]
    b, c = _v_coefficients(theta)
    K = so3.hat(phi)
    K2 = K @ K
    V = np.eye(3) + b * K + c * K2
    a = np.sinc(theta / np.pi)
    R = np.eye(3) + a * K + b * K2
    return make_transform(R, (V @ rho[..., None])[..., 0])


def log(T: ArrayLike) -> FloatArray:
    """Exponential coordinates ξ = Sθ = (ω̂θ, vθ) of T, with θ ∈ [0, π] (MR §3.3.3.2).

    ρ = V⁻¹ p with V⁻¹ = I − ½[φ] + (1/θ²)(1 − θ sin θ / (2(1 − cos θ)))[φ]²; the bracket tends to
    1/12 as θ → 0, where its series is used.
    """
    Tm = np.asarray(T, dtype=np.float64)
    phi = so3.log(Tm[..., :3, :3])
    theta = np.linalg.norm(phi, axis=-1)[..., None, None]
    small = theta < 1e-2
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    # 1/θ² − (1 + cos θ)/(2θ sin θ) rewritten with half-angles: 1/θ² − cot(θ/2)/(2θ).
    d = np.where(
        small, 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0, 1.0 / t**2 - 0.5 / (t * np.tan(t / 2))
    )
    K = so3.hat(phi)
    Vinv = np.eye(3) - 0.5 * K + d * (K @ K)
    return np.concatenate((phi, (Vinv @ Tm[..., :3, 3:4])[..., 0]), axis=-1)


def adjoint(T: ArrayLike) -> FloatArray:
    """[Ad_T] = [[R, 0], [[p]R, R]] ∈ R⁶ˣ⁶, mapping twists V_b to V_a = Ad_{T_ab} V_b (MR eq. 3.83)."""
    Tm = np.asarray(T, dtype=np.float64)
    R, p = Tm[..., :3, :3], Tm[..., :3, 3]
    out = np.zeros(Tm.shape[:-2] + (6, 6))
    out[..., :3, :3] = R
    out[..., 3:, 3:] = R
    out[..., 3:, :3] = so3.hat(p) @ R
    return out


def transform_twist(T_ab: ArrayLike, V_b: ArrayLike) -> FloatArray:
    """V_a = [Ad_{T_ab}] V_b: the same twist expressed in frame {a} (MR eq. 3.83)."""
    return (adjoint(T_ab) @ np.asarray(V_b, dtype=np.float64)[..., None])[..., 0]


def transform_wrench(T_ab: ArrayLike, F_a: ArrayLike) -> FloatArray:
    """F_b = [Ad_{T_ab}]ᵀ F_a: a wrench (m, f) given in {a} expressed in {b} (MR eq. 3.95)."""
    return (np.swapaxes(adjoint(T_ab), -1, -2) @ np.asarray(F_a, dtype=np.float64)[..., None])[
        ..., 0
    ]


def screw_axis(q: ArrayLike, s_hat: ArrayLike, h: float) -> FloatArray:
    """Screw axis S = (ŝ, −ŝ × q + hŝ) of the screw through point q along unit ŝ with pitch h.

    For an infinite pitch (pure translation) use S = (0, ŝ) directly.
    """
    s = np.asarray(s_hat, dtype=np.float64)
    qv = np.asarray(q, dtype=np.float64)
    return np.concatenate((s, -np.cross(s, qv) + h * s), axis=-1)
