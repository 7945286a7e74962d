"""Manipulability, conditioning and singularity measures of a Jacobian (..., 6, n), rows (ω, v).

`part` selects rows: "linear" (v, units m/rad or m/m), "angular" (ω), or "full" (all six; mixes
units, so its values depend on the length unit: prefer "linear"/"angular" for thresholds).
All measures come from the singular values σ₁ ≥ … ≥ σ_k of the selected rows (k = min(rows, n)).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
Part = Literal["full", "linear", "angular"]


def _rows(J: ArrayLike, part: str) -> FloatArray:
    Jm = np.asarray(J, dtype=np.float64)
    if part == "full":
        return Jm
    if part == "angular":
        return Jm[..., :3, :]
    if part == "linear":
        return Jm[..., 3:, :]
    raise ValueError(f"part must be 'full', 'linear' or 'angular', got {part!r}")


def manipulability(J: ArrayLike, part: Part = "full") -> FloatArray:
    """Yoshikawa's measure w = √det(J Jᵀ) = σ₁ σ₂ ⋯ σ_k (MR §5.4; De Luca). Zero at a singularity.

    For a chain with fewer joints than rows (n < rows) the product of the n singular values,
    √det(Jᵀ J), is returned instead, so that the measure is still informative.
    """
    return np.prod(np.linalg.svd(_rows(J, part), compute_uv=False), axis=-1)


def manipulability_ellipsoid(J: ArrayLike, part: Part = "linear") -> tuple[FloatArray, FloatArray]:
    """Semi-axes of the velocity manipulability ellipsoid {J q̇ : ‖q̇‖ ≤ 1} (MR §5.4).

    Returns:
        (lengths, directions): lengths σ_i (..., k) in decreasing order, and the unit axis
        directions as the columns of (..., rows, k).
    """
    U, s, _ = np.linalg.svd(_rows(J, part), full_matrices=False)
    return s, U


def condition_number(J: ArrayLike, part: Part = "full") -> FloatArray:
    """σ_max / σ_min of the selected rows (MR's μ₂ = √μ₃); ∞ at a singularity."""
    s = np.linalg.svd(_rows(J, part), compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(
            s[..., -1] > 0, s[..., 0] / np.where(s[..., -1] > 0, s[..., -1], 1.0), np.inf
        )


def is_near_singular(
    J: ArrayLike, part: Part = "full", threshold: float = 1e-3
) -> NDArray[np.bool_]:
    """True where the smallest singular value of the selected rows is below `threshold`."""
    s = np.linalg.svd(_rows(J, part), compute_uv=False)
    return s[..., -1] < threshold
