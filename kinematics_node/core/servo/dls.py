"""Damped least squares with variable damping: joint velocities for a task twist, singularity-robust.

For J = Σ σᵢ uᵢ vᵢᵀ (SVD, σ₁ ≥ … ≥ σ_m) and a task velocity x, the solution is

    q̇ = Σᵢ σᵢ / (σᵢ² + λᵢ²) · vᵢ uᵢᵀ x,

with λᵢ = 0 for σᵢ ≥ ε (those directions are followed exactly, as by the pseudo-inverse) and,
for σᵢ < ε, the variable damping of Chiaverini (1997, "Singularity-robust task-priority redundancy
resolution for real-time kinematic control of robot manipulators", IEEE T-RA 13(3), eq. 16;
after Nakamura & Hanafusa 1986):

    λ² = (1 − (σᵢ/ε)²) λ_max².

Only the small singular values are damped ("numerical filtering", Maciejewski & Klein 1988), so
motion along the well-conditioned directions goes on at full speed through a singularity, and the
joint speed the damped directions can ask for is bounded by |uᵢᵀ x| / (2 λ) (at σᵢ = λ). λ is
continuous in σ, so nothing jumps when a singular value crosses ε. Leaving a singularity needs no
special case: the damped solution still moves along vᵢ when uᵢᵀ x points away from it.

The split into an undamped part, a damped part and the exact null space lets the servo scale them
separately under the joint limits (the damped and null-space parts give way first).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dgesdd as _dgesdd

FloatArray = NDArray[np.float64]


class DLSSolution(NamedTuple):
    """Joint velocities for one task velocity, split by singular direction (k = min(m, n)).

    Attributes:
        undamped: Σ over σᵢ ≥ ε of vᵢ uᵢᵀ x / σᵢ, (n,).
        damped: Σ over σᵢ < ε of σᵢ/(σᵢ² + λᵢ²) vᵢ uᵢᵀ x, (n,).
        row_basis: (k, n) the right singular vectors vᵢᵀ, an orthonormal basis of J's row space
            when J has full rank: I − row_basisᵀ row_basis projects onto the null space.
        singular_values: σ₁ ≥ … ≥ σ_k, k = min(m, n).
        left: (m, k) the left singular vectors uᵢ.
        gains: (k,) σᵢ / (σᵢ² + λᵢ²): with `left` and `row_basis`, the whole linear map x ↦ q̇
            (see `apply`).
    """

    undamped: FloatArray
    damped: FloatArray
    row_basis: FloatArray
    singular_values: FloatArray
    left: FloatArray
    gains: FloatArray


def apply(solution: DLSSolution, y: FloatArray) -> FloatArray:
    """The same damped inverse applied to another task vector y (m,): Σ gᵢ vᵢ uᵢᵀ y, e.g. the
    task acceleration, whose image is the joint acceleration to feed forward."""
    return solution.row_basis.T.dot(solution.gains * solution.left.T.dot(y))


def variable_damping(sigma: FloatArray, threshold: float, max_damping: float) -> FloatArray:
    """λ² per singular value: (1 − (σ/ε)²) λ_max² where σ < ε, else 0 (Chiaverini 1997)."""
    ratio = sigma / threshold
    return np.where(ratio < 1.0, (1.0 - ratio * ratio) * (max_damping * max_damping), 0.0)


def svd(J: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Thin SVD (U (m, k), σ (k,), Vᵀ (k, n)), k = min(m, n), of a small matrix: LAPACK's dgesdd
    called directly (a few µs on a 6×7 matrix, half the time of `numpy.linalg.svd`'s wrapper),
    numpy's as the fallback."""
    U, s, Vt, info = _dgesdd(J, 1, 0)  # compute_uv, not full_matrices
    if info != 0:
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
    return U, s, Vt


def solve(J: FloatArray, x: FloatArray, threshold: float, max_damping: float) -> DLSSolution:
    """Damped least-squares joint velocities q̇ = undamped + damped for J q̇ ≈ x (see module doc).

    Args:
        J: (m, n) task Jacobian, finite.
        x: (m,) task velocity, in the same row order and units as J.
        threshold: ε; singular values below it are damped.
        max_damping: λ_max, the damping at σ = 0.

    (`A.dot(b)` rather than `A @ b` here: the same BLAS call and the same result, with half the
    call overhead on these small arrays.)
    """
    U, s, Vk = svd(J)
    ux = U.T.dot(x)  # uᵢᵀ x
    if s[-1] >= threshold:  # the common case: nothing to damp
        gains = 1.0 / s
        return DLSSolution(Vk.T.dot(ux * gains), np.zeros(J.shape[1]), Vk, s, U, gains)
    # `variable_damping` on floats (the same arithmetic, without the array calls)
    lam_max2 = max_damping * max_damping
    lam2_list = [
        (1.0 - r * r) * lam_max2 if r < 1.0 else 0.0
        for r in (sigma / threshold for sigma in s.tolist())
    ]
    gains = s / (s * s + np.array(lam2_list))  # σ > 0 where λ = 0, and λ > 0 where σ = 0
    coeff = ux * gains
    # The damped directions (λ > 0) are the last ones: σ decreases, and λ grows as σ does.
    # (Contiguous copies of the rows, as boolean indexing makes, so that the products are the
    # same floats.)
    k = sum(1 for lam2 in lam2_list if not lam2 > 0.0)
    damped = np.ascontiguousarray(Vk[k:]).T.dot(coeff[k:])
    undamped = np.ascontiguousarray(Vk[:k]).T.dot(coeff[:k])
    return DLSSolution(undamped, damped, Vk, s, U, gains)
