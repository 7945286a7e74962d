"""What an IK call returns, and the seed rules shared by every IK solver (numeric and closed form).

Kept apart from `ik` so that the closed form (`closed_form`) and the numeric search (`ik`) can both
use them while `ik` calls the closed form: no import circle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..exceptions import InvalidInputError
from ..model import KinematicChain, middle_of_limits

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class IKResult:
    """Outcome of one `SerialChain.ik` call. Arrays are read-only.

    Attributes:
        q: (n,) the solution; on failure the best configuration found (smallest weighted
            residual). Always finite and within the limits.
        success: whether `q` meets both tolerances (or every per-axis bound, if given).
        position_error: ‖p_target − p(q)‖ [m]; components freed by a zero weight or an infinite
            axis tolerance are excluded.
        orientation_error: rotation angle of R(q)ᵀ R_target [rad] (0 when position_only); if a
            rotation component is freed, the norm of the remaining rotation-vector components.
        iterations: Levenberg–Marquardt iterations over all attempts.
        restarts: random restarts used (attempts − 1).
        solutions: distinct solutions found, closest to the seed first (q is solutions[0] on
            success); empty on failure.
        message: human-readable summary, e.g. why the search failed.
    """

    q: FloatArray
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    restarts: int = 0
    solutions: tuple[FloatArray, ...] = field(default=())
    message: str = ""


@dataclass(frozen=True)
class IKBatchResult:
    """Outcome of `SerialChain.ik_batch` for N targets: `IKResult`'s fields with a leading N axis.

    Attributes:
        q: (N, n) solutions, or best configurations where success is False.
        success: (N,) bool.
        position_error: (N,) [m]. orientation_error: (N,) [rad].
        iterations: (N,) LM iterations spent on each target. restarts: (N,) restarts per target.
        message: one summary line for the batch.
    """

    q: FloatArray
    success: NDArray[np.bool_]
    position_error: FloatArray
    orientation_error: FloatArray
    iterations: NDArray[np.int64]
    restarts: NDArray[np.int64]
    message: str = ""


# ---------------------------------------------------------------------- boundary helpers
def default_seed(chain: KinematicChain) -> FloatArray:
    """Middle of the joint limits; 0 for continuous joints (clipped into half-bounded limits)."""
    return middle_of_limits(chain.lower, chain.upper)


def check_seed(
    chain: KinematicChain, q_seed: ArrayLike | None, name: str, batch: int | None
) -> FloatArray:
    """The seed rules of `ik` (and `ik_all`): `default_seed` when None, else validated as shape
    (n,) or, for a `batch` of N, (N, n), and clamped into the limits.

    Raises:
        InvalidInputError: wrong shape or a non-finite value, naming `name`.
    """
    if q_seed is None:
        s = default_seed(chain)
        return s if batch is None else np.tile(s, (batch, 1))
    if (
        batch is None
        and isinstance(q_seed, np.ndarray)
        and q_seed.dtype == np.float64
        and q_seed.shape == (chain.dof,)
        and _finite_within(q_seed.tolist(), chain.lower.tolist(), chain.upper.tolist())
    ):
        return q_seed.copy()  # the common case, checked on floats (~1 µs instead of ~6)
    q = chain.check_q(q_seed, name)
    want = (chain.dof,) if batch is None else (batch, chain.dof)
    if q.shape != want:
        raise InvalidInputError(f"{name} must have shape {want}, got shape {q.shape}")
    return np.clip(q, chain.lower, chain.upper)  # a seed outside the limits is clamped


def _finite_within(q: list[float], lower: list[float], upper: list[float]) -> bool:
    """Every value finite and within its limits (then clamping changes nothing)."""
    for x, a, b in zip(q, lower, upper, strict=True):
        if not (a <= x <= b and -math.inf < x < math.inf):
            return False
    return True


__all__: Sequence[str] = ["IKBatchResult", "IKResult", "check_seed", "default_seed"]
