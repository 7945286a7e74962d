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
#: Above this condition number of C₂ a lane is solved again with θ₃ measured from φ + 1.
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
    pp = sp.dot(p, p)[..., None]
    pl = sp.dot(p, l)[..., None]
    return np.concatenate((p, l, pp, pl, sp.cross(p, l), pp * l - 2.0 * pl * p), axis=-1)


def _interpolate(values: FloatArray, axes: int) -> FloatArray:
    """Coefficients over (1, cos, sin)^⊗axes of values sampled at `_SAMPLES` per angle: values
    (…, 3, …, 3, 14) with the `axes` sample axes just before the last → same shape, coefficients."""
    out = values
    for a in range(axes):
        out = np.moveaxis(np.tensordot(_V_INV, np.moveaxis(out, -2 - a, 0), axes=(1, 0)), 0, -2 - a)
    return out


def arm_coefficients(w: FloatArray, r: FloatArray) -> FloatArray:
    """P of every lane: w, r (L, 6, 3) axis directions and points (origin on axis 3, scaled) →
    (L, 14, 3, 9): equation, θ₃ term (1, c₃, s₃), m₄₅ = (1, c₄, s₄) ⊗ (1, c₅, s₅)."""
    L = w.shape[0]
    c, s = np.cos(_SAMPLES), np.sin(_SAMPLES)
    # every (θ₃, θ₄, θ₅) of the samples: axes (L, 3, 3, 3)
    shape = (L, 3, 3, 3)

    def ax(i: int) -> tuple[FloatArray, FloatArray]:
        return w[:, None, None, None, i], r[:, None, None, None, i]

    c5, s5 = np.broadcast_to(c[None, None, None, :], shape), np.broadcast_to(s, shape)
    c4 = np.broadcast_to(c[None, None, :, None], shape)
    s4 = np.broadcast_to(s[None, None, :, None], shape)
    c3 = np.broadcast_to(c[None, :, None, None], shape)
    s3 = np.broadcast_to(s[None, :, None, None], shape)
    (w3, r3), (w4, r4), (w5, r5), (w6, r6) = ax(2), ax(3), ax(4), ax(5)
    p = r5 + _rotate(w5, c5, s5, r6 - r5)
    p = r4 + _rotate(w4, c4, s4, p - r4)
    p = r3 + _rotate(w3, c3, s3, p - r3)
    l = _rotate(w3, c3, s3, _rotate(w4, c4, s4, _rotate(w5, c5, s5, np.broadcast_to(w6, p.shape))))
    E = _interpolate(_equations(p, l), 3)  # (L, 3, 3, 3, 14)
    return np.moveaxis(E, -1, 1).reshape(L, 14, 3, 9)


def target_coefficients(w: FloatArray, r: FloatArray, R: FloatArray, t: FloatArray) -> FloatArray:
    """The right-hand sides of L lanes: axes w, r (L, 6, 3) (origin on axis 3, scaled) and
    G = (R, t) (L, 3, 3), (L, 3) in the same coordinates → (L, 14, 9) over (1, c₁, s₁) ⊗ (1, c₂, s₂)."""
    L = w.shape[0]
    c, s = np.cos(_SAMPLES), np.sin(_SAMPLES)
    g = np.einsum("lij,lj->li", R, r[:, 5]) + t  # G r₆
    h = np.einsum("lij,lj->li", R, w[:, 5])  # R_G ω₆
    shape = (L, 3, 3)
    c1, s1 = np.broadcast_to(c[None, :, None], shape), np.broadcast_to(s[None, :, None], shape)
    c2, s2 = np.broadcast_to(c[None, None, :], shape), np.broadcast_to(s[None, None, :], shape)
    w1, r1 = w[:, None, None, 0], r[:, None, None, 0]
    w2, r2 = w[:, None, None, 1], r[:, None, None, 1]
    gg, hh = g[:, None, None], h[:, None, None]
    x = r1 + _rotate(w1, c1, -s1, gg - r1)  # e₁⁻¹
    p = r2 + _rotate(w2, c2, -s2, x - r2)  # e₂⁻¹
    l = _rotate(w2, c2, -s2, _rotate(w1, c1, -s1, np.broadcast_to(hh, p.shape)))
    E = _interpolate(_equations(p, l), 2)  # (L, 3, 3, 14)
    return np.moveaxis(E, -1, 1).reshape(L, 14, 9)


def _companion(
    P: FloatArray, RHS: FloatArray, phi: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The 24 × 24 companion matrices of Σ(x₃) for lanes P (L, 14, 3, 9), RHS (L, 14, 9), with
    θ₃ = φ + 2 atan x₃; also the pseudo-inverse of Q (L, 8, 14), q₀ (L, 14) and cond(C₂) (L,)."""
    L = P.shape[0]
    Q, q0 = RHS[:, :, 1:], RHS[:, :, 0]
    U, S, Vt = np.linalg.svd(Q)  # Q = U S Vᵀ, U (L, 14, 14)
    N = U[:, :, 8:].swapaxes(1, 2)  # (L, 6, 14): left null space of Q
    inv_s = np.where(S > S[:, :1] * 1e-12, 1.0 / np.where(S > 0, S, 1.0), 0.0)
    Q_pinv = (Vt.swapaxes(1, 2) * inv_s[:, None, :]) @ U[:, :, :8].swapaxes(1, 2)
    Pm = P.copy()
    Pm[:, :, 0, 0] -= q0  # q₀ joins the constant monomial of the θ₃-free part
    B = np.einsum("lke,leim->lkim", N, Pm)  # (L, 6, 3, 9)
    B0 = B[:, :, 0]
    cp, sp_ = math.cos(phi), math.sin(phi)
    Bc = B[:, :, 1] * cp + B[:, :, 2] * sp_  # cos(φ + u) = cos φ cos u − sin φ sin u
    Bs = -B[:, :, 1] * sp_ + B[:, :, 2] * cp
    A = (B0 + Bc, 2.0 * Bs, B0 - Bc)  # (1 + x₃²) × the equations, powers 0, 1, 2 of x₃
    C = np.zeros((3, L, 12, 12))
    for k, Ak in enumerate(A):
        F = np.einsum("ai,lkab,bj->lkij", _HALF, Ak.reshape(L, 6, 3, 3), _HALF)  # (L, 6, 3, 3)
        F = F.reshape(L, 6, 9)
        for shift in (0, 1):  # the equations, and the equations × x₄
            rows = slice(6 * shift, 6 * shift + 6)
            for i in range(3):
                C[k, :, rows, 3 * (i + shift) : 3 * (i + shift) + 3] = F[:, :, 3 * i : 3 * i + 3]
    C0, C1, C2 = C
    cond = np.linalg.cond(C2)
    ok = np.isfinite(cond) & (cond < _C2_CONDITION)
    C2s = np.where(ok[:, None, None], C2, np.eye(12))
    D0 = np.linalg.solve(C2s, C0)
    D1 = np.linalg.solve(C2s, C1)
    M = np.zeros((L, 24, 24))
    M[:, :12, 12:] = np.eye(12)
    M[:, 12:, :12] = -D0
    M[:, 12:, 12:] = -D1
    return M, Q_pinv, q0, cond


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
    x4 = (v[lb[0], lb[1], i + 1, j] / v[lb[0], lb[1], i, j]).real
    b = mag[:, :, :, :2].reshape(L, BRANCHES, 8).argmax(axis=2)
    i, j = b // 2, b % 2
    x5 = (v[lb[0], lb[1], i, j + 1] / v[lb[0], lb[1], i, j]).real
    theta3 = phi + 2.0 * np.arctan(x3)
    return theta3, x4, x5, ok & np.isfinite(x4) & np.isfinite(x5)


def solve_general_6r(
    w: FloatArray,
    r: FloatArray,
    P: FloatArray,
    R: FloatArray,
    t: FloatArray,
    scale: float,
    trace: Trace,
) -> tuple[FloatArray, BoolArray]:
    """All (≤ 16) solutions of e₁ ⋯ e₆ = G = (R, t) for L lanes: Q (L, 16, 6), ok (L, 16).

    w, r (L or 1, 6, 3): the lanes' axes; P (L or 1, 14, 3, 9): `arm_coefficients` of the same
    axes moved to the origin on axis 3 and scaled by 1/scale. Unpolished: the caller refines and
    checks by forward kinematics.
    """
    L = R.shape[0]
    origin = r[:, 2]  # (L or 1, 3)
    rs = (r - origin[:, None]) / scale
    ws = np.broadcast_to(w, (L,) + w.shape[1:])
    rs = np.broadcast_to(rs, (L,) + rs.shape[1:])
    # G in the shifted, scaled coordinates: x' = (x − o)/s, G' x' = (R (s x' + o) + t − o)/s.
    ts = (np.einsum("lij,lj->li", R, np.broadcast_to(origin, (L, 3))) + t - origin) / scale
    RHS = target_coefficients(ws, rs, R, ts)
    Pl = np.broadcast_to(P, (L,) + P.shape[1:])
    M, Q_pinv, q0, cond = _companion(Pl, RHS, THETA3_OFFSET)
    theta3, x4, x5, ok = _roots(M, THETA3_OFFSET)
    bad = ~(np.isfinite(cond) & (cond < _C2_CONDITION))
    if bad.any():  # C₂ near singular: θ₃ = φ + π nearly a root; measure from another offset
        phi2 = THETA3_OFFSET + 1.0
        M2, _, _, cond2 = _companion(Pl[bad], RHS[bad], phi2)
        t3b, x4b, x5b, okb = _roots(M2, phi2)
        okb &= (np.isfinite(cond2) & (cond2 < _C2_CONDITION))[:, None]
        theta3[bad], x4[bad], x5[bad], ok[bad] = t3b, x4b, x5b, okb
    theta4, theta5 = 2.0 * np.arctan(x4), 2.0 * np.arctan(x5)
    trace.fails.append(("reach", ok))
    # θ₁, θ₂ from the 14 equations at (θ₃, θ₄, θ₅): Q m₁₂ = P m₄₅ − q₀ by least squares.
    W = ws[:, None]  # (L, 1, 6, 3)
    Rr = rs[:, None]
    c3, s3 = np.cos(theta3), np.sin(theta3)
    c4, s4 = np.cos(theta4), np.sin(theta4)
    c5, s5 = np.cos(theta5), np.sin(theta5)
    p = Rr[..., 4, :] + _rotate(W[..., 4, :], c5, s5, Rr[..., 5, :] - Rr[..., 4, :])
    p = Rr[..., 3, :] + _rotate(W[..., 3, :], c4, s4, p - Rr[..., 3, :])
    p = Rr[..., 2, :] + _rotate(W[..., 2, :], c3, s3, p - Rr[..., 2, :])
    l = _rotate(
        W[..., 2, :], c3, s3,
        _rotate(W[..., 3, :], c4, s4, _rotate(W[..., 4, :], c5, s5, np.broadcast_to(W[..., 5, :], p.shape))),
    )  # fmt: skip
    lhs = _equations(p, l) - q0[:, None, :]  # (L, 16, 14)
    m12 = np.einsum("lke,lbe->lbk", Q_pinv, lhs)  # (L, 16, 8): (c₂, s₂, c₁, c₁c₂, c₁s₂, s₁, …)
    theta1 = np.arctan2(m12[..., 5], m12[..., 2])
    theta2 = np.arctan2(m12[..., 1], m12[..., 0])
    # θ₆: R₆ = (R₁ ⋯ R₅)ᵀ R_G; a unit x ⟂ ω₆ goes to R₆ x = y.
    w6 = ws[:, None, 5]
    x = np.broadcast_to(_perpendicular(ws[:, 5])[:, None], (L, BRANCHES, 3))
    y = np.einsum("lij,lbj->lbi", R, x)
    for k, th in ((0, theta1), (1, theta2), (2, theta3), (3, theta4), (4, theta5)):
        y = _rotate(W[..., k, :], np.cos(th), -np.sin(th), y)
    theta6 = np.arctan2(sp.dot(w6, sp.cross(x, y)), sp.dot(x, y))
    Q = np.stack((theta1, theta2, theta3, theta4, theta5, theta6), axis=-1)
    return Q, ok & np.isfinite(Q).all(axis=-1)


def solve_general_6r_shifted(
    w: FloatArray,
    r: FloatArray,
    P: FloatArray | None,
    R: FloatArray,
    t: FloatArray,
    scale: float,
    trace: Trace,
    shift: int,
) -> tuple[FloatArray, BoolArray]:
    """`solve_general_6r` with the chain's loop read from joint `shift` + 1: e₁ ⋯ e₆ = G is
    e_{k+1} ⋯ e₆ e′₁ ⋯ e′ₖ = G with e′ᵢ = G⁻¹ eᵢ G, the rotation about axis i moved by G⁻¹
    (k = shift). An elimination that degenerates for one order of the axes (three axes through a
    point among joints 3-5, say) need not for another. P is used only for shift 0."""
    if shift == 0:
        assert P is not None
        return solve_general_6r(w, r, P, R, t, scale, trace)
    L = R.shape[0]
    Rt = R.swapaxes(1, 2)
    wl = np.broadcast_to(w, (L,) + w.shape[1:]).copy()
    rl = np.broadcast_to(r, (L,) + r.shape[1:]).copy()
    wl[:, :shift] = np.einsum("lij,lkj->lki", Rt, wl[:, :shift])
    rl[:, :shift] = np.einsum("lij,lkj->lki", Rt, rl[:, :shift] - t[:, None])
    order = [*range(shift, 6), *range(shift)]
    ws, rs = wl[:, order], rl[:, order]
    Q, ok = solve_general_6r(ws, rs, prepared_coefficients(ws, rs, scale), R, t, scale, trace)
    back = np.argsort(order)
    return Q[..., back], ok


def _perpendicular(a: FloatArray) -> FloatArray:
    """A unit vector normal to each unit vector a (…, 3)."""
    helper = np.where(
        (np.abs(a[..., 0]) < 0.9)[..., None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    )
    x = sp.cross(a, helper)
    return x / sp.norm(x)[..., None]


def prepared_coefficients(w: FloatArray, r: FloatArray, scale: float) -> FloatArray:
    """`arm_coefficients` of lanes w, r (L, 6, 3) in the solver's coordinates (origin on axis 3,
    lengths / scale)."""
    return arm_coefficients(w, (r - r[:, 2:3]) / scale)
