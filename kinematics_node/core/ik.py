"""Inverse kinematics (filled in by the IK work; types first so the API is importable)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class IKOptions:
    position_tolerance: float = 1e-5
    orientation_tolerance: float = 1e-4
    timeout: float = 0.005


@dataclass(frozen=True)
class IKResult:
    q: NDArray[np.float64]
    success: bool
    position_error: float
    orientation_error: float
    iterations: int


@dataclass(frozen=True)
class IKBatchResult:
    q: NDArray[np.float64]
    success: NDArray[np.bool_]
    position_error: NDArray[np.float64]
    orientation_error: NDArray[np.float64]
    iterations: NDArray[np.int64]


def solve(chain, T_target, q_seed=None, options=None):  # type: ignore[no-untyped-def]
    raise NotImplementedError("IK is not implemented yet")


def solve_batch(chain, T_targets, q_seeds=None, options=None):  # type: ignore[no-untyped-def]
    raise NotImplementedError("IK is not implemented yet")
