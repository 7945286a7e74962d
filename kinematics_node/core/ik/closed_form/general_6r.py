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
degree one is fixed by three values), so no symbolic expansion is written out. The right-hand
side is moreover a polynomial in g = G r₆ and h = R_G ω₆ of degree ≤ 2 in g and ≤ 1 in h, so
per arm it is one matrix K (40 × 126) on the 40 monomials of (g, h), fitted once: per target, one
product. The left null space N (6 × 14) of Q (from its QR for one target, its SVD for stacks or
an ill-conditioned Q) eliminates θ₁, θ₂:
N (P(θ₃) m₄₅ − q₀) = 0, six equations in θ₃, θ₄, θ₅. With half-angle tangents xᵢ = tan(θᵢ/2)
(θ₃ measured from a fixed offset φ, so that θ₃ = φ + π is almost never a root and the leading
matrix stays invertible) they are polynomial, of degree 2 in x₄ and x₅; with their products by x₄
they form Σ(x₃) v = 0, Σ = C₀ + C₁x₃ + C₂x₃² (12 × 12) on v = (x₄ⁱ x₅ʲ), i ≤ 3, j ≤ 2, whose
roots are the eigenvalues of the 24 × 24 companion matrix M = [[0, I], [−C₂⁻¹C₀, −C₂⁻¹C₁]].

det Σ(x₃) has degree 24, of which 8 roots are the spurious ±i of (1 + x₃²)⁴: at most 16 real
solutions. At x₃ = ±i only the vector equations' rotation by θ₃ survives, (Pc ± i Ps), of rank one
per vector equation, so Σ(±i) has a null space V (12 × 4) that depends on the arm alone; M's
invariant subspace of ±i is then spanned by (V, ±iV), and with an orthonormal complement Q₂
(24 × 16, per arm) the 16 genuine roots are the eigenvalues of Q₂ᵀ M Q₂: a 16 × 16 problem
(a third of the 24 × 24's time). Each real root x₃ then gives (x₄, x₅) from the null vector of
Σ(x₃): for one target, from the 16 × 16 problem's eigenvector (`_shift_angles`: M acts on the
±i subspace as a known rotation, so M's eigenvector follows by products); for stacked lanes, by
one step of inverse iteration; roots that coincide to within `CLUSTER` share a null space of
their multiplicity, split by the shift x₄ + c x₅ of the monomials. Each
root is polished by one Gauss–Newton step on the six eliminated equations in (cos, sin) of θ₃, θ₄,
θ₅ (a near-double root, found to ε / gap, comes back to ε), m₁₂ follows from the 14 equations by
least squares (θ₁, θ₂), and θ₆ from the orientation through coefficients of R₂ᵀR₁ᵀ and (R₃R₄R₅)ᵀ
precomputed per arm. Candidates are checked by forward kinematics (and refined where still off)
in `chain_solver`.

Everything is vectorised over lanes (targets, or target × held value of a 7R arm): NumPy's
solvers take stacks of matrices; one lane calls LAPACK directly (`scipy.linalg.lapack`: a fifth
of NumPy's per-call cost on these sizes). Lengths are scaled by the arm's size first. Angles [rad].
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.linalg import lapack

from .. import subproblems as sp
from .geometry import BoolArray, FloatArray, IntArray, Trace

#: Candidate slots per lane: a 6R chain has at most 16 solutions (Raghavan & Roth 1993).
BRANCHES = 16
#: Offset φ of θ₃'s half-angle tangent [rad] (any value; fixed so that results are repeatable).
THETA3_OFFSET = 0.6180339887498949
#: An eigenvalue x₃ counts as real when |Im x₃| ≤ this × (1 + |x₃|²) (a double real root splits
#: into a complex pair of about √ε; Newton steps and the FK check decide).
REAL_ROOT = 1e-4
#: Real roots of one lane closer than this × (1 + |x₃|) are one root of higher multiplicity (a
#: double root, or a pair split by rounding): inverse iteration cannot tell their null vectors
#: apart (its error grows as ε / gap, a shared null space's as the gap: equal near √ε).
CLUSTER = 1e-7
#: Where C₂⁻¹[C₀ C₁] has entries beyond this × those of Σ, a lane is solved again with θ₃
#: measured from φ + 1 (C₂ is singular where θ₃ = φ + π is a root).
_C2_CONDITION = 1e10
#: One target's Q (14 × 8) is decomposed by QR where the reciprocal condition number of its R is
#: above this, else by the SVD (`_null_and_pinv`).
_Q_RCOND = 1e-10
_UPPER8 = np.triu(np.ones((8, 8)))

# Angles 0, 2π/3, 4π/3: f(θ) = a + b cos θ + c sin θ from its three values, (a, b, c) = V⁻¹ f.
_SAMPLES = np.array([0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0])
_V_INV = np.linalg.inv(np.stack((np.ones(3), np.cos(_SAMPLES), np.sin(_SAMPLES)), axis=1))
# (1, cos, sin) ⊗ (1, cos, sin) coefficients from the 3 × 3 samples, as one 9 × 9 matrix.
_V_INV2 = np.kron(_V_INV, _V_INV)
_V_INV3 = np.kron(_V_INV, _V_INV2)
# (1 + x²)(1, cos θ, sin θ) in the powers (1, x, x²) of x = tan(θ/2): rows 1 + x², 1 − x², 2x.
_HALF = np.array([[1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [0.0, 2.0, 0.0]])
# The same for (1, cos, sin) ⊗ (1, cos, sin) of two angles (a 9-vector): Hᵀ A H of a 3 × 3 A is
# vec(A) times this, one matrix product where `np.einsum` with three operands costs ~10 µs more
_HALF2 = np.kron(_HALF, _HALF)
# [ω]× = (ω @ _HAT).reshape(3, 3): the skew matrix of ω as one product
_HAT = np.zeros((3, 9))
_HAT[2, 1], _HAT[1, 2], _HAT[0, 5] = -1.0, 1.0, -1.0
_HAT[2, 3], _HAT[1, 6], _HAT[0, 7] = 1.0, -1.0, 1.0
# The monomials of the right-hand side: (1, g, gᵢgⱼ (i ≤ j)) ⊗ (1, h), 10 × 4 = 40.
_PAIRS_I, _PAIRS_J = np.triu_indices(3)
# (g, h) at which K is fitted (scaled coordinates: |g| of order one): 80 points for 40 monomials.
_FIT = np.random.default_rng(20240624).uniform(-1.5, 1.5, size=(80, 6))
# The fixed right-hand side of inverse iteration (any vector with a component along every null
# vector; fixed so that results are repeatable).
_B = np.random.default_rng(7).standard_normal(12)
_B_STACK = np.ascontiguousarray(np.broadcast_to(_B[:, None], (BRANCHES + 8, 12, 1)))
_DIAG = np.arange(12)
# Entries of v = (x₄ⁱ x₅ʲ) (index 3i + j) that x₄ (+3), x₅ (+1) or both map into v: i ≤ 2; j ≤ 1.
_X4_BASE = np.array([3 * i + j for i in range(3) for j in range(3)])
_X5_BASE = np.array([3 * i + j for i in range(4) for j in range(2)])
_BASE = np.array([3 * i + j for i in range(3) for j in range(2)])
# The sums of `_shift_ratios` as products of entries v[A] v[B] summed by a 0/1 matrix (34, 4).
_PROD_A = np.concatenate((_X4_BASE + 3, _X4_BASE, _X5_BASE + 1, _X5_BASE))
_PROD_B = np.concatenate((_X4_BASE, _X4_BASE, _X5_BASE, _X5_BASE))
_PROD_SUM = np.zeros((34, 4))
for _k, (_a, _b) in enumerate(((0, 9), (9, 18), (18, 26), (26, 34))):
    _PROD_SUM[_a:_b, _k] = 1.0
_PROD_SUM_T = np.ascontiguousarray(_PROD_SUM.T)
_EYE12 = np.eye(12)
# M on the ±i subspace's basis (real, imaginary parts of (V, iV)): M Re = −Im, M Im = Re.
_J = np.block([[np.zeros((4, 4)), np.eye(4)], [-np.eye(4), np.zeros((4, 4))]])
# (1, cos θ, sin θ) as cos(kθ − φ) for k = (0, 1, 1), φ = (0, 0, π/2): one call of np.cos.
_K3 = np.array([0.0, 1.0, 1.0])
_PH3 = np.array([0.0, 0.0, 0.5 * math.pi])
# ... and their derivatives (0, −sin θ, cos θ) too: cos(kθ − φ) for k = (0, 1, 1, 0, 1, 1)
_K6 = np.array([0.0, 1.0, 1.0, 0.0, 1.0, 1.0])
_PH6 = np.array([0.0, 0.0, 0.5 * math.pi, 0.5 * math.pi, -0.5 * math.pi, 0.0])
# Which of those rows (0-2: the values, 3-5: the derivatives) each angle takes in m₃₄₅ (row 0)
# and in its derivatives by θ₃, θ₄, θ₅ (rows 1-3): (3 angles, 4, 3)
_D3 = np.array([[[0, 1, 2], [3, 4, 5], [0, 1, 2], [0, 1, 2]],
                [[0, 1, 2], [0, 1, 2], [3, 4, 5], [0, 1, 2]],
                [[0, 1, 2], [0, 1, 2], [0, 1, 2], [3, 4, 5]]])  # fmt: skip
# m₁₂'s entries θ₁, θ₂ are read from: c₂, s₂, c₁, s₁.
_M12_SEL = np.array([0, 1, 2, 5])
_UPPER8_SEL = _UPPER8[_M12_SEL]
# `Arm.one`'s E without the arm's rows: where F₂ (the equations' last 9 columns) goes in C₂
_E_TEMPLATE = np.zeros((2, 27, 28))
_E_TEMPLATE[0, 18 + np.arange(9), np.arange(9)] = 1.0
_E_TEMPLATE[1, 18 + np.arange(9), 3 + np.arange(9)] = 1.0
#: The largest polishing step [rad] taken (`_angles`): larger ones mean a root far from exact.
_POLISH_LIMIT = 0.1
# The adjugate of a 3 × 3 matrix A flattened row-major (`_polish_steps`): adj[i][j] =
# A[j+1][i+1] A[j+2][i+2] − A[j+1][i+2] A[j+2][i+1] (indices mod 3), as the flat indices of the
# four factors
_ADJ = np.array([
    [3 * ((j + a) % 3) + (i + b) % 3 for i in range(3) for j in range(3)]
    for a, b in ((1, 1), (2, 2), (1, 2), (2, 1))
])  # fmt: skip


def _features(g: FloatArray, h: FloatArray) -> FloatArray:
    """The 40 monomials (1, g, gᵢgⱼ) ⊗ (1, h) of g, h (…, 3) → (…, 40)."""
    one = np.ones(g.shape[:-1] + (1,))
    mu = np.concatenate((one, g, g[..., _PAIRS_I] * g[..., _PAIRS_J]), axis=-1)
    hh = np.concatenate((one, h), axis=-1)
    return (mu[..., :, None] * hh[..., None, :]).reshape(g.shape[:-1] + (40,))


_FIT_PINV = np.linalg.pinv(_features(_FIT[:, :3], _FIT[:, 3:]))  # (40, 80)


def _equations(p: FloatArray, l: FloatArray) -> FloatArray:
    """Raghavan and Roth's 14 quantities of a point p and a direction l (…, 3): (…, 14)."""
    pp = sp.dot(p, p)[..., None]
    pl = sp.dot(p, l)[..., None]
    return np.concatenate((p, l, pp, pl, sp.cross(p, l), pp * l - 2.0 * pl * p), axis=-1)


def _interpolate(values: FloatArray) -> FloatArray:
    """Coefficients over (1, cos, sin)^⊗3 of values sampled at `_SAMPLES` per angle: values
    (…, 3, 3, 3, m) with the three sample axes just before the last → same shape, coefficients."""
    shape = values.shape
    return (_V_INV3 @ values.reshape(shape[:-4] + (27, shape[-1]))).reshape(shape)


def screw_parts(w: FloatArray, r: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A, B, C (…, 4, 4) with e^{[S]θ} = A + B cos θ + C sin θ for the revolute screws of unit
    directions w and points r (…, 3): e^{[S]θ} = I + sin θ [S] + (1 − cos θ)[S]² (MR eq. 3.88)."""
    K = np.zeros(w.shape[:-1] + (4, 4))
    W = (w @ _HAT).reshape(w.shape[:-1] + (3, 3))  # [ω]×
    K[..., :3, :3] = W
    K[..., :3, 3] = -(W @ r[..., None])[..., 0]  # v = −ω × r
    K2 = K @ K
    return np.eye(4) + K2, -K2, K


def poly_coefficients(P: FloatArray, phi: float) -> FloatArray:
    """The arm's part of Σ: P (L, 14, 3, 9) → (L, 14, 3, 9), the 14 equations times
    (1 + x₃²)(1 + x₄²)(1 + x₅²) as polynomials: power k of x₃ (θ₃ = φ + 2 atan x₃), then the
    monomials x₄ⁱ x₅ʲ (i, j ≤ 2) in the order 3i + j. Linear in P: two matrix products."""
    cp, sn = math.cos(phi), math.sin(phi)
    # powers 0, 1, 2 of x₃ from (1, cos, sin) of θ₃ − φ: cos(φ + u) = cos φ cos u − sin φ sin u
    T = np.array([[1.0, cp, sn], [0.0, -2.0 * sn, 2.0 * cp], [1.0, -cp, -sn]])
    return (T @ P) @ _HALF2  # Hᵀ A H per equation and power of x₃


#: `poly_coefficients` of the constant monomial alone (where q₀ enters), flattened: (27,).
_CONSTANT = poly_coefficients(np.eye(27)[0].reshape(1, 1, 3, 9).repeat(14, axis=1), 0.0)[
    0, 0
].reshape(27)


class Arm:
    """What the general solver precomputes for lanes of 6R axes w, r (L, 6, 3) (L = 1 for a 6R
    arm): coordinates with the origin on axis 3 and lengths / scale, the screws' parts
    (`screw_parts`), the arm coefficients P (L, 14, 3, 9) and Σ's arm part for both offsets of θ₃
    (L, 14, 27), the right-hand side's map K (L, 40, 126), and the deflating basis Q₂ (L, 24, 16)
    with Q₂[:12]ᵀ Q₂[12:] (L, 16, 16)."""

    def __init__(
        self,
        w: FloatArray,
        r: FloatArray,
        scale: float,
        fit: bool = True,
        base: tuple[Arm, int] | None = None,
    ) -> None:
        """`base`: an arm built before, and how many of its leading joints this arm shares (an
        arm built per target, `solve_general_6r_shifted`, whose last joints alone move with the
        target): the parts of those joints are taken from it, not computed again."""
        L = w.shape[0]
        self.lanes = L
        same = 0 if base is None else base[1]
        self.origin: FloatArray = (
            base[0].origin if base is not None and same >= 3 else r[:, 2].copy()
        )
        self.scale = scale
        rs = (r - self.origin[:, None]) / scale
        self.w, self.r = w, rs
        c, s = np.cos(_SAMPLES), np.sin(_SAMPLES)
        # e^{±[S_i]θ_k} at the samples (L, 3, 4, 4) of joints 1-5, kept for arms built on this one
        self.samples: dict[tuple[int, float], FloatArray] = {}
        first = same if same >= 3 else 0  # the first joint whose parts are computed here
        if first < 5:
            A, B, C = screw_parts(w[:, first:5], rs[:, first:5])  # (L, 5 − first, 4, 4)

        def at(i: int, sign: float) -> FloatArray:
            if i < first:
                assert base is not None
                return base[0].samples[i, sign]
            k = i - first
            out = (
                A[:, k, None]
                + c[None, :, None, None] * B[:, k, None]
                + sign * s[None, :, None, None] * C[:, k, None]
            )
            self.samples[i, sign] = out
            return out

        E34: FloatArray
        if base is not None and same >= 4:
            E34 = base[0].E34
        else:
            E34 = at(2, 1.0)[:, :, None] @ at(3, 1.0)[:, None, :]  # (L, 3, 3, 4, 4)
        self.E34: FloatArray = E34
        X = E34[:, :, :, None] @ at(4, 1.0)[:, None, None, :]  # (L, 3, 3, 3, 4, 4)
        p = X[..., :3, :3] @ rs[:, None, None, None, 5, :, None] + X[..., :3, 3:]
        l = X[..., :3, :3] @ w[:, None, None, None, 5, :, None]
        E = _interpolate(_equations(p[..., 0], l[..., 0]))  # (L, 3, 3, 3, 14)
        self.P = np.moveaxis(E, -1, 1).reshape(L, 14, 3, 9)
        # The 14 equations' left sides as m₃₄₅ Pf, m₃₄₅ = (1, c₃, s₃) ⊗ (1, c₄, s₄) ⊗ (1, c₅, s₅)
        self.Pf = np.ascontiguousarray(self.P.transpose(0, 2, 3, 1).reshape(L, 27, 14))
        # Σ's arm part with θ₃ measured from φ, and from φ + 1 (`solve_general_6r`; computed
        # where first needed, `second_offset`): (L, 14, 27)
        self.G: tuple[FloatArray, FloatArray | None] = (
            poly_coefficients(self.P, THETA3_OFFSET).reshape(L, 14, 27),
            None,
        )
        # e₂⁻¹(θ₂ₖ) e₁⁻¹(θ₁ⱼ) at the samples: (L, 3 [j], 3 [k], 4, 4). With `fit`, the right-hand
        # side at the fitting points, and K by least squares (exact: the right-hand side is such
        # a polynomial); without (an arm built for one call), the right-hand side from M12.
        self.M12: FloatArray
        if base is not None and same >= 3:
            self.M12 = base[0].M12
        else:
            self.M12 = at(1, -1.0)[:, None, :] @ at(0, -1.0)[:, :, None]
        self.K: FloatArray | None = None
        if base is not None and same >= 3:  # K depends on M12 alone
            self.K = base[0].K
        elif fit:
            rhs = _right_hand_side(self.M12[:, None], _FIT[None, :, :3], _FIT[None, :, 3:])
            self.K = np.einsum("fs,lsx->lfx", _FIT_PINV, rhs.reshape(L, -1, 126))  # (L, 40, 126)
        # θ₆ (`_angles`): R₆ x₆ = (R₃R₄R₅)ᵀ (R₂ᵀR₁ᵀ) R_G x₆ for a unit x₆ ⟂ ω₆, with R₂ᵀR₁ᵀ over
        # (1, c₁, s₁) ⊗ (1, c₂, s₂) (L, 9, 3, 3) and the functionals (ω₆ × x₆)ᵀ and x₆ᵀ of
        # (R₃R₄R₅)ᵀ over m₃₄₅ (L, 27, 6)
        self.x6 = _perpendicular(w[:, 5])
        self.B12: FloatArray
        if base is not None and same >= 3:
            self.B12 = base[0].B12
        else:
            R12 = self.M12[..., :3, :3].reshape(L, 9, 3, 3)
            self.B12 = np.einsum("ab,lbij->laij", _V_INV2, R12)
        R345 = _interpolate(X[..., :3, :3].swapaxes(-1, -2).reshape(L, 3, 3, 3, 9))
        R345 = R345.reshape(L, 27, 3, 3)
        a = sp.cross(w[:, 5], self.x6)
        self.Bay = np.concatenate(
            (np.einsum("li,lnij->lnj", a, R345), np.einsum("li,lnij->lnj", self.x6, R345)), axis=2
        )
        self.Q2, self.S, self.W, self.Wi = _deflating_basis(self.P)
        self._lane_zero()

    def _lane_zero(self) -> None:
        """Lane 0's arrays for `_solve_one` (contiguous 2-D: one lane's products skip the stacks)
        and its constants as floats (`target_floats`)."""
        # `_solve_one` makes [C₂ | C₀ Q₂[:12] + C₁ Q₂[12:]] (12 × 28) as one product F E, with
        # E (2, 27, 28) stacking, for the equations and their products by x₄, the rows of Q₂ that
        # [F₀ F₁] multiplies and the columns of C₂ that F₂ fills (one product where five array
        # operations were: one target's arrays are so small that each operation costs ~1 µs).
        E = _E_TEMPLATE.copy()
        E[:, :18, 12:] = self.W[0].reshape(18, 2, 16).transpose(1, 0, 2)
        # `_shift_angles`: Wᵢ (24, 8), the ±i subspace's orthonormal basis, on which M acts as J;
        # with y = Wᵢ a + Q₂ z, a = (x I − J)⁻¹ Wᵢᵀ M Q₂ z and Wᵢᵀ M Q₂ = Wᵢ[:12]ᵀ Q₂[12:] −
        # Wᵢ[12:]ᵀ Y: the rows of that and of J times it, and the top rows of [Wᵢ Q₂]
        Wi = self.Wi
        Wt, Wb, Q2t, Q2b = Wi[0, :12], Wi[0, 12:], self.Q2[0, :12], self.Q2[0, 12:]
        WtQ = Wt.T @ Q2b
        top = np.concatenate((Wt, Q2t), axis=1)  # (12, 24): v = [Wᵢ Q₂][:12] (a, z)
        self.one = (
            np.concatenate((self.G[0][0], self.Pf[0].T), axis=1),  # (14, 54): Σ's and Pfᵀ
            E,
            np.ascontiguousarray(self.S[0]),
            # Q₂[12:]ᵀ (for Q₂ᵀ M Q₂ = S − Q₂[12:]ᵀ Y) over the rows Wᵢ[12:]ᵀ, J Wᵢ[12:]ᵀ: both
            # products with Y as one (32, 12)
            np.concatenate((self.Q2[0, 12:].T, Wb.T, _J @ Wb.T)),
            np.concatenate((WtQ, _J @ WtQ)),  # (16, 16)
            # the entries of v whose products `_shift_ratios` sums, as rows of [Wᵢ Q₂]
            np.concatenate((top[_PROD_A], top[_PROD_B])),  # (68, 24)
        )
        self.PfBay = np.concatenate((self.Pf[0], self.Bay[0]), axis=1)  # (27, 20): `_angles_one`
        self.floats = (
            self.r[0, 5].tolist(),
            self.w[0, 5].tolist(),
            self.origin[0].tolist(),
            self.x6[0].tolist(),
        )

    def lane(self, k: int) -> Arm:
        """Lane k of this arm as an arm of its own (its arrays views of this one's)."""
        out = Arm.__new__(Arm)
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray):
                value = value[k : k + 1]
            elif name == "G":
                value = tuple(None if v is None else v[k : k + 1] for v in value)
            elif name == "samples":
                value = {key: v[k : k + 1] for key, v in value.items()}
            setattr(out, name, value)
        out.lanes = 1
        out._lane_zero()
        return out

    @staticmethod
    def stack(arms: Sequence[Arm]) -> Arm:
        """One arm whose lanes are those of `arms` in turn (arms of one chain, all fitted or none).
        Its `samples` are left out: they serve arms built on a one-lane base."""
        if len(arms) == 1:
            return arms[0]
        out = Arm.__new__(Arm)
        for name, value in vars(arms[0]).items():
            if isinstance(value, np.ndarray):
                value = np.concatenate([getattr(a, name) for a in arms])
            elif name == "G":
                parts = [a.G for a in arms]
                value = tuple(
                    None
                    if any(p[i] is None for p in parts)
                    else np.concatenate([p[i] for p in parts])
                    for i in range(2)
                )
            elif name == "samples":
                value = {}
            setattr(out, name, value)
        out.lanes = sum(a.lanes for a in arms)
        return out

    def second_offset(self) -> FloatArray:
        """Σ's arm part with θ₃ measured from φ + 1 (L, 14, 27): for the rare target whose
        leading matrix C₂ is near singular from φ. Built on first use (an arm built for one call,
        `solve_general_6r_shifted`, seldom needs it)."""
        G1 = self.G[1]
        if G1 is None:
            G1 = poly_coefficients(self.P, THETA3_OFFSET + 1.0).reshape(self.lanes, 14, 27)
            self.G = (self.G[0], G1)
        return G1

    def tile(self, n: int) -> Arm:
        """This arm's K lanes repeated for n targets: lane i·K + k is target i, lane k."""
        return Arm.stack([self] * n)

    def target_floats(
        self, R: Sequence[Sequence[float]], t: Sequence[float]
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """`target_side` of one target of a fitted one-lane arm, from its rotation's rows R and
        translation t as floats: Q (14, 8), q₀ (14,), R_G x₆ (1, 3)."""
        assert self.K is not None
        (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = R
        t0, t1, t2 = t
        (r0, r1, r2), (w0, w1, w2), (o0, o1, o2), (x0, x1, x2) = self.floats
        k = 1.0 / self.scale
        # G′ x′ = (R (s x′ + o) + t − o) / s
        g0 = a0 * r0 + a1 * r1 + a2 * r2 + (a0 * o0 + a1 * o1 + a2 * o2 + t0 - o0) * k
        g1 = b0 * r0 + b1 * r1 + b2 * r2 + (b0 * o0 + b1 * o1 + b2 * o2 + t1 - o1) * k
        g2 = c0 * r0 + c1 * r1 + c2 * r2 + (c0 * o0 + c1 * o1 + c2 * o2 + t2 - o2) * k
        h = (1.0, a0 * w0 + a1 * w1 + a2 * w2, b0 * w0 + b1 * w1 + b2 * w2,
             c0 * w0 + c1 * w1 + c2 * w2)  # fmt: skip
        mu = (1.0, g0, g1, g2, g0 * g0, g0 * g1, g0 * g2, g1 * g1, g1 * g2, g2 * g2)
        rhs = (np.array([m * e for m in mu for e in h]) @ self.K[0]).reshape(14, 9)
        u = np.array([[a0 * x0 + a1 * x1 + a2 * x2, b0 * x0 + b1 * x1 + b2 * x2,
                       c0 * x0 + c1 * x1 + c2 * x2]])  # fmt: skip
        return rhs[:, 1:], rhs[:, 0], u

    def target_side(
        self, R: FloatArray, t: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Right-hand sides of L targets G = (R, t) (L, 3, 3), (L, 3) in the base frame [m]:
        Q (L, 14, 8) over m₁₂ and q₀ (L, 14); and R_G x₆ (L, 3) (for θ₆)."""
        L = R.shape[0]
        if L == 1 and self.K is not None:  # on floats: a tenth of the array operations' time
            Q, q0, u = self.target_floats(R[0].tolist(), t[0].tolist())
            return Q[None], q0[None], u
        # G in the solver's coordinates: G′ x′ = (R (s x′ + o) + t − o) / s
        ts = np.einsum("lij,lj->li", R, np.broadcast_to(self.origin, (L, 3))) + t - self.origin
        g = np.einsum("lij,lj->li", R, np.broadcast_to(self.r[:, 5], (L, 3))) + ts / self.scale
        h = np.einsum("lij,lj->li", R, np.broadcast_to(self.w[:, 5], (L, 3)))
        if self.K is None:
            rhs = _right_hand_side(self.M12, g, h)
        elif self.lanes > 1:
            rhs = (_features(g, h)[:, None, :] @ self.K)[:, 0]
        else:
            rhs = _features(g, h) @ self.K[0]
        rhs = rhs.reshape(L, 14, 9)
        u = np.einsum("lij,lj->li", R, np.broadcast_to(self.x6, (L, 3)))
        return rhs[:, :, 1:], rhs[:, :, 0], u


def _right_hand_side(M12: FloatArray, g: FloatArray, h: FloatArray) -> FloatArray:
    """The 14 equations' right-hand sides over (1, c₁, s₁) ⊗ (1, c₂, s₂) (…, 14 · 9) for g = G r₆
    and h = R_G ω₆ (…, 3), from e₂⁻¹e₁⁻¹ at the sample angles M12 (…, 3, 3, 4, 4)."""
    p = np.einsum("...jkab,...b->...jka", M12[..., :3, :3], g) + M12[..., :3, 3]
    l = np.einsum("...jkab,...b->...jka", M12[..., :3, :3], h)
    eq = _equations(p, l)
    rhs = np.einsum("ab,...be->...ea", _V_INV2, eq.reshape(eq.shape[:-3] + (9, 14)))
    return rhs.reshape(rhs.shape[:-2] + (126,))


def _deflating_basis(
    P: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Q₂ (L, 24, 16), orthonormal, spanning the complement of the companion matrix's invariant
    subspace of the spurious roots ±i; Q₂[:12]ᵀ Q₂[12:] (L, 16, 16); the rows of Q₂ that
    `_companion` multiplies [F₀ F₁] by, W (L, 18, 32); and that invariant subspace's basis
    (L, 24, 8), on which M acts as J = [[0, I], [−I, 0]] (`_shift_angles`).

    At x₃ = ±i, Σ = N (Pc ± i Ps) in the half-angle monomials of x₄, x₅ (the constant and q₀
    terms carry the factor 1 + x₃²). V = {v: K v[:9] = 0, K v[3:] = 0} with K = Pc + i Ps lies in
    Σ(i)'s null space for every target (four dimensions at least: K has rank one per vector
    equation), so (V, iV) are eigenvectors of M of eigenvalue i; their real and imaginary parts
    span an invariant subspace (8 dimensions) that Q₂ completes."""
    L = P.shape[0]
    Kc = (P[:, :, 1] + 1j * P[:, :, 2]).reshape(L, 14, 3, 3)
    Ki = Kc.reshape(L, 14, 9) @ _HALF2  # Hᵀ Kc H per equation
    Z = np.zeros((L, 28, 12), dtype=complex)
    Z[:, :14, :9] = Ki
    Z[:, 14:, 3:] = Ki
    info = 1
    if L == 1:  # one lane: LAPACK directly (~35 µs against NumPy's ~50)
        _, _, vt, info = lapack.zgesdd(Z[0], full_matrices=0)
    if info == 0:
        V = vt[None, -4:].conj().swapaxes(1, 2)
    else:
        V = np.linalg.svd(Z)[2][:, -4:].conj().swapaxes(1, 2)  # (L, 12, 4)
    W = np.concatenate(
        (
            np.concatenate((V.real, V.imag), axis=2),
            np.concatenate((-V.imag, V.real), axis=2),
        ),
        axis=1,
    )  # (L, 24, 8): real and imaginary parts of (V, iV)
    if L == 1:  # LAPACK directly (a third of NumPy's stacked QR: a shifted arm pays it per call)
        qr, tau, _, _ = lapack.dgeqrf(W[0])
        Q = lapack.dorgqr(np.concatenate((qr, np.zeros((24, 16))), axis=1), tau)[0][None]
    else:
        Q = np.linalg.qr(W, mode="complete")[0]
    Q2 = np.ascontiguousarray(Q[:, :, 8:])
    rows = np.concatenate(
        (
            np.concatenate((Q2[:, :9], Q2[:, 12:21]), axis=1),
            np.concatenate((Q2[:, 3:12], Q2[:, 15:24]), axis=1),
        ),
        axis=2,
    )
    return Q2, Q2[:, :12].swapaxes(1, 2) @ Q2[:, 12:], rows, W


# -- LAPACK on one lane (direct: NumPy's stacked wrappers cost ~10 µs a call more), NumPy on many
def _svd(Q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    if Q.shape[0] == 1:
        u, s, vt, info = lapack.dgesdd(Q[0])
        if info == 0:
            return u[None], s[None], vt[None]
    U, S, Vt = np.linalg.svd(Q)
    return U, S, Vt


def _solve(A: FloatArray, B: FloatArray) -> FloatArray:
    """A⁻¹ B for stacks; inf where a matrix is singular."""
    if A.shape[0] == 1:
        _, _, x, info = lapack.dgesv(A[0], B[0])
        return x[None] if info == 0 else np.full(B.shape, np.inf)
    try:
        return np.asarray(np.linalg.solve(A, B), dtype=np.float64)
    except np.linalg.LinAlgError:  # an exactly singular matrix in some lane: found by its LU
        singular = np.linalg.slogdet(A)[0] == 0
        x = np.linalg.solve(np.where(singular[:, None, None], np.eye(A.shape[1]), A), B)
        x[singular] = np.inf
        return np.asarray(x, dtype=np.float64)


def _eigvals(A: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Real and imaginary parts of the eigenvalues of a stack of real matrices."""
    if A.shape[0] == 1:
        wr, wi, _, _, info = lapack.dgeev(A[0], compute_vl=0, compute_vr=0)
        if info == 0:
            return wr[None], wi[None]
    lam = np.linalg.eigvals(A)
    return np.asarray(lam.real, dtype=np.float64), np.asarray(lam.imag, dtype=np.float64)


def _companion(
    arm: Arm, G: FloatArray, Q: FloatArray, q0: FloatArray, lanes: IntArray | None
) -> tuple[FloatArray, FloatArray, BoolArray, FloatArray, tuple[FloatArray, FloatArray]]:
    """For lanes of right-hand sides Q (L, 14, 8), q₀ (L, 14) and the arm part G (L or 1, 14, 27):
    the six eliminated equations F (L, 6, 27) (powers 0, 1, 2 of x₃, then x₄ⁱ x₅ʲ), the deflated
    companion matrix Q₂ᵀ M Q₂ (L, 16, 16), where C₂ was invertible (L,), the rows c₂, s₂, c₁, s₁
    of the pseudo-inverse of Q (L, 4, 14), and the same six equations in (cos, sin) of θ₃, θ₄, θ₅ for `_polish`:
    N Pfᵀ m₃₄₅ = N q₀, (L, 6, 27) and (L, 6). `lanes`: the arm lane of each lane (None: the
    arm's own).

    Σ's blocks are Cₖ = [[Fₖ, 0], [0, Fₖ]] (Fₖ on the columns x₄ⁱ x₅ʲ, i ≤ 2, and again on
    i ≥ 1 for the equations times x₄), so Cₖ X = [Fₖ X[:9]; Fₖ X[3:]]: products with Q₂ need no
    12 × 12 matrices, and one arm for every lane makes each of them one matrix product."""
    L = Q.shape[0]
    U, S, Vt = _svd(Q)  # Q = U S Vᵀ, U (L, 14, 14)
    N = U[:, :, 8:].swapaxes(1, 2)  # (L, 6, 14): left null space of Q
    inv_s = 1.0 / np.maximum(S, S[:, :1] * 1e-12)
    inv_s[S <= S[:, :1] * 1e-12] = 0.0
    # the pseudo-inverse's rows c₂, s₂, c₁, s₁ (the entries of m₁₂ that `_angles` reads)
    Q_pinv = (Vt.swapaxes(1, 2)[:, _M12_SEL] * inv_s[:, None, :]) @ U[:, :, :8].swapaxes(1, 2)
    shared = lanes is None and arm.lanes == 1
    Q2, S2, W = (arm.Q2, arm.S, arm.W) if lanes is None else (
        arm.Q2[lanes], arm.S[lanes], arm.W[lanes]
    )  # fmt: skip
    # N (P(θ₃) m₄₅ − q₀) = 0; q₀ joins the constant monomial.
    Nq = N @ q0[:, :, None]  # (L, 6, 1)
    if shared:
        F = (N.reshape(L * 6, 14) @ G[0]).reshape(L, 6, 27)
        NP = (N.reshape(L * 6, 14) @ arm.Pf[0].T).reshape(L, 6, 27)
    else:
        F = N @ G
        NP = N @ (arm.Pf if lanes is None else arm.Pf[lanes]).swapaxes(1, 2)
    F -= Nq * _CONSTANT
    # C₀ Q₂[:12] + C₁ Q₂[12:] = [F₀₁ W_top; F₀₁ W_bottom], F₀₁ = [F₀ F₁] (6 × 18)
    if shared:
        rhs = (F[:, :, :18].reshape(L * 6, 18) @ W[0]).reshape(L, 6, 2, 16)
    else:
        rhs = (F[:, :, :18] @ W).reshape(L, 6, 2, 16)
    C2 = np.zeros((L, 12, 12))
    C2[:, :6, :9] = F[:, :, 18:]
    C2[:, 6:, 3:] = F[:, :, 18:]
    # M Q₂ = [Q₂[12:]; −C₂⁻¹ (C₀ Q₂[:12] + C₁ Q₂[12:])]
    Y = _solve(C2, rhs.transpose(0, 2, 1, 3).reshape(L, 12, 16))
    # A near-singular C₂ shows as entries far larger than those of Σ.
    size = np.abs(F).max(axis=(1, 2))
    big = np.abs(Y).max(axis=(1, 2))
    good = big < _C2_CONDITION * size  # (False for inf and NaN)
    if not good.all():
        Y[~good] = 0.0
    if shared:
        QY = (Q2[0, 12:].T @ Y.transpose(1, 0, 2).reshape(12, L * 16)).reshape(16, L, 16)
        A = S2 - QY.transpose(1, 0, 2)
    else:
        A = S2 - Q2[:, 12:].swapaxes(1, 2) @ Y
    return F, A, good, Q_pinv, (NP, Nq[:, :, 0])


def _real_roots(
    F: FloatArray, A: FloatArray, ok_lanes: BoolArray
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
    """The real roots x₃ of lanes with deflated companion matrices A (L, 16, 16): lane and x₃ of
    each (R,), sorted, with θ₄, θ₅ (R,) from the null vectors of Σ(x₃) (`_companion`'s F)."""
    wr, wi = _eigvals(A)
    if A.shape[0] == 1:  # one lane: on floats
        xs = sorted(
            x for x, y in zip(wr[0].tolist(), wi[0].tolist(), strict=True)
            if abs(y) <= REAL_ROOT * (1.0 + x * x + y * y)
        ) if ok_lanes[0] else []  # fmt: skip
        lane = np.zeros(len(xs), dtype=np.int64)
        x3 = np.array(xs)
        near: BoolArray = np.array(
            [abs(b - a) <= CLUSTER * (1.0 + abs(b)) for a, b in zip(xs[:-1], xs[1:], strict=True)],
            dtype=bool,
        )
    else:
        real = (np.abs(wi) <= REAL_ROOT * (1.0 + wr * wr + wi * wi)) & ok_lanes[:, None]
        lane, slot = np.nonzero(real)
        x3 = wr[lane, slot]
        order = np.lexsort((x3, lane))
        lane, x3 = lane[order], x3[order]
        # Roots of a lane that coincide to within CLUSTER: one null space of their multiplicity.
        near = np.asarray(
            (lane[1:] == lane[:-1]) & (np.abs(np.diff(x3)) <= CLUSTER * (1.0 + np.abs(x3[1:]))),
            dtype=bool,
        )
    R = lane.size
    if not R:
        empty = np.empty(0)
        return lane, empty, empty, empty
    Fl = F if F.shape[0] == 1 else F[lane]
    x = x3[:, None, None]
    Fx = Fl[:, :, :9] + x * (Fl[:, :, 9:18] + x * Fl[:, :, 18:])  # (R, 6, 9)
    # One step of inverse iteration on Σ(x₃) = [[Fx, 0], [0, Fx]], shifted by ~ε‖Σ‖ (below x₃'s
    # own error; an exactly singular Σ would stop NumPy's stacked solve for every root).
    Sig = np.zeros((R, 12, 12))
    Sig[:, :6, :9] = Fx
    Sig[:, 6:, 3:] = Fx
    Sig += (1e-15 * np.abs(Fl).max()) * _EYE12 if F.shape[0] == 1 else (
        (1e-15 * np.abs(Fl).max(axis=(1, 2)))[:, None, None] * _EYE12
    )  # fmt: skip
    if R <= 3:  # LAPACK per root (NumPy's stacked solve costs ~9 µs a call)
        v = np.stack([_solve(S[None], _B[None, :, None])[0, :, 0] for S in Sig])
    else:
        v = _solve(Sig, np.broadcast_to(_B[:, None], (R, 12, 1)))[..., 0]
    bad: BoolArray = np.asarray(~np.isfinite(v).all(axis=1), dtype=bool)
    th4, th5 = _shift_ratios(np.where(bad[:, None], 0.0, v) if bad.any() else v)
    if near.any() or bad.any():
        _clusters(Sig, near, bad, th4, th5)
    return lane, x3, th4, th5


def _shift_ratios(v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """θ₄, θ₅ (R,) from null vectors v (R, 12) of the monomials x₄ⁱ x₅ʲ (3i + j): x₄ is the
    least-squares ratio of the entries x₄ⁱ⁺¹ x₅ʲ to x₄ⁱ x₅ʲ (i ≤ 2), x₅ that of x₄ⁱ x₅ʲ⁺¹ to
    x₄ⁱ x₅ʲ (j ≤ 1); θ = 2 atan2(num, den) with den ≥ 0, which also takes x = ±∞ (θ = π)."""
    s = (v[:, _PROD_A] * v[:, _PROD_B]) @ _PROD_SUM  # (R, 4): num₄, den₄, num₅, den₅
    th = 2.0 * np.arctan2(s[:, 0::2], s[:, 1::2])
    return th[:, 0], th[:, 1]


def _clusters(
    Sig: FloatArray, near: BoolArray, bad: BoolArray, th4: FloatArray, th5: FloatArray
) -> None:
    """θ₄, θ₅ of the roots in clusters (runs of `near`) and of roots whose Σ(x₃) (Sig (R, 12, 12))
    was exactly singular, in place. The null space U (12 × m) of Σ at a cluster of m roots (its
    members' mean: they are within `CLUSTER`) holds their m null vectors: the eigenvectors a of
    the shift x₄ + c x₅ on U's rows, (U₁ − μ U₀) a = 0, give v = U a."""
    R = Sig.shape[0]
    starts = np.flatnonzero(np.concatenate(([True], ~near)))
    ends = np.append(starts[1:], R)
    need = (ends - starts > 1) | (np.add.reduceat(bad, starts) > 0)
    for start, end in zip(starts[need].tolist(), ends[need].tolist(), strict=True):
        m = end - start
        # LAPACK directly where it succeeds (NumPy's wrappers cost ~10 µs a call more: most
        # targets of an arm whose wrist nearly meets have such a pair), NumPy's where it fails
        # their mean (of a pair, the usual cluster, without `mean`'s ~5 µs of overhead)
        S = 0.5 * (Sig[start] + Sig[start + 1]) if m == 2 else Sig[start:end].mean(axis=0)
        _, _, vt, info = lapack.dgesdd(S)
        U = (vt if info == 0 else np.linalg.svd(S)[2])[-m:].T  # (12, m)
        c = 0.5772156649015329  # any constant: x₄ + c x₅ also separates roots sharing x₄
        Ub, rhs = U[_BASE], U[_BASE + 3] + c * U[_BASE + 1]
        # By LAPACK's dgelss (an SVD) directly (~2 µs; NumPy's lstsq ~8), not dgels: OpenBLAS
        # may hand dgels's small triangular products to its threads, and after a large call (a
        # stack's, or any 400 × 400 product in the same process) each one waited for them, 2.6
        # ms at the median (`docs/closed_form.md`). A cluster of more than 6 roots (a fuzzed
        # degenerate arm gave one) has more unknowns than rows: NumPy's lstsq, minimum norm.
        info = 1
        if m <= Ub.shape[0]:
            _, X, _, _, _, info = lapack.dgelss(Ub, rhs)
        W = X[:m] if info == 0 else np.linalg.lstsq(Ub, rhs, rcond=None)[0]
        _, wi, _, vr, info = lapack.dgeev(W, compute_vl=0)
        if info == 0 and not wi.any():
            v = U @ vr  # (12, m)
        else:  # (a complex pair, not a double root: the FK check rejects)
            if info == 0:  # dgeev's pairs as columns (re, im): the vectors re ± i im
                vc = vr.astype(complex)
                for j in np.flatnonzero(wi > 0).tolist():
                    vc[:, j] = vr[:, j] + 1j * vr[:, j + 1]
                    vc[:, j + 1] = vc[:, j].conj()
            else:
                vc = np.linalg.eig(W)[1]
            v = U @ vc
            top = v[np.abs(v).argmax(axis=0), np.arange(m)]
            v = (v * (np.abs(top) / np.where(top == 0, 1.0, top))).real
        th4[start:end], th5[start:end] = _shift_ratios(np.ascontiguousarray(v.T))


def solve_general_6r(
    arm: Arm,
    R: FloatArray,
    t: FloatArray,
    trace: Trace,
    sides: tuple[FloatArray, FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, BoolArray]:
    """All (≤ 16) solutions of e₁ ⋯ e₆ = G = (R, t) for L lanes: Q (L, 16, 6), ok (L, 16).

    `arm`: the lanes' axes (one arm for every lane, or one per lane). `sides`: the right-hand
    sides Q (L, 14, 8), q₀ (L, 14) and θ₆'s b12u (L, 9, 3) where the caller has them
    (`MovedFirst`), else `Arm.target_side`'s. Unpolished: the caller refines and checks by
    forward kinematics.
    """
    L = R.shape[0]
    if sides is None:
        Q, q0, u = arm.target_side(R, t)
        b12u = (arm.B12 @ u[:, None, :, None])[..., 0]  # (L, 9, 3): R₂ᵀR₁ᵀ u over m₁₂
    else:
        Q, q0, b12u = sides
    if L == 1 and arm.lanes == 1:
        one = _solve_one(arm, Q[0], q0[0], b12u[0])
        if one is not None:
            Qout = np.zeros((1, BRANCHES, 6))
            ok = np.zeros((1, BRANCHES), dtype=bool)
            k = min(one.shape[0], BRANCHES)
            Qout[0, :k] = one[:k]
            ok[0, :k] = np.isfinite(one[:k]).all(axis=1)
            trace.fails.append(("reach", ok))
            return Qout, ok
    F, A, good, Q_pinv, eqs = _companion(arm, arm.G[0], Q, q0, None)
    lane, x3, th4, th5 = _real_roots(F, A, good)
    th3 = THETA3_OFFSET + 2.0 * np.arctan(x3)
    if not good.all():  # C₂ near singular: θ₃ = φ + π nearly a root; measure from another offset
        bad = np.flatnonzero(~good)
        sub = bad if arm.lanes > 1 else None
        G2 = arm.second_offset()[bad] if arm.lanes > 1 else arm.second_offset()
        F2, A2, good2, _, _ = _companion(arm, G2, Q[bad], q0[bad], sub)
        lane2, x3b, th4b, th5b = _real_roots(F2, A2, good2)
        lane = np.concatenate((lane, bad[lane2]))
        th3 = np.concatenate((th3, THETA3_OFFSET + 1.0 + 2.0 * np.arctan(x3b)))
        th4, th5 = np.concatenate((th4, th4b)), np.concatenate((th5, th5b))
        order = np.argsort(lane, kind="stable")
        lane, th3, th4, th5 = lane[order], th3[order], th4[order], th5[order]
    Qout = np.zeros((L, BRANCHES, 6))
    ok = np.zeros((L, BRANCHES), dtype=bool)
    if lane.size:
        q = _angles(arm, lane, th3, th4, th5, b12u, q0, Q_pinv, eqs)
        slot = np.arange(lane.size) - np.searchsorted(lane, lane)  # the root's place in its lane
        keep = slot < BRANCHES
        Qout[lane[keep], slot[keep]] = q[keep]
        ok[lane[keep], slot[keep]] = np.isfinite(q[keep]).all(axis=1)
    trace.fails.append(("reach", ok))
    return Qout, ok


def solve_one_rows(
    arm: Arm, R: Sequence[Sequence[float]], t: Sequence[float], polish: bool = True
) -> FloatArray | None:
    """The solutions (k, 6) of one target G of a fitted 6R arm (one lane), its rotation's rows R
    and translation t as floats, angles in (−π, π]; None where `solve_general_6r` must decide
    (`_solve_one`). Without `polish` the roots skip `_angles`' Gauss–Newton step: for a caller
    that checks (and refines) by forward kinematics only the one solution it takes (`ik`)."""
    Q, q0, u = arm.target_floats(R, t)
    q = _solve_one(arm, Q, q0, arm.B12[0] @ u[0], polish)
    if q is None or np.isfinite(q).all():
        return q
    return q[np.isfinite(q).all(axis=1)]


def _solve_one(
    arm: Arm, Q: FloatArray, q0: FloatArray, b12u: FloatArray, polish: bool = True
) -> FloatArray | None:
    """`solve_general_6r` of one target of a 6R arm (Q (14, 8), q₀ (14,), and b12u (9, 3) the
    coefficients of R₂ᵀR₁ᵀ R_G x₆ over m₁₂ (`Arm.B12` times u = R_G x₆), for θ₆):
    the same steps on 2-D arrays with LAPACK called directly, about half the time of the stacked
    form on one lane. The solutions (R, 6); None where the stacked form must decide (C₂ near
    singular). The null vectors of Σ(x₃) come from the deflated matrix's eigenvectors, computed
    in the same LAPACK call as its eigenvalues (`_shift_angles`), not by inverse iteration per
    root; roots that coincide share a null space as in `_real_roots` (`_clusters`). Without
    `polish`, the angles by `_angles_one`."""
    GP, E, S0, QB, A0, GAB = arm.one
    parts = _null_and_pinv(Q)
    if parts is None:
        return None
    N, Q_pinv = parts
    Nq = N @ q0
    H = N @ GP  # N times Σ's arm part, and N Pfᵀ (`_angles`' polish)
    F = H[:, :27] - Nq[:, None] * _CONSTANT  # (6, 27)
    CX = (F @ E).reshape(12, 28)  # [C₂ | C₀ Q₂[:12] + C₁ Q₂[12:]] (`Arm.one`)
    _, _, Y, info = lapack.dgesv(CX[:, :12], CX[:, 12:])
    size = float(np.abs(F).max())
    if info or not float(np.abs(Y).max()) < _C2_CONDITION * size:
        return None
    T = QB @ Y  # (32, 16): Q₂[12:]ᵀ Y, then `_shift_angles`' rows times Y
    wr, wi, _, vr, info = lapack.dgeev(S0 - T[:16], compute_vl=0)
    if info:
        return None
    # the real roots, sorted, on floats (at most 16: Python's loop beats array operations)
    wl, il = wr.tolist(), wi.tolist()
    idx = [
        i for i, y in enumerate(il)
        if y == 0.0 or abs(y) <= REAL_ROOT * (1.0 + wl[i] ** 2 + y * y)
    ]  # fmt: skip
    idx.sort(key=wl.__getitem__)
    R = len(idx)
    if not R:
        return np.empty((0, 6))
    xl = [wl[i] for i in idx]
    xs = np.array(xl)
    # Σ(x₃)'s null vectors (`_shift_angles`) as (a, z), and their θ₄, θ₅
    Z = vr[:, idx]
    P = (A0 - T[16:]) @ Z  # (16, R): Wᵢᵀ M Q₂ z and J times it
    inv = np.array([1.0 / (1.0 + x * x) for x in xl])
    aZ = np.concatenate(((P[:8] * xs + P[8:]) * inv, Z))  # (24, R): (a, z)
    th = np.empty((3, R))  # θ₃, θ₄, θ₅ (rows)
    th[0] = [THETA3_OFFSET + 2.0 * math.atan(x) for x in xl]
    th[1:] = _shift_angles(GAB @ aZ)
    near = [b - a <= CLUSTER * (1.0 + abs(b)) for a, b in zip(xl[:-1], xl[1:], strict=True)]
    if any(near):  # roots that coincide: their shared null space (`_clusters`)
        x = xs[:, None, None]
        Fx = F[:, :9] + x * (F[:, 9:18] + x * F[:, 18:])  # (R, 6, 9)
        Sig = np.zeros((R, 12, 12))  # Σ(x₃) + 1e-15‖Σ‖ I (`_real_roots`)
        Sig[:, :6, :9] = Fx
        Sig[:, 6:, 3:] += Fx
        Sig[:, _DIAG, _DIAG] += 1e-15 * size
        _clusters(Sig, np.array(near), np.zeros(R, dtype=bool), th[1], th[2])
    return _angles_one(arm, th, b12u, q0, Q_pinv, (H[:, 27:], Nq) if polish else None)


def _null_and_pinv(Q: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """The left null space N (6, 14) of one target's Q (14, 8) (orthonormal rows) and its
    pseudo-inverse's rows c₂, s₂, c₁, s₁ of m₁₂ (4, 14), those `_angles` reads; None if LAPACK
    fails. By QR (`dgeqrf`, `dorgqr`, `dtrtri`: ~9 µs
    against the SVD's ~16) where R's reciprocal condition number is above `_Q_RCOND`; else by
    the SVD, singular values below 1e-12 of the largest taken as zero (a Q of lower rank). Any
    orthonormal basis of the null space gives the same Σ(x₃) up to an orthogonal mix of its
    rows: the same roots, null vectors and Y = C₂⁻¹[C₀ C₁]."""
    qr, tau, _, info = lapack.dgeqrf(Q)
    if info == 0 and lapack.dtrcon(qr[:8])[0] > _Q_RCOND:
        A = np.zeros((14, 14))
        A[:, :8] = qr
        Qf, _, info = lapack.dorgqr(A, tau)
        if info == 0:
            # R⁻¹ by `dtrtri` (its strictly lower part still holds the reflectors), not
            # `dtrsm` through `dtrtrs`: OpenBLAS may run that on threads, and on a busy machine
            # a call then waits milliseconds for the second one
            Rinv, info = lapack.dtrtri(qr[:8])
            if info == 0:
                return Qf[:, 8:].T, (Rinv[_M12_SEL] * _UPPER8_SEL) @ Qf[:, :8].T
    U, S, Vt, info = lapack.dgesdd(Q)
    if info:
        return None
    s = S.tolist()
    cut = s[0] * 1e-12
    inv = np.array([1.0 / x if x > cut else 0.0 for x in s])
    return U[:, 8:].T, (Vt.T[_M12_SEL] * inv) @ U[:, :8].T


def _shift_angles(VAB: FloatArray) -> FloatArray:
    """θ₄, θ₅ (2, R) of null vectors v = [Wᵢ Q₂][:12] (a, z) given as the entries that
    `_shift_ratios` multiplies, VAB = [v[_PROD_A]; v[_PROD_B]] (68, R) (`_solve_one`: one product
    of the arm's rows (`Arm.one`) with (a, z)). Σ(x₃)'s null vector v itself is the eigenvector
    y = (v, x₃ v) = Wᵢ a + Q₂ z of M, with (x₃ I − J) a = Wᵢᵀ M Q₂ z (J² = −I: (x₃ I − J)⁻¹ =
    (x₃ I + J) / (1 + x₃²)), z the deflated matrix's eigenvector: only products, no solve per
    root (inverse iteration's), and no exactly singular Σ(x₃) to fall back from."""
    s = _PROD_SUM_T @ (VAB[:34] * VAB[34:])  # (4, R): num₄, den₄, num₅, den₅
    return 2.0 * np.arctan2(s[0::2], s[1::2])


def _polish_steps(J: FloatArray, res: FloatArray) -> FloatArray:
    """One Gauss–Newton step (R, 3) on R sets of six equations in θ₃, θ₄, θ₅ with residuals res
    (R, 6) and Jacobians given transposed, J (R, 3, 6): Δθ = −(J Jᵀ)⁻¹ J res. A step is a
    polish: one that is not small (a root far from converging, or a singular J Jᵀ: not finite)
    is not taken. The 3 × 3 solves by the adjugate (`_ADJ`) on every root at once (hand-written
    for speed: ~15 µs on 8 roots, where `np.linalg.solve` with the damping it needs took ~22)."""
    A = (J @ J.swapaxes(1, 2)).reshape(-1, 9)
    adj = A.take(_ADJ[0], 1) * A.take(_ADJ[1], 1) - A.take(_ADJ[2], 1) * A.take(_ADJ[3], 1)
    det = A[:, 0] * adj[:, 0] + A[:, 1] * adj[:, 3] + A[:, 2] * adj[:, 6]
    g = J @ res[:, :, None]  # (R, 3, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        step = (adj.reshape(-1, 3, 3) @ g)[:, :, 0] / -det[:, None]
    # (NaN fails the test too; the ufunc's reduce skips `max`'s wrapper)
    small = np.maximum.reduce(np.abs(step), axis=1) < _POLISH_LIMIT
    return np.where(small[:, None], step, 0.0)


def _angles_one(
    arm: Arm,
    th: FloatArray,
    b12u: FloatArray,
    q0: FloatArray,
    Q_pinv: FloatArray,
    eqs: tuple[FloatArray, FloatArray] | None = None,
) -> FloatArray:
    """`_angles` on one lane's roots: θ₃, θ₄, θ₅ as the rows of th (3, R) → full solutions
    (R, 6), in fewer array operations (hand-written for speed: one target's arrays are so small
    that each operation costs about a microsecond): angles as rows, so that each joint's is a
    contiguous slice; the rows (1, cos θ, sin θ) and their derivatives (0, −sin θ, cos θ) from
    one call of np.cos; m₃₄₅ and its three derivatives as one stack; Pf and Bay as one product.
    b12u (9, 3): R₂ᵀR₁ᵀ R_G x₆ over m₁₂ (`_solve_one`), q₀ (14,), Q_pinv: the pseudo-inverse's
    rows c₂, s₂, c₁, s₁ (4, 14). With `eqs` (N Pfᵀ (6, 27), N q₀ (6,)), polished first by
    `_angles`' Gauss–Newton step."""
    R = th.shape[1]
    q = np.empty((6, R))
    if eqs is None:
        t = np.cos(th[:, :, None] * _K3 - _PH3)  # (3, R, 3)
        m345 = (t[0, :, :, None, None] * t[1, :, None, :, None] * t[2, :, None, None, :]).reshape(
            R, 27
        )
        q[2:5] = th
    else:
        td = np.cos(th[:, :, None] * _K6 - _PH6)  # (3, R, 6): (1, c, s) and (0, −s, c)
        # rows of m₃₄₅ (0) and of its derivatives by θ₃, θ₄, θ₅ (1-3): (R, 4, 27)
        a3, a4, a5 = td[0][:, _D3[0]], td[1][:, _D3[1]], td[2][:, _D3[2]]  # (R, 4, 3) each
        M = (a3[:, :, :, None, None] * a4[:, :, None, :, None] * a5[:, :, None, None, :]).reshape(
            R, 4, 27
        )
        NP, Nq = eqs
        E = M @ NP.T  # (R, 4, 6): the equations, then Jᵀ
        step = _polish_steps(E[:, 1:], E[:, 0] - Nq)  # (R, 3)
        q[2:5] = th + step.T
        m345 = M[:, 0] + (step[:, None, :] @ M[:, 1:])[:, 0]  # to first order
    lhs = m345 @ arm.PfBay  # (R, 20): P's 14 equations, then Bay's 6 functionals
    m12 = (lhs[:, :14] - q0) @ Q_pinv.T  # (R, 4): c₂, s₂, c₁, s₁
    q[1::-1] = np.arctan2(m12[:, 1::2], m12[:, 0::2]).T  # θ₂, θ₁
    t12 = np.cos(q[:2, :, None] * _K3 - _PH3)  # (2, R, 3)
    m12f = (t12[0, :, :, None] * t12[1, :, None, :]).reshape(R, 9)
    w12 = m12f @ b12u  # (R, 3): R₂ᵀR₁ᵀ R_G x₆
    yw = lhs[:, 14:].reshape(R, 2, 3) @ w12[:, :, None]  # ((ω₆ × x₆)·y, x₆·y)
    q[5] = np.arctan2(yw[:, 0, 0], yw[:, 1, 0])
    return q.T


def _angles(
    arm: Arm,
    lane: IntArray,
    theta3: FloatArray,
    theta4: FloatArray,
    theta5: FloatArray,
    b12u: FloatArray,
    q0: FloatArray,
    Q_pinv: FloatArray,
    eqs: tuple[FloatArray, FloatArray],
    polish: bool = True,
) -> FloatArray:
    """Full solutions (R, 6) of roots (θ₃, θ₄, θ₅) (R,) of lanes `lane`, first polished by one
    Gauss–Newton step on the six eliminated equations `eqs` (`_companion`): θ₁, θ₂ from the 14
    equations by least squares, Q m₁₂ = P(θ₃) m₄₅ − q₀; θ₆ from the orientation, y = R₆ x₆ =
    (R₃R₄R₅)ᵀ (R₂ᵀR₁ᵀ) u with u = R_G x₆: R₂ᵀR₁ᵀ u over m₁₂ per lane, b12u (L or 1, 9, 3)
    (`solve_general_6r`), and (R₃R₄R₅)ᵀ by `Arm.Bay`."""
    R = lane.size
    one = arm.lanes == 1
    q = np.empty((R, 6))
    q[:, 2], q[:, 3], q[:, 4] = theta3, theta4, theta5
    # rows (1, cos θ, sin θ) of θ₃, θ₄, θ₅ (R, 3, 3) and m₃₄₅ = t₃ ⊗ t₄ ⊗ t₅ (R, 27)
    t = np.empty((R, 3, 3))
    t[:, :, 0] = 1.0
    c, sn = np.cos(q[:, 2:5]), np.sin(q[:, 2:5])
    t[:, :, 1], t[:, :, 2] = c, sn
    t34 = t[:, 0, :, None] * t[:, 1, None, :]  # (R, 3, 3)
    m345 = (t34[:, :, :, None] * t[:, 2, None, None, :]).reshape(R, 27)
    if polish:
        # One Gauss–Newton step on N (Pfᵀ m₃₄₅(θ₃, θ₄, θ₅) − q₀) = 0 (6 equations, 3 unknowns): a
        # root found to ε / gap (near-double roots, as wrists that nearly meet give) comes back
        # to ε. The derivatives of m₃₄₅ by each angle replace its row by (0, −sin θ, cos θ).
        d = np.zeros((R, 3, 3))
        d[:, :, 1], d[:, :, 2] = -sn, c
        dm = np.empty((R, 3, 27))
        dm[:, 0] = (
            (d[:, 0, :, None] * t[:, 1, None, :])[:, :, :, None] * t[:, 2, None, None, :]
        ).reshape(R, 27)
        dm[:, 1] = (
            (t[:, 0, :, None] * d[:, 1, None, :])[:, :, :, None] * t[:, 2, None, None, :]
        ).reshape(R, 27)
        dm[:, 2] = (t34[:, :, :, None] * d[:, 2, None, None, :]).reshape(R, 27)
        NP, Nq = eqs
        NPt = NP[0].T if NP.shape[0] == 1 else NP[lane].swapaxes(1, 2)
        J = dm @ NPt  # (R, 3, 6) = Jᵀ
        step = _polish_steps(J, (m345[:, None, :] @ NPt)[:, 0] - Nq[lane])  # (R, 3)
        q[:, 2:5] += step
        m345 = m345 + (step[:, None, :] @ dm)[:, 0]  # to first order
    if one:
        lhs = m345 @ arm.Pf[0]  # (R, 14)
        Yv = m345 @ arm.Bay[0]  # (R, 6)
    else:
        lhs = np.einsum("rn,rne->re", m345, arm.Pf[lane])
        Yv = np.einsum("rn,rnk->rk", m345, arm.Bay[lane])
    lhs -= q0[lane]
    if Q_pinv.shape[0] == 1:
        m12 = lhs @ Q_pinv[0].T  # (R, 4): c₂, s₂, c₁, s₁
    else:
        m12 = np.einsum("rke,re->rk", Q_pinv[lane], lhs)
    q[:, 0] = np.arctan2(m12[:, 3], m12[:, 2])
    q[:, 1] = np.arctan2(m12[:, 1], m12[:, 0])
    t12 = np.ones((R, 2, 3))  # rows (1, cos θ, sin θ) of θ₁, θ₂
    t12[:, :, 1] = np.cos(q[:, :2])
    t12[:, :, 2] = np.sin(q[:, :2])
    # R₂ᵀR₁ᵀ u at each root, from its coefficients over m₁₂ (9, 3) per lane of targets
    m12f = (t12[:, 0, :, None] * t12[:, 1, None, :]).reshape(R, 1, 9)
    if b12u.shape[0] == 1:
        w12 = (m12f[:, 0] @ b12u[0])[:, :, None]  # (R, 3, 1)
    else:
        w12 = (m12f @ b12u[lane]).swapaxes(1, 2)
    yw = (Yv.reshape(R, 2, 3) @ w12)[:, :, 0]  # ((ω₆ × x₆)·y, x₆·y)
    q[:, 5] = np.arctan2(yw[:, 0], yw[:, 1])
    return q


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
    axes (three axes through a point among joints 3-5, say) need not for another. `arm`, when
    given: the prepared `Arm` of w, r (shift 0), or for shift > 0 an arm of one lane built from
    w, r in the loop's order (`shifted_base`), whose first 6 − k joints (those G does not move)
    one target's arm takes from it (the arm is built per call: that part of it once). With such
    an arm and k ≥ 4, the loop is written with the moved joints first (`MovedFirst`): every
    lane then shares the arm as it stands, and only the right-hand sides move with the targets.
    For k ≥ 4 `arm` may also hold one such lane per lane of w, r and the targets (a 7R arm's
    held values)."""
    if shift == 0:
        return solve_general_6r(arm or Arm(w, r, scale, fit=False), R, t, trace)
    L = R.shape[0]
    order = _loop_order(shift)
    if shift >= 4 and arm is not None and arm.lanes == w.shape[0] and arm.lanes in (1, L):
        # (one arm for every lane, or one per lane: a 7R arm's held values, `held_shifted`)
        sides = MovedFirst(arm, shift).right_hand_side(R, t)
        Q, ok = solve_general_6r(arm, R, t, trace, sides)
        return Q[..., np.argsort(order)], ok
    Rt = R.swapaxes(1, 2)
    wl = np.broadcast_to(w, (L,) + w.shape[1:]).copy()
    rl = np.broadcast_to(r, (L,) + r.shape[1:]).copy()
    wl[:, :shift] = np.einsum("lij,lkj->lki", Rt, wl[:, :shift])
    rl[:, :shift] = np.einsum("lij,lkj->lki", Rt, rl[:, :shift] - t[:, None])
    base = (arm, 6 - shift) if arm is not None and L == 1 and arm.lanes == 1 else None
    Q, ok = solve_general_6r(
        Arm(wl[:, order], rl[:, order], scale, fit=False, base=base), R, t, trace
    )
    return Q[..., np.argsort(order)], ok


def _loop_order(shift: int) -> list[int]:
    """The joints in the order of the loop read from joint `shift` + 1 (0-based indices)."""
    return [*range(shift, 6), *range(shift)]


def solve_one_shifted(
    base: Arm,
    w: FloatArray,
    r: FloatArray,
    shift: int,
    R: Sequence[Sequence[float]],
    t: Sequence[float],
    polish: bool = True,
) -> FloatArray | None:
    """`solve_one_rows` of one target G = (R, t) (rotation rows and translation as floats) with
    the loop read from joint `shift` + 1 ≤ 4 (`solve_general_6r_shifted`; from joint 5 or 6:
    `MovedFirst`), its arm built on `base` (`shifted_base`): the loop's last `shift` joints move
    with the target, and the arm's parts of its first 6 − shift joints come from `base`. None
    where the stacked form must decide. Axes w, r (1, 6, 3)."""
    assert 1 <= shift <= 3, shift
    Ra, ta = np.array(R), np.array(t)
    order = _loop_order(shift)
    wl, rl = w.copy(), r.copy()
    wl[:, :shift] = wl[:, :shift] @ Ra  # Rᵀ w, row by row
    rl[:, :shift] = (rl[:, :shift] - ta) @ Ra
    arm = Arm(wl[:, order], rl[:, order], base.scale, fit=False, base=(base, 6 - shift))
    q = solve_one_rows(arm, R, t, polish)
    return None if q is None else q[:, np.argsort(order)]


class MovedFirst:
    """The right-hand sides of a 6R arm whose loop is read from joint k + 1 = 5 or 6 (shift
    k = 4, 5), the joints that the target moves written first (`solve_general_6r_shifted`):
    the arm (`shifted_base`, one lane or one per lane of targets) serves every target as it
    stands, and only the right-hand side moves with the target, in closed form.

    The loop's first 6 − k joints are moved by G, aᵢ = G eᵢ G⁻¹ (eᵢ about the joint's own axis),
    so the right-hand side's map a₂⁻¹a₁⁻¹ G (applied to r₆, ω₆ and, for θ₆, x₆) is

        G e₂⁻¹e₁⁻¹  (k = 4: both moved),        e₂⁻¹ G e₁⁻¹  (k = 5: the first moved),

    the target one rigid motion between the arm's sample transforms (`Arm.M12`: e₂⁻¹e₁⁻¹ at the
    3 × 3 sample angles; at the sample angle 0 one factor is I, so e₁⁻¹ = M12[:, 0] and
    e₂⁻¹ = M12[0, :]). Per target: that motion applied to points and directions prepared once,
    the 14 equations at the samples and their interpolation, where an arm with the moved joints
    built per target cost about twice as much for one target."""

    def __init__(self, arm: Arm, shift: int) -> None:
        assert shift in (4, 5), shift
        self.arm = arm
        self.order = np.argsort(_loop_order(shift))
        L = arm.lanes
        # r₆ (a point) and ω₆, x₆ (directions) as homogeneous columns (L, 1, 1, 4, 3)
        H = np.zeros((L, 1, 1, 4, 3))
        H[..., :3, 0], H[..., :3, 1], H[..., :3, 2] = (
            x[:, None, None] for x in (arm.r[:, 5], arm.w[:, 5], arm.x6)
        )
        H[..., 3, 0] = 1.0
        M12 = arm.M12  # (L, 3 [j], 3 [k], 4, 4)
        # k = 4: G (e₂⁻¹e₁⁻¹ H) at the samples [j, k] (L, 3, 3, 4, 3); k = 5: e₂⁻¹[k] G (e₁⁻¹[j] H)
        # (L, 3, 1, 4, 3), e₂⁻¹ (L, 1, 3, 4, 4) after the target
        self.inner = M12 @ H if shift == 4 else M12[:, :, :1] @ H
        self.after = None if shift == 4 else M12[:, None, 0]
        self.origin, self.scale = arm.origin, arm.scale
        self.origin_floats = arm.origin[0].tolist()  # (`solve`: one lane)

    def right_hand_side(
        self, R: FloatArray, t: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Q (L, 14, 8), q₀ (L, 14) and θ₆'s b12u (L, 9, 3) (`solve_general_6r`'s `sides`) of
        L targets G = (R, t) ((L, 3, 3), (L, 3)) in the base frame [m]."""
        # G in the arm's coordinates, G′ x′ = (R (s x′ + o) + t − o) / s, as 4 × 4 (L, 1, 1, 4, 4)
        Gs = np.zeros((R.shape[0], 1, 1, 4, 4))
        Gs[:, 0, 0, :3, :3] = R
        Gs[:, 0, 0, :3, 3] = ((R @ self.origin[..., None])[..., 0] + t - self.origin) / self.scale
        Gs[..., 3, 3] = 1.0
        return self._sides(Gs)

    def _sides(self, Gs: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """`right_hand_side` of targets given in the arm's coordinates, Gs (L, 1, 1, 4, 4)."""
        L = Gs.shape[0]
        Y = Gs @ self.inner
        if self.after is not None:
            Y = self.after @ Y  # (L, 3, 3, 4, 3)
        # [lane and sample, xyz, (r₆, ω₆, x₆)] (2-D slices: `_equations` costs half as much)
        Y = Y[..., :3, :].reshape(L * 9, 3, 3)
        eqs = _equations(Y[:, :, 0], Y[:, :, 1])  # (9L, 14)
        coef = _V_INV2 @ np.concatenate((eqs, Y[:, :, 2]), axis=1).reshape(L, 9, 17)
        rhs = coef[..., :14].swapaxes(1, 2)
        return rhs[..., 1:], rhs[..., 0], coef[..., 14:]

    def solve(
        self, R: Sequence[Sequence[float]], t: Sequence[float], polish: bool = True
    ) -> FloatArray | None:
        """`solve_one_rows` of one target G = (R, t) (rotation rows and translation as floats) of
        a one-lane arm: the solutions (k, 6) in the chain's joint order; None where the stacked
        form must decide."""
        (o0, o1, o2), k = self.origin_floats, 1.0 / self.scale
        Gs = np.array([
            [*row, (row[0] * o0 + row[1] * o1 + row[2] * o2 + ti - oi) * k]
            for row, ti, oi in zip(R, t, (o0, o1, o2), strict=True)
        ] + [[0.0, 0.0, 0.0, 1.0]])  # fmt: skip
        Q, q0, b12u = self._sides(Gs.reshape(1, 1, 1, 4, 4))
        q = _solve_one(self.arm, Q[0], q0[0], b12u[0], polish)
        if q is None:
            return None
        if not np.isfinite(q).all():
            q = q[np.isfinite(q).all(axis=1)]
        return q[:, self.order]


def shifted_base(w: FloatArray, r: FloatArray, scale: float, shift: int) -> Arm:
    """The arm of one lane of axes w, r (1, 6, 3) in the order of the loop read from joint
    `shift` + 1 (`solve_general_6r_shifted`'s `arm` for shift > 0): built once per chain, its
    joints that the target does not move are shared by every target's arm."""
    order = _loop_order(shift)
    # fitted: K depends on joints 1, 2 alone, so every target's arm takes it (its right-hand
    # side then costs one product on floats, `target_floats`, not `_right_hand_side`'s ~20 µs);
    # for shift ≥ 4 the target moves joint 1 (and 2) of the loop, which `MovedFirst` moves
    # through the samples of M12 instead
    return Arm(w[:, order], r[:, order], scale, fit=shift <= 3)


def _perpendicular(a: FloatArray) -> FloatArray:
    """A unit vector normal to each unit vector a (…, 3): a × e₁, or a × e₂ where a is near e₁
    (written out: `np.cross` costs ~20 µs on a few vectors, and an arm built for one call,
    `solve_general_6r_shifted`, pays it every call)."""
    if a.shape == (1, 3):  # one lane (an arm built per call): on floats
        b0, b1, b2 = a[0].tolist()
        v = (-b2, 0.0, b0) if abs(b0) >= 0.9 else (0.0, b2, -b1)
        n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        return np.array([[v[0] / n, v[1] / n, v[2] / n]])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    near_x = np.abs(a0) >= 0.9
    zero = np.zeros_like(a0)
    x = np.stack(
        (np.where(near_x, -a2, zero), np.where(near_x, zero, a2), np.where(near_x, a0, -a1)),
        axis=-1,
    )
    return x / np.sqrt((x * x).sum(axis=-1, keepdims=True))
