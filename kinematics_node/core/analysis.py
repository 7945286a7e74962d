"""Manipulability, conditioning and singularity measures of a Jacobian (..., 6, n), rows (ω, v).

`part` selects rows: "linear" (v, units m/rad or m/m), "angular" (ω), or "full" (all six; mixes
units, so its values depend on the length unit: prefer "linear"/"angular" for thresholds).
All measures come from the singular values σ₁ ≥ … ≥ σ_k of the selected rows (k = min(rows, n)),
`singular_values`; `conditioning` gives the measures the node publishes from one Jacobian;
`translational_ellipsoid` the shape the node's ~/markers and a recording's markers draw, and
`condition_colour` its colour.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
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


def singular_values(J: ArrayLike, part: Part = "full") -> FloatArray:
    """σ₁ ≥ … ≥ σ_k (..., k) of the selected rows of J: the one SVD behind every measure here."""
    return np.asarray(np.linalg.svd(_rows(J, part), compute_uv=False), dtype=np.float64)


def manipulability(J: ArrayLike, part: Part = "full") -> FloatArray:
    """Yoshikawa's measure w = √det(J Jᵀ) = σ₁ σ₂ ⋯ σ_k (MR §5.4; De Luca). Zero at a singularity.

    For a chain with fewer joints than rows (n < rows) the product of the n singular values,
    √det(Jᵀ J), is returned instead, so that the measure is still informative.
    """
    return np.prod(singular_values(J, part), axis=-1)


def manipulability_det(J: ArrayLike) -> FloatArray:
    """`manipulability` of the full J (..., r, n) from a determinant instead of an SVD: |det J|
    when square, √det(J Jᵀ) with more columns than rows, √det(Jᵀ J) with fewer (MR §5.4).

    The same value to round-off relative to σ₁ ⋯ σ_k (the Gram form squares the condition
    number, so near a singularity it is off by about ε σ₁² ⋯ in absolute terms and clamped at 0),
    for a fraction of the cost: a 6 × 6 LU instead of an SVD, which for the batches of a
    reachability map was half its time (docs/performance.md, "Workspace maps").
    """
    Jm = np.asarray(J, dtype=np.float64)
    r, n = Jm.shape[-2:]
    if r == n:
        return np.asarray(np.abs(np.linalg.det(Jm)), dtype=np.float64)
    G = Jm @ Jm.swapaxes(-1, -2) if n > r else Jm.swapaxes(-1, -2) @ Jm
    return np.asarray(np.sqrt(np.maximum(np.linalg.det(G), 0.0)), dtype=np.float64)


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
    return _condition(singular_values(J, part))


def _condition(s: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore"):
        return np.where(
            s[..., -1] > 0, s[..., 0] / np.where(s[..., -1] > 0, s[..., -1], 1.0), np.inf
        )


def is_near_singular(
    J: ArrayLike, part: Part = "full", threshold: float = 1e-3
) -> NDArray[np.bool_]:
    """True where the smallest singular value of the selected rows is below `threshold`."""
    return singular_values(J, part)[..., -1] < threshold


@dataclass(frozen=True)
class Conditioning:
    """How well-conditioned one Jacobian (6, n) is (see `conditioning`).

    Attributes:
        manipulability: Yoshikawa's measure of the linear rows (a volume, [m^k/rad^k] for k
            revolute joints); comparable across arms, unlike the full measure.
        condition_number: σ_max / σ_min of all six rows (∞ at a singularity; mixes rad and m).
        min_singular_value: σ_min of all six rows.
        near_singular: σ_min below the threshold.
    """

    manipulability: float
    condition_number: float
    min_singular_value: float
    near_singular: bool


def conditioning(J: ArrayLike, singular_threshold: float = 1e-3) -> Conditioning:
    """`Conditioning` of one Jacobian (6, n), rows (ω, v): the linear rows' manipulability and
    the full matrix's condition number and smallest singular value, from two SVDs."""
    s = singular_values(J, "full")
    return Conditioning(
        manipulability=float(np.prod(singular_values(J, "linear"), axis=-1)),
        condition_number=float(_condition(s)),
        min_singular_value=float(s[..., -1]),
        near_singular=bool(s[..., -1] < singular_threshold),
    )


#: Condition number at which `condition_colour` reaches red: the recordings' report calls the arm
#: near a singularity above it (`kinematics bag --singular-condition`'s default).
RED_CONDITION = 100.0


@dataclass(frozen=True)
class Ellipsoid:
    """The translational manipulability ellipsoid {J_v q̇ : ‖q̇‖ ≤ 1} at the tool (MR §5.4), as a
    pose and three semi-axes (see `translational_ellipsoid`).

    Attributes:
        centre: the tool origin in the base (3,) [m].
        rotation: (3, 3), a proper rotation (det +1): its columns are the principal axes, the
            left singular vectors of J_v in decreasing order of σ (the last one's sign flipped
            where numpy's U has det −1).
        semi_axes: σ₁ ≥ σ₂ ≥ σ₃ (3,) [m/rad for revolute joints]; 0 where J_v has fewer than 3
            singular values (fewer than 3 joints).
        condition_number: σ₁ / σ₃ (∞ where σ₃ = 0).
    """

    centre: FloatArray
    rotation: FloatArray
    semi_axes: FloatArray
    condition_number: float

    @property
    def weakest(self) -> FloatArray:
        """The most singular direction: the unit axis of the smallest σ (its sign is arbitrary)."""
        return self.rotation[:, 2]


def translational_ellipsoid(J: ArrayLike, centre: ArrayLike) -> Ellipsoid:
    """`Ellipsoid` of the linear rows J_v of one world Jacobian (6, n), rows (ω, v), placed at
    `centre` (3,), the tip origin in the base. One SVD: J_v = U Σ Vᵀ; axes U, lengths σ.

    Raises:
        ValueError: J is not (6, n), centre not (3,), or either is not finite.
    """
    Jm = np.asarray(J, dtype=np.float64)
    p = np.asarray(centre, dtype=np.float64)
    if Jm.ndim != 2 or Jm.shape[0] != 6 or p.shape != (3,):
        raise ValueError(f"expected J (6, n) and centre (3,), got {Jm.shape} and {p.shape}")
    if not (np.isfinite(Jm).all() and np.isfinite(p).all()):
        raise ValueError("the Jacobian and the centre must be finite")
    U, s, _ = np.linalg.svd(Jm[3:], full_matrices=True)
    axes = np.zeros(3)
    axes[: s.size] = s
    if np.linalg.det(U) < 0:
        U = U.copy()
        U[:, 2] = -U[:, 2]
    return Ellipsoid(p.copy(), U, axes, float(_condition(axes)))


def condition_colour(condition: float, red_at: float = RED_CONDITION) -> tuple[float, float, float]:
    """(r, g, b) in [0, 1] for a condition number: green at 1, yellow halfway, red from `red_at`
    on (∞ included), on a log scale: t = ln κ / ln red_at, r = min(1, 2t), g = min(1, 2 − 2t).
    r never falls and g never rises as κ grows.

    Raises:
        ValueError: `red_at` ≤ 1, or `condition` NaN or below 1.
    """
    if not red_at > 1.0:
        raise ValueError(f"red_at must be > 1, got {red_at}")
    if not condition >= 1.0:  # NaN too
        raise ValueError(f"a condition number is >= 1, got {condition}")
    t = 1.0 if condition >= red_at else math.log(condition) / math.log(red_at)
    return min(1.0, 2.0 * t), min(1.0, 2.0 - 2.0 * t), 0.0
