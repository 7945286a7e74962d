"""`IKOptions`: the settings of the IK solvers, validated on construction.

Kept apart from `ik` so that the IK problem (`_ik_problem`), which both solvers build from a
chain and these options, sits below the entry points that use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..exceptions import InvalidInputError

FloatArray = NDArray[np.float64]
Mode = Literal["speed", "distance"]
_MODES = ("speed", "distance")
Method = Literal["auto", "closed_form", "numeric"]
_METHODS = ("auto", "closed_form", "numeric")


def _is_real(x: object) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _is_int(x: object) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


@dataclass(frozen=True)
class IKOptions:
    """Settings of the IK solver (immutable; validated on construction).

    Attributes:
        position_tolerance: success threshold on ‖p_target − p(q)‖ [m], > 0.
        orientation_tolerance: success threshold on the rotation angle of R(q)ᵀ R_target [rad], > 0.
        timeout: time budget of one `ik` call [s], > 0; the call returns within about a
            millisecond of it. For `ik_batch` see `batch_timeout`.
        max_restarts: random restarts allowed after the first attempt (int ≥ 0). The default
            (100 000) leaves the timeout to end a search that does not succeed: one attempt
            takes about 0.5 ms on a 6–7 joint arm.
        max_iterations: Levenberg–Marquardt iterations per attempt (int ≥ 1).
        mode: "speed" returns the first solution; "distance" keeps restarting until the time
            budget (or `max_restarts`) is used up and returns the solution closest to the seed.
            (A 6R arm's closed form ranks its whole solution set, so it returns the nearest at
            once in both modes.)
        num_solutions: number of distinct solutions to collect (int ≥ 1), returned in
            `IKResult.solutions` sorted by distance to the seed.
        position_only: ignore the orientation of the target (only the position must match).
        weights: None, or 6 non-negative floats in (ω, v) order, tip-frame axes, multiplying the
            squared error components in the least-squares cost; a zero weight frees that component
            (it is then also excluded from the success test). At least one must be positive.
        axis_tolerances: None, or 6 bounds > 0 in (ω, v) order, tip-frame axes (inf allowed), on
            the components of the error e = (log(R(q)ᵀ R_target), R(q)ᵀ(p_target − p(q))), as
            TRAC-IK's per-axis bounds: success means |eᵢ| ≤ axis_tolerances[i] for every i (the
            two scalar tolerances are then not used), and a component already within its bound
            does not pull on the solver, so e.g. (1e-4, 1e-4, inf, 1e-5, 1e-5, 1e-5) leaves the
            rotation about the tool's z axis free. Not combined with `position_only` (give inf
            for the three ω bounds instead).
        joint_weights: None, or one non-negative float per joint for the joint-space distance
            d(q, q_seed)² = Σ wⱼ (qⱼ − q_seedⱼ)² used by "distance" mode and to sort solutions.
        solution_separation: two solutions are distinct when some joint differs by more than this
            [rad or m] (continuous joints compared modulo 2π); > 0.
        batch_timeout: time budget of a whole `ik_batch` call [s]; None means `timeout` × N.
        rng_seed: seed of the random restarts (None: fresh entropy each call).
        method: "auto" (default) uses the closed form (docs/closed_form.md) where the chain has a
            family and the whole pose is asked for (no position_only, no freed component), and the
            numeric search otherwise or when the closed form finds nothing; "closed_form" uses
            only the closed form (an error where it does not apply); "numeric" only the
            Levenberg–Marquardt search.
    """

    position_tolerance: float = 1e-5
    orientation_tolerance: float = 1e-4
    timeout: float = 0.05
    max_restarts: int = 100_000
    max_iterations: int = 60
    mode: Mode = "speed"
    num_solutions: int = 1
    position_only: bool = False
    weights: tuple[float, ...] | None = None
    axis_tolerances: tuple[float, ...] | None = None
    joint_weights: tuple[float, ...] | None = None
    solution_separation: float = 1e-2
    batch_timeout: float | None = None
    rng_seed: int | None = None
    method: Method = "auto"

    def __post_init__(self) -> None:
        for name in (
            "position_tolerance",
            "orientation_tolerance",
            "timeout",
            "solution_separation",
        ):
            value = getattr(self, name)
            if not _is_real(value) or not math.isfinite(value) or value <= 0:
                raise InvalidInputError(
                    f"IKOptions.{name} must be a finite number > 0, got {value!r}"
                )
        if self.batch_timeout is not None and (
            not _is_real(self.batch_timeout)
            or not math.isfinite(self.batch_timeout)
            or self.batch_timeout <= 0
        ):
            raise InvalidInputError(
                f"IKOptions.batch_timeout must be None or a finite number > 0 [s], "
                f"got {self.batch_timeout!r}"
            )
        if not _is_int(self.max_restarts) or self.max_restarts < 0:
            raise InvalidInputError(
                f"IKOptions.max_restarts must be an int ≥ 0, got {self.max_restarts!r}"
            )
        if not _is_int(self.max_iterations) or self.max_iterations < 1:
            raise InvalidInputError(
                f"IKOptions.max_iterations must be an int ≥ 1, got {self.max_iterations!r}"
            )
        if not _is_int(self.num_solutions) or self.num_solutions < 1:
            raise InvalidInputError(
                f"IKOptions.num_solutions must be an int ≥ 1, got {self.num_solutions!r}"
            )
        if self.method not in _METHODS:
            raise InvalidInputError(
                f"IKOptions.method must be one of {_METHODS}, got {self.method!r}"
            )
        if self.mode not in _MODES:
            raise InvalidInputError(f"IKOptions.mode must be one of {_MODES}, got {self.mode!r}")
        if not isinstance(self.position_only, (bool, np.bool_)):
            raise InvalidInputError(
                f"IKOptions.position_only must be a bool, got {self.position_only!r}"
            )
        if self.rng_seed is not None and (not _is_int(self.rng_seed) or self.rng_seed < 0):
            raise InvalidInputError(
                f"IKOptions.rng_seed must be None or an int ≥ 0, got {self.rng_seed!r}"
            )
        if self.weights is not None:
            w = _weights_tuple(self.weights, "weights")
            if len(w) != 6:
                raise InvalidInputError(
                    "IKOptions.weights must have 6 values ordered (ωx, ωy, ωz, vx, vy, vz), "
                    f"got {len(w)}"
                )
            active = w[3:] if self.position_only else w
            if not any(x > 0 for x in active):
                raise InvalidInputError(
                    f"IKOptions.weights must have at least one positive "
                    f"{'position ' if self.position_only else ''}weight, got {w}"
                )
            object.__setattr__(self, "weights", w)
        if self.axis_tolerances is not None:
            object.__setattr__(self, "axis_tolerances", _axis_tolerances(self))
        if self.joint_weights is not None:
            object.__setattr__(
                self, "joint_weights", _weights_tuple(self.joint_weights, "joint_weights")
            )


def _float_array(values: object, name: str, expected: str) -> FloatArray:
    """`values` as a float array, or an InvalidInputError saying what IKOptions.`name` must be."""
    try:
        return np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"IKOptions.{name} must be {expected}, got {values!r}") from None


def _weights_tuple(values: object, name: str) -> tuple[float, ...]:
    arr = _float_array(values, name, "a sequence of numbers")
    if arr.ndim != 1:
        raise InvalidInputError(f"IKOptions.{name} must be a flat sequence, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InvalidInputError(f"IKOptions.{name} must be finite and ≥ 0, got {arr.tolist()}")
    return tuple(float(x) for x in arr)


def _axis_tolerances(opts: IKOptions) -> tuple[float, ...]:
    arr = _float_array(opts.axis_tolerances, "axis_tolerances", "6 numbers")
    if arr.shape != (6,):
        raise InvalidInputError(
            "IKOptions.axis_tolerances must have 6 values ordered (ωx, ωy, ωz, vx, vy, vz) "
            f"[rad, m], got shape {arr.shape}"
        )
    if np.any(np.isnan(arr)) or np.any(arr <= 0):
        raise InvalidInputError(
            f"IKOptions.axis_tolerances must be > 0 (inf frees an axis), got {arr.tolist()}"
        )
    if np.all(np.isinf(arr)):
        raise InvalidInputError("IKOptions.axis_tolerances must bound at least one axis")
    if opts.position_only:
        raise InvalidInputError(
            "IKOptions.axis_tolerances and position_only cannot be combined: "
            "give inf for the three ω bounds instead"
        )
    return tuple(float(x) for x in arr)
