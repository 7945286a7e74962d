"""The "general_6r" family: every solution of any 6R chain from one eigenvalue problem.

Raghavan & Roth (1993), in the matrix form of Manocha & Canny (1994), with the elimination by an
SVD that Cao, Coutsias & Pollock (2023) recommend for stability. In the PoE model
e₁ ⋯ e₆ = G = T M⁻¹ (eᵢ = e^{[Sᵢ]θᵢ}) joint 6 fixes every point of its own axis, so the point r₆
and the direction ω₆ of axis 6 give

    p = e₃e₄e₅ r₆ = e₂⁻¹e₁⁻¹ (G r₆),        l = R₃R₄R₅ ω₆ = R₂ᵀR₁ᵀ (R_G ω₆).

With the origin on axis 3, Raghavan and Roth's 14 equations p, l, p·p, p·l, p × l and
(p·p) l − 2 (p·l) p are, on the left, of degree at most one in each of (cos θᵢ, sin θᵢ), i = 3, 4, 5
(θ₃ leaves p·p and p·l), and on the right of degree at most one in each of θ₁, θ₂:

    P(θ₃) m₄₅ = Q m₁₂ + q₀,   m₄₅ = (1, c₄, s₄) ⊗ (1, c₅, s₅),  m₁₂ = (1, c₁, s₁) ⊗ (1, c₂, s₂) less 1.

P (14 × 3 × 9) depends on the arm only; Q (14 × 8) and q₀ on the target. Their coefficients are
read off exactly by evaluating both sides at three angles per joint (a trigonometric polynomial of
degree one is fixed by three values), so no symbolic expansion is written out. The left null
space N (6 × 14) of Q, from its SVD, eliminates θ₁, θ₂: N (P(θ₃) m₄₅ − q₀) = 0, six equations in
θ₃, θ₄, θ₅. With half-angle tangents xᵢ = tan(θᵢ/2) (θ₃ measured from a fixed random offset φ, so
that θ₃ = φ + π is almost never a root and the leading matrix stays invertible) they are
polynomial, of degree 2 in x₄ and x₅; with their products by x₄ they form Σ(x₃) v = 0,
Σ = C₀ + C₁x₃ + C₂x₃² (12 × 12) on v = (x₄ⁱ x₅ʲ), i ≤ 3, j ≤ 2. det Σ(x₃) = 0 has degree 24,
of which 8 roots are the spurious ±i of (1 + x₃²)⁴: at most 16 real solutions. They are the
eigenvalues of the 24 × 24 companion matrix, with x₄, x₅ read from the eigenvectors; m₁₂ then
follows from the 14 equations by least squares (θ₁, θ₂), and θ₆ from the orientation. Candidates
are polished by Newton steps and checked by forward kinematics in `chain_solver`.

Everything is vectorised over lanes (targets, or target × held value of a 7R arm): NumPy's
eigensolver takes stacks of matrices. Lengths are scaled by the arm's size first. Angles [rad].
"""

from __future__ import annotations

import math

import numpy as np

from .. import subproblems as sp
from .geometry import BoolArray, FloatArray, Trace

#: Candidate slots per lane: a 6R chain has at most 16 solutions (Raghavan & Roth 1993).
BRANCHES = 16
#: Offset φ of θ₃'s half-angle tangent [rad] (any value; fixed so that results are repeatable).
THETA3_OFFSET = 0.6180339887498949
#: An eigenvalue x₃ counts as real when |Im x₃| ≤ this × (1 + |x₃|²) (a double real root splits
#: into a complex pair of about √ε; Newton steps and the FK check decide).
REAL_ROOT = 1e-4
#: Where C₂⁻¹[C₀ C₁] has entries beyond this × those of Σ, a lane is solved again with θ₃
#: measured from φ + 1 (C₂ is singular where θ₃ = φ + π is a root).
_C2_CONDITION = 1e10

# Angles 0, 2π/3, 4π/3: f(θ) = a + b cos θ + c sin θ from its three values, (a, b, c) = V⁻¹ f.
_SAMPLES = np.array([0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0])
_V_INV = np.linalg.inv(np.stack((np.ones(3), np.cos(_SAMPLES), np.sin(_SAMPLES)), axis=1))
# (1 + x²)(1, cos θ, sin θ) in the powers (1, x, x²) of x = tan(θ/2): rows 1 + x², 1 − x², 2x.
_HALF = np.array([[1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [0.0, 2.0, 0.0]])


def _rotate(k: FloatArray, c: FloatArray, s: FloatArray, x: FloatArray) -> FloatArray:
    """R(k, θ) x with c = cos θ, s = sin θ (…) for unit k and x (…, 3) (Rodrigues, MR eq. 3.51)."""
    c, s = c[..., None], s[..., None]
    return x * c + sp.cross(k, x) * s + k * (sp.dot(k, x)[..., None] * (1.0 - c))


def _equations(p: FloatArray, l: FloatArray) -> FloatArray:
    """Raghavan and Roth's 14 quantities of a point p and a direction l (…, 3): (…, 14)."""
    pp = np.einsum("...i,...i->...", p, p)[..., None]
    pl = np.einsum("...i,...i->...", p, l)[..., None]
    pxl = _cross(p, l)
    return np.concatenate((p, l, pp, pl, pxl, pp * l - 2.0 * pl * p), axis=-1)


_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """a × b for (…, 3) arrays (one einsum: np.cross costs ten times more on small arrays)."""
    return np.einsum("ijk,...j,...k->...i", _EPS, a, b)


# (1, cos, sin) ⊗ (1, cos, sin) coefficients from the 3 × 3 samples, as one 9 × 9 matrix.
_V_INV2 = np.kron(_V_INV, _V_INV)


def _interpolate(values: FloatArray, axes: int) -> FloatArray:
    """Coefficients over (1, cos, sin)^⊗axes of values sampled at `_SAMPLES` per angle: values
    (…, 3, …, 3, 14) with the `axes` sample axes just before the last → same shape, coefficients."""
    out = values
    for a in range(axes):
        out = np.moveaxis(np.tensordot(_V_INV, np.moveaxis(out, -2 - a, 0), axes=(1, 0)), 0, -2 - a)
    return out


def screw_parts(w: FloatArray, r: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A, B, C (…, 4, 4) with e^{[S]θ} = A + B cos θ + C sin θ for the revolute screws of unit
    directions w and points r (…, 3): e^{[S]θ} = I + sin θ [S] + (1 − cos θ)[S]² (MR eq. 3.88)."""
    K = np.zeros(w.shape[:-1] + (4, 4))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    K[..., :3, 3] = np.cross(r, w)  # v = −ω × r
    K2 = K @ K
    return np.eye(4) + K2, -K2, K


class Arm:
    """What the general solver precomputes for lanes of 6R axes w, r (L, 6, 3) (L = 1 for a 6R
    arm): coordinates with the origin on axis 3 and lengths / scale, the screws' parts
    (`screw_parts`), the arm coefficients P (L, 14, 3, 9), and e₂⁻¹e₁⁻¹ at the sample angles."""

    def __init__(self, w: FloatArray, r: FloatArray, scale: float) -> None:
        self.origin = r[:, 2].copy()
        self.scale = scale
        rs = (r - self.origin[:, None]) / scale
        self.w, self.r = w, rs
        self.A, self.B, self.C = screw_parts(w, rs)  # (L, 6, 4, 4)
        c, s = np.cos(_SAMPLES), np.sin(_SAMPLES)

        def at(i: int, sign: float) -> FloatArray:  # e^{±[S_i]θ_k} at the samples: (L, 3, 4, 4)
            return (
                self.A[:, i, None]
                + c[None, :, None, None] * self.B[:, i, None]
                + sign * s[None, :, None, None] * self.C[:, i, None]
            )

        E3, E4, E5 = at(2, 1.0), at(3, 1.0), at(4, 1.0)
        X = E3[:, :, None, None] @ E4[:, None, :, None] @ E5[:, None, None, :]  # (L, 3, 3, 3, 4, 4)
        p = X[..., :3, :3] @ rs[:, None, None, None, 5, :, None] + X[..., :3, 3:]
        l = X[..., :3, :3] @ w[:, None, None, None, 5, :, None]
        E = _interpolate(_equations(p[..., 0], l[..., 0]), 3)  # (L, 3, 3, 3, 14)
        L = w.shape[0]
        self.P = np.moveaxis(E, -1, 1).reshape(L, 14, 3, 9)
        # Σ's arm part with θ₃ measured from φ, and from φ + 1 (`solve_general_6r`).
        self.G = (
            poly_coefficients(self.P, THETA3_OFFSET),
            poly_coefficients(self.P, THETA3_OFFSET + 1.0),
        )
        # e₂⁻¹(θ₂ₖ) e₁⁻¹(θ₁ⱼ) at the samples: (L, 3 [j], 3 [k], 4, 4)
        self.M12 = at(1, -1.0)[:, None, :] @ at(0, -1.0)[:, :, None]
        self.x6 = _perpendicular(w[:, 5])

    def tile(self, n: int) -> Arm:
        """This arm's K lanes repeated for n targets: lane i·K + k is target i, lane k."""
        out = Arm.__new__(Arm)
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray):
                value = np.tile(value, (n,) + (1,) * (value.ndim - 1))
            elif isinstance(value, tuple):
                value = tuple(np.tile(v, (n,) + (1,) * (v.ndim - 1)) for v in value)
            setattr(out, name, value)
        return out

    def target_coefficients(self, R: FloatArray, t: FloatArray) -> FloatArray:
        """Right-hand sides of L targets G = (R, t) (L, 3, 3), (L, 3) in the base frame [m] →
        (L, 14, 9) over (1, c₁, s₁) ⊗ (1, c₂, s₂)."""
        L = R.shape[0]
        ts = np.einsum("lij,lj->li", R, np.broadcast_to(self.origin, (L, 3))) + t - self.origin
        ts /= self.scale  # G in the solver's coordinates: G′ x′ = (R (s x′ + o) + t − o) / s
        g = np.einsum("lij,lj->li", R, np.broadcast_to(self.r[:, 5], (L, 3))) + ts  # G r₆
        h = np.einsum("lij,lj->li", R, np.broadcast_to(self.w[:, 5], (L, 3)))  # R_G ω₆
        M = self.M12
        p = np.einsum("ljkab,lb->ljka", M[..., :3, :3], g) + M[..., :3, 3]
        l = np.einsum("ljkab,lb->ljka", M[..., :3, :3], h)
        E = np.einsum("ab,lbe->lea", _V_INV2, _equations(p, l).reshape(L, 9, 14))
        return E  # (L, 14, 9)


def poly_coefficients(P: FloatArray, phi: float) -> FloatArray:
    """The arm's part of Σ: P (L, 14, 3, 9) → (L, 3, 14, 9), the 14 equations times
    (1 + x₃²)(1 + x₄²)(1 + x₅²) as polynomials: power k of x₃ (θ₃ = φ + 2 atan x₃), then the
    monomials x₄ⁱ x₅ʲ (i, j ≤ 2) in the order 3i + j. Linear in P."""
    L = P.shape[0]
    cp, sn = math.cos(phi), math.sin(phi)
    B0 = P[:, :, 0]
    Bc = P[:, :, 1] * cp + P[:, :, 2] * sn  # cos(φ + u) = cos φ cos u − sin φ sin u
    Bs = -P[:, :, 1] * sn + P[:, :, 2] * cp
    A = np.stack((B0 + Bc, 2.0 * Bs, B0 - Bc), axis=1)  # (L, 3, 14, 9), powers 0, 1, 2 of x₃
    F = np.einsum("ai,lkeab,bj->lkeij", _HALF, A.reshape(L, 3, 14, 3, 3), _HALF)
    return F.reshape(L, 3, 14, 9)


#: `poly_coefficients` of the constant monomial alone (where q₀ enters): (3, 9).
_CONSTANT = poly_coefficients(np.eye(27)[0].reshape(1, 1, 3, 9).repeat(14, axis=1), 0.0)[0, :, 0]


def _companion(
    G: FloatArray, RHS: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """The 24 × 24 companion matrices of Σ(x₃) for lanes with `poly_coefficients` G
    (L or 1, 3, 14, 9) and right-hand sides RHS (L, 14, 9); also the pseudo-inverse of Q
    (L, 8, 14), q₀ (L, 14), and where C₂ was invertible (L,)."""
    L = RHS.shape[0]
    Q, q0 = RHS[:, :, 1:], RHS[:, :, 0]
    U, S, Vt = np.linalg.svd(Q)  # Q = U S Vᵀ, U (L, 14, 14)
    N = U[:, :, 8:].swapaxes(1, 2)  # (L, 6, 14): left null space of Q
    inv_s = np.where(S > S[:, :1] * 1e-12, 1.0 / np.where(S > 0, S, 1.0), 0.0)
    Q_pinv = (Vt.swapaxes(1, 2) * inv_s[:, None, :]) @ U[:, :, :8].swapaxes(1, 2)
    # N (P(θ₃) m₄₅ − q₀) = 0; q₀ joins the constant monomial.
    Gt = G - q0[:, None, :, None] * _CONSTANT[None, :, None, :]  # (L, 3, 14, 9)
    F = np.einsum("lie,lkem->lkim", N, Gt)  # (L, 3, 6, 9)
    C = np.zeros((L, 3, 12, 12))
    C[:, :, :6, :9] = F  # the six equations on x₄ⁱ x₅ʲ, i ≤ 2
    C[:, :, 6:, 3:] = F  # the same times x₄
    # C₂⁻¹ [C₀ C₁]; a near-singular C₂ shows as entries far larger than those of Σ.
    C01 = np.concatenate((C[:, 0], C[:, 1]), axis=2)
    try:
        D = np.linalg.solve(C[:, 2], C01)
    except np.linalg.LinAlgError:  # an exactly singular C₂ in some lane: one lane at a time
        D = np.stack([_solve_or_inf(a, b) for a, b in zip(C[:, 2], C01, strict=True)])
    size = np.abs(F).max(axis=(1, 2, 3)) + 1e-300
    good = np.isfinite(D).all(axis=(1, 2)) & (np.abs(D).max(axis=(1, 2)) < _C2_CONDITION * size)
    D = np.where(good[:, None, None], D, 0.0)
    M = np.zeros((L, 24, 24))
    M[:, :12, 12:] = np.eye(12)
    M[:, 12:, :] = -D
    return M, Q_pinv, q0, good


def _solve_or_inf(a: FloatArray, b: FloatArray) -> FloatArray:
    """a⁻¹ b, or inf where a is singular."""
    try:
        return np.asarray(np.linalg.solve(a, b), dtype=np.float64)
    except np.linalg.LinAlgError:
        return np.full(b.shape, np.inf)


def _roots(M: FloatArray, phi: float) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """θ₃, x₄, x₅ (L, 16) and ok (L, 16) from the companion matrices M (L, 24, 24)."""
    lam, vec = np.linalg.eig(M)
    L = M.shape[0]
    realness = np.abs(lam.imag) / (1.0 + np.abs(lam) ** 2)
    order = np.argsort(realness, axis=1, kind="stable")[:, :BRANCHES]
    lam = np.take_along_axis(lam, order, axis=1)
    vec = np.take_along_axis(vec, order[:, None, :], axis=2)  # (L, 24, 16)
    ok = np.take_along_axis(realness, order, axis=1) <= REAL_ROOT
    x3 = lam.real
    # The eigenvector's first half is (x₄ⁱ x₅ʲ), i ≤ 3, j ≤ 2; for a large x₃ the second half
    # (x₃ times it) carries more digits.
    v = np.where((np.abs(lam) > 1.0)[:, None, :], vec[:, 12:], vec[:, :12])
    v = v.swapaxes(1, 2).reshape(L, BRANCHES, 4, 3)
    mag = np.abs(v)
    # x₄ = v[i+1, j] / v[i, j] at the largest v[i, j] with i ≤ 2; x₅ likewise with j ≤ 1.
    a = mag[:, :, :3, :].reshape(L, BRANCHES, 9).argmax(axis=2)
    i, j = a // 3, a % 3
    lb = np.arange(L)[:, None], np.arange(BRANCHES)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):  # (a zero vector: not ok below)
        x4 = (v[lb[0], lb[1], i + 1, j] / v[lb[0], lb[1], i, j]).real
        b = mag[:, :, :, :2].reshape(L, BRANCHES, 8).argmax(axis=2)
        i, j = b // 2, b % 2
        x5 = (v[lb[0], lb[1], i, j + 1] / v[lb[0], lb[1], i, j]).real
    theta3 = phi + 2.0 * np.arctan(x3)
    return theta3, x4, x5, ok & np.isfinite(x4) & np.isfinite(x5)


def solve_general_6r(
    arm: Arm, R: FloatArray, t: FloatArray, trace: Trace
) -> tuple[FloatArray, BoolArray]:
    """All (≤ 16) solutions of e₁ ⋯ e₆ = G = (R, t) for L lanes: Q (L, 16, 6), ok (L, 16).

    `arm`: the lanes' axes (one arm for every lane, or one per lane). Unpolished: the caller
    refines and checks by forward kinematics.
    """
    L = R.shape[0]
    RHS = arm.target_coefficients(R, t)
    G = np.broadcast_to(arm.G[0], (L,) + arm.G[0].shape[1:])
    M, Q_pinv, q0, good = _companion(G, RHS)
    theta3, x4, x5, ok = _roots(M, THETA3_OFFSET)
    ok &= good[:, None]
    bad = ~good
    if bad.any():  # C₂ near singular: θ₃ = φ + π nearly a root; measure from another offset
        G2 = np.broadcast_to(arm.G[1], (L,) + arm.G[1].shape[1:])
        M2, _, _, good2 = _companion(G2[bad], RHS[bad])
        t3b, x4b, x5b, okb = _roots(M2, THETA3_OFFSET + 1.0)
        theta3[bad], x4[bad], x5[bad], ok[bad] = t3b, x4b, x5b, okb & good2[:, None]
    trace.fails.append(("reach", ok))
    theta4, theta5 = 2.0 * np.arctan(x4), 2.0 * np.arctan(x5)

    def E(i: int, th: FloatArray) -> FloatArray:  # e^{[S_i]θ} (L, 16, 4, 4)
        c, s = np.cos(th)[..., None, None], np.sin(th)[..., None, None]
        return arm.A[:, None, i] + c * arm.B[:, None, i] + s * arm.C[:, None, i]

    X345 = E(2, theta3) @ E(3, theta4) @ E(4, theta5)
    p = X345[..., :3, :3] @ arm.r[:, None, 5, :, None] + X345[..., :3, 3:]
    l = X345[..., :3, :3] @ arm.w[:, None, 5, :, None]
    # θ₁, θ₂ from the 14 equations at (θ₃, θ₄, θ₅): Q m₁₂ = P m₄₅ − q₀ by least squares.
    lhs = _equations(p[..., 0], l[..., 0]) - q0[:, None, :]  # (L, 16, 14)
    m12 = np.einsum("lke,lbe->lbk", Q_pinv, lhs)  # (L, 16, 8): (c₂, s₂, c₁, c₁c₂, c₁s₂, s₁, …)
    theta1 = np.arctan2(m12[..., 5], m12[..., 2])
    theta2 = np.arctan2(m12[..., 1], m12[..., 0])
    # θ₆: R₆ = (R₁ ⋯ R₅)ᵀ R_G; a unit x ⟂ ω₆ goes to y = R₆ x.
    R15 = (E(0, theta1) @ E(1, theta2) @ X345)[..., :3, :3]
    x = arm.x6[:, None, :]
    y = np.einsum("lbji,lj->lbi", R15, np.einsum("lij,lj->li", R, np.broadcast_to(arm.x6, (L, 3))))
    w6 = arm.w[:, None, 5]
    theta6 = np.arctan2(np.einsum("lbi,lbi->lb", np.broadcast_to(w6, y.shape), _cross(x, y)),
                        np.einsum("lbi,lbi->lb", np.broadcast_to(x, y.shape), y))  # fmt: skip
    Q = np.stack((theta1, theta2, theta3, theta4, theta5, theta6), axis=-1)
    return Q, ok & np.isfinite(Q).all(axis=-1)


def solve_general_6r_shifted(
    w: FloatArray,
    r: FloatArray,
    arm: Arm | None,
    R: FloatArray,
    t: FloatArray,
    scale: float,
    trace: Trace,
    shift: int,
) -> tuple[FloatArray, BoolArray]:
    """`solve_general_6r` for lanes of axes w, r (L or 1, 6, 3) with the chain's loop read from
    joint `shift` + 1: e₁ ⋯ e₆ = G is e_{k+1} ⋯ e₆ e′₁ ⋯ e′ₖ = G with e′ᵢ = G⁻¹ eᵢ G, the rotation
    about axis i moved by G⁻¹ (k = shift). An elimination that degenerates for one order of the
    axes (three axes through a point among joints 3-5, say) need not for another. `arm`, the
    prepared `Arm` of w, r, is used when given and shift is 0."""
    if shift == 0:
        return solve_general_6r(arm or Arm(w, r, scale), R, t, trace)
    L = R.shape[0]
    Rt = R.swapaxes(1, 2)
    wl = np.broadcast_to(w, (L,) + w.shape[1:]).copy()
    rl = np.broadcast_to(r, (L,) + r.shape[1:]).copy()
    wl[:, :shift] = np.einsum("lij,lkj->lki", Rt, wl[:, :shift])
    rl[:, :shift] = np.einsum("lij,lkj->lki", Rt, rl[:, :shift] - t[:, None])
    order = [*range(shift, 6), *range(shift)]
    Q, ok = solve_general_6r(Arm(wl[:, order], rl[:, order], scale), R, t, trace)
    return Q[..., np.argsort(order)], ok


def _perpendicular(a: FloatArray) -> FloatArray:
    """A unit vector normal to each unit vector a (…, 3)."""
    helper = np.where(
        (np.abs(a[..., 0]) < 0.9)[..., None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    )
    x = np.cross(a, helper)
    return x / np.linalg.norm(x, axis=-1, keepdims=True)
