"""Which twist components the servo follows: all six, or a chosen few for arms with fewer joints.

A SCARA (4 joints) can move its tool in x, y, z and turn it about z, but never tilt it; a planar
3R arm moves in x, y and turns about z. The servo follows the components `ServoConfig.task_axes`
names, in the base's or the tip's axes, and drops the others (its status lists them). Left to
None, the choice is made from the arm itself: the components its Jacobian can produce at all.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..chain import SerialChain
from ..exceptions import InvalidInputError
from .config import TWIST_AXES, ServoConfig

_PROBES = 8  # random configurations on which a Jacobian row must be zero to count as unreachable


def task_jacobian_rows(
    J_world: NDArray[np.float64], R: NDArray[np.float64], frame: str
) -> NDArray[np.float64]:
    """The (6, n) Jacobian, rows (ω, v) of the tip origin, in base axes or, for frame "tip", in the
    tip's axes: diag(Rᵀ, Rᵀ) J (R = orientation of the tip in the base)."""
    if frame == "base":
        return J_world
    Rt = R.T
    return np.concatenate((Rt @ J_world[:3], Rt @ J_world[3:]))


def select_axes(chain: SerialChain, config: ServoConfig) -> tuple[tuple[int, ...], tuple[str, ...]]:
    """(row indices followed, names of the dropped components) for `chain` under `config`.

    Raises:
        InvalidInputError: more components to follow than the arm has joints, or (task_axes None)
            an arm with fewer than six joints that can move more components than it has joints
            (e.g. a 5R arm): it cannot follow them all, and the servo cannot guess which to drop.
    """
    n = chain.dof
    if config.task_axes is not None:
        rows = tuple(sorted(TWIST_AXES.index(a) for a in config.task_axes))
        if len(rows) > n:
            raise InvalidInputError(
                f"ServoConfig.task_axes names {len(rows)} components but the arm has {n} joints; "
                f"name at most {n}"
            )
    elif n >= 6:
        rows = tuple(range(6))
    else:
        rng = np.random.default_rng(0)
        lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
        hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
        peak = np.zeros(6)
        for q in rng.uniform(lo, hi, size=(_PROBES, n)):
            T, J = chain.fk_jacobian(q, "world")
            Jt = task_jacobian_rows(J, T[:3, :3], config.task_axes_frame)
            peak = np.maximum(peak, np.abs(Jt).max(axis=1))
        rows = tuple(int(i) for i in np.flatnonzero(peak > 1e-9))
        if len(rows) > n:
            names = ", ".join(TWIST_AXES[i] for i in rows)
            raise InvalidInputError(
                f"the arm has {n} joints and can move {len(rows)} twist components ({names}) in "
                f"{config.task_axes_frame} axes; choose at most {n} with ServoConfig.task_axes"
            )
    dropped = tuple(TWIST_AXES[i] for i in range(6) if i not in rows)
    return rows, dropped
