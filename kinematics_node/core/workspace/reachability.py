"""Which poses a chain reaches within its limits: the numbers of one chunk of a workspace map.

For voxel centres c (M, 3) and tool orientations R (K, 3, 3), every target [R_k, c_m] is solved:

* in closed form where the chain has a family (`ik.closed_form.branches_within_limits`): every
  branch of every target, batched, each branch counted once however many whole-turn equivalents
  it has within the limits (a map asks whether and how well, not for every equivalent), each one
  checked by forward kinematics to `tolerance`. A 7R arm's held joint is swept over `held`
  values (default 36 across its limits): a target counts as reachable when some branch at some
  held value reaches it, so the map can only miss poses reachable between those values.
* by the numeric batch IK elsewhere (`SerialChain.ik_batch`, Levenberg–Marquardt): one solution
  per target, `restarts` random restarts drawn from `seed` and no time budget, so the same chunk
  gives the same answer in any process.

Per target: whether it is reached, the number of distinct solutions found, and the best
manipulability among them (Yoshikawa's √det(J Jᵀ), for a 6-joint arm |det J|: the same in every
frame, as det Ad = 1, so it is taken of the space Jacobian, from a determinant rather than an SVD:
`analysis.manipulability_det`) with that solution. Per voxel, Reuleaux's reachability index
D = 100 · reached / K, the best manipulability and the number of solutions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..analysis import manipulability_det
from ..exceptions import InvalidInputError
from ..ik.closed_form import branches_within_limits
from ..ik.options import IKOptions

if TYPE_CHECKING:
    from ..chain import SerialChain

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Targets solved per pass: the closed form's working arrays and the Jacobians of their solutions
#: stay at a few MB.
TARGETS_PER_PASS = 4096


@dataclass(frozen=True)
class VoxelReach:
    """What a chain reaches at M voxel centres in K orientations.

    Attributes:
        reached: (M, K) the target [R_k, c_m] has a solution within the limits.
        solutions: (M, K) distinct solutions found (closed form: branches; numeric: 0 or 1).
        manipulability: (M, K) the best manipulability among them (0 where none).
        q: (M, K, n) the solution with that manipulability (NaN where none).
        method: "closed_form" or "numeric".
    """

    reached: BoolArray
    solutions: IntArray
    manipulability: FloatArray
    q: FloatArray
    method: str

    @property
    def index(self) -> FloatArray:
        """(M,) the reachability index D = 100 · reached orientations / K (Reuleaux's)."""
        K = self.reached.shape[1]
        return 100.0 * self.reached.sum(axis=1) / K

    @property
    def best_manipulability(self) -> FloatArray:
        """(M,) the best manipulability of each voxel (0 where nothing is reached)."""
        return self.manipulability.max(axis=1, initial=0.0)

    @property
    def solution_count(self) -> IntArray:
        """(M,) solutions found over every orientation of each voxel."""
        return self.solutions.sum(axis=1)


def targets(centres: ArrayLike, rotations: ArrayLike) -> FloatArray:
    """(M·K, 4, 4) tool poses [R_k, c_m], voxel-major."""
    c = np.asarray(centres, dtype=np.float64)
    R = np.asarray(rotations, dtype=np.float64)
    M, K = c.shape[0], R.shape[0]
    T = np.zeros((M, K, 4, 4))
    T[:, :, :3, :3] = R[None]
    T[:, :, :3, 3] = c[:, None, :]
    T[:, :, 3, 3] = 1.0
    return T.reshape(M * K, 4, 4)


def reach_voxels(
    chain: SerialChain,
    centres: ArrayLike,
    rotations: ArrayLike,
    *,
    tolerance: float = 1e-9,
    method: str = "auto",
    held: ArrayLike | None = None,
    restarts: int = 20,
    seed: int = 0,
) -> VoxelReach:
    """Reach of `chain` at voxel `centres` (M, 3) [m, base frame] in `rotations` (K, 3, 3).

    Args:
        tolerance: a solution must reproduce its target by FK to this [m, rad].
        method: "auto" (closed form where the chain has a family, else numeric),
            "closed_form" or "numeric".
        held: a 7R arm's held-joint values [rad] for the closed form (see module docstring).
        restarts, seed: the numeric IK's random restarts per target and their generator's seed.

    Raises:
        InvalidInputError: shapes, non-finite values, an unknown method.
        NoClosedFormError: method "closed_form" for a chain without a closed-form family.
    """
    c = np.asarray(centres, dtype=np.float64)
    R = np.asarray(rotations, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 3 or not np.all(np.isfinite(c)):
        raise InvalidInputError(f"centres must be finite (M, 3) positions, got shape {c.shape}")
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise InvalidInputError(f"rotations must have shape (K, 3, 3), got {R.shape}")
    M, K, n = c.shape[0], R.shape[0], chain.dof
    reach = reach_targets(
        chain,
        targets(c, R),
        tolerance=tolerance,
        method=method,
        held=held,
        restarts=restarts,
        seed=seed,
    )
    return VoxelReach(
        reach.reached.reshape(M, K),
        reach.solutions.reshape(M, K),
        reach.manipulability.reshape(M, K),
        reach.q.reshape(M, K, n),
        reach.method,
    )


def reach_targets(
    chain: SerialChain,
    T: FloatArray,
    *,
    tolerance: float = 1e-9,
    method: str = "auto",
    held: ArrayLike | None = None,
    restarts: int = 20,
    seed: int = 0,
) -> VoxelReach:
    """`reach_voxels` of any N tool poses T (N, 4, 4) in the base frame, as one row of N:
    `reached`, `solutions`, `manipulability` (1, N) and `q` (1, N, n). The numeric IK's pass
    starting at target i is seeded with `seed` + i.

    Raises:
        InvalidInputError: an unknown method (and as `branches_within_limits` / `ik_batch`).
    """
    if method not in ("auto", "closed_form", "numeric"):
        raise InvalidInputError(
            f"method must be 'auto', 'closed_form' or 'numeric', got {method!r}"
        )
    if method == "auto":
        method = "closed_form" if chain.ik_family is not None else "numeric"
    N, n = len(T), chain.dof
    reached = np.zeros(N, dtype=bool)
    count = np.zeros(N, dtype=np.int64)
    best = np.zeros(N)
    q = np.full((N, n), np.nan)
    for start in range(0, N, TARGETS_PER_PASS):
        part = slice(start, min(start + TARGETS_PER_PASS, N))
        if method == "closed_form":
            Q, owner = _closed_form(chain, T[part], held, tolerance)
        else:
            Q, owner = _numeric(chain, T[part], tolerance, restarts, seed + start)
        if not owner.size:
            continue
        w = manipulability_det(chain.jacobian(Q, "space"))  # the same in every frame
        owner = owner + start
        np.add.at(count, owner, 1)
        # the best solution of each target: sort by (target, w) and take each target's last
        order = np.lexsort((w, owner))
        last = order[np.r_[owner[order][1:] != owner[order][:-1], True]]
        t = owner[last]
        reached[t], best[t], q[t] = True, w[last], Q[last]
    return VoxelReach(reached[None], count[None], best[None], q[None], method)


def _closed_form(
    chain: SerialChain, T: FloatArray, held: ArrayLike | None, tolerance: float
) -> tuple[FloatArray, IntArray]:
    b = branches_within_limits(chain, T, held, tolerance)
    return b.q, b.target


def _numeric(
    chain: SerialChain, T: FloatArray, tolerance: float, restarts: int, seed: int
) -> tuple[FloatArray, IntArray]:
    options = IKOptions(
        position_tolerance=tolerance,
        orientation_tolerance=tolerance,
        timeout=3600.0,
        max_restarts=restarts,
        rng_seed=seed,
        method="numeric",
    )
    result = chain.ik_batch(T, options=options)
    ok = np.flatnonzero(result.success)
    return np.asarray(result.q)[ok], ok.astype(np.int64)
