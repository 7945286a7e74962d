"""Inverse kinematics: damped least squares (Levenberg–Marquardt) with random restarts.

Problem: find joint values q within the limits such that T_base_tip(q) = T_target.

Error (tip-frame, "body" formulation, Modern Robotics §6.2.2). With T_err = T(q)⁻¹ T_target:

* full pose, every weight > 0: the body error twist V_b = log(T_err) = (ω̂θ, vθ) ∈ R⁶ (MR eq.
  6.7's log), driven to zero with the body Jacobian J_b (MR eq. 5.18), J_b Δq = V_b (MR §6.2.2);
* position only, or some orientation weight is 0: the decoupled tip-frame error
  e = (log(R_err), p_err) with p_err = R(q)ᵀ(p_target − p(q)). Its exact derivative is the body
  Jacobian taken at the *target point* rigidly attached to the tip, J_v + J_ω × p_err, so a zero
  weight on a rotation component really leaves that rotation free (V_b's v part would couple it).

Step (Levenberg–Marquardt on the weighted residual r = W^½ e, J_w = W^½ J):
    Δq = J_wᵀ (J_w J_wᵀ + λ I)⁻¹ r,
which equals (J_wᵀ J_w + λ I)⁻¹ J_wᵀ r but needs only an m×m solve (m = 6, or 3 position-only).
The trial q + Δq is moved into the joint limits: a revolute joint by whole turns when q ± 2πk
fits (the pose is the same, so e.g. an elbow limited to [−π, π] may cross ±π), otherwise clamped;
joints at a limit that the step pushes outwards are frozen and the step recomputed. The trial is
accepted if it lowers ‖r‖² (λ then shrinks by Nielsen's rule), otherwise rejected (λ grows by a
doubling factor). Non-finite trials are rejected. An attempt ends on convergence, after
`max_iterations`, when λ exceeds 1e6, after two accepted steps in a row that each lower ‖r‖² by
less than 5 % (stuck: a local minimum or a limit), or after two accepted steps in a row with more
joints pinned at a limit than the arm has spare degrees of freedom, max(n − m, 0) (the free joints
can no longer span the task). The next attempt starts from a configuration drawn uniformly within
the limits (continuous joints: seed ± π). This repeats until success, `timeout` or `max_restarts`.

Every returned revolute value is the whole-turn equivalent within the limits that is closest to
the seed (continuous joints: within π of the seed).

Units: lengths [m], angles [rad], time [s]. Errors and weights are ordered (ω, v) and expressed in
the tip frame.

Thread safety: every call owns its state (a fresh `numpy.random.Generator` seeded from
`rng_seed`); the chain is immutable and nothing at module level is mutated, so calls can run
concurrently from many threads. For a given `rng_seed` the sequence of attempts is deterministic;
the result is reproducible whenever the search ends by success or `max_restarts`, not by timeout
("distance" mode normally ends by timeout, so set `max_restarts` to make it reproducible).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._ik_batch import BatchOutcome, BatchSolver
from ._ik_problem import IKProblem
from ._ik_single import SingleSolver
from .exceptions import InvalidInputError
from .ik_options import IKOptions
from .model import KinematicChain, middle_of_limits, readonly

FloatArray = NDArray[np.float64]
# Below this many targets `ik_batch` solves them one by one with the scalar solver: the lock-step
# NumPy iteration costs ~1 ms whatever the batch size, so it only pays off for larger batches
# (measured on Panda and UR5: 1.4 vs 0.44 ms per target at N = 10, about even at N = 50–64,
# 0.2 vs 0.5 ms at N = 200).
SCALAR_BATCH_BELOW = 48


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
    q = chain.check_q(q_seed, name)
    want = (chain.dof,) if batch is None else (batch, chain.dof)
    if q.shape != want:
        raise InvalidInputError(f"{name} must have shape {want}, got shape {q.shape}")
    return np.clip(q, chain.lower, chain.upper)  # a seed outside the limits is clamped


def _options(options: IKOptions | None) -> IKOptions:
    if options is None:
        return IKOptions()
    if not isinstance(options, IKOptions):
        raise InvalidInputError(f"options must be an IKOptions, got {type(options).__name__}")
    return options


# ---------------------------------------------------------------------- public entry points
def solve(
    chain: KinematicChain,
    T_target: ArrayLike,
    q_seed: ArrayLike | None = None,
    options: IKOptions | None = None,
) -> IKResult:
    """Joint values q with T_base_tip(q) = T_target (4×4, tip pose in the base frame).

    Args:
        chain: the robot model.
        T_target: (4, 4) homogeneous transform, finite, rotation in SO(3).
        q_seed: (n,) start and reference for "distance" mode; values outside the limits are
            clamped into them. Default: the middle of the limits (0 for continuous joints).
        options: `IKOptions` (defaults if None).

    Returns:
        `IKResult`; on failure `success` is False and `q` is the best configuration found.

    Raises:
        InvalidInputError: T_target is not a finite rigid transform of shape (4, 4), q_seed has
            the wrong length or a non-finite value, or options do not fit the chain.
    """
    opts = _options(options)
    T = chain.check_target(T_target)
    if T.shape != (4, 4):
        raise InvalidInputError(
            f"T_target must have shape (4, 4) (use ik_batch for many), got {T.shape}"
        )
    seed = check_seed(chain, q_seed, "q_seed", None)
    start = time.perf_counter()
    deadline = start + opts.timeout
    out = SingleSolver(IKProblem.build(chain, opts), T, seed).run(deadline)
    elapsed_ms = (time.perf_counter() - start) * 1e3
    solutions = tuple(readonly(s) for s in out.solutions)
    if out.success:
        n_found = len(solutions)
        msg = f"found {n_found} solution{'s' if n_found > 1 else ''} in {elapsed_ms:.2f} ms"
        if n_found < opts.num_solutions:
            msg += f" ({opts.num_solutions} requested; {out.stop_reason})"
        msg += f", {out.restarts} restarts, {out.iterations} iterations"
    else:
        msg = (
            f"no solution: {out.stop_reason} after {elapsed_ms:.1f} ms, {out.restarts} restarts; "
            f"best residual {out.position_error:.3g} m / {out.orientation_error:.3g} rad "
            f"(tolerances {opts.position_tolerance:g} m / {opts.orientation_tolerance:g} rad)"
        )
    return IKResult(
        q=readonly(out.q),
        success=out.success,
        position_error=out.position_error,
        orientation_error=out.orientation_error,
        iterations=out.iterations,
        restarts=out.restarts,
        solutions=solutions,
        message=msg,
    )


def solve_batch(
    chain: KinematicChain,
    T_targets: ArrayLike,
    q_seeds: ArrayLike | None = None,
    options: IKOptions | None = None,
) -> IKBatchResult:
    """IK for N targets at once, vectorised across targets (NumPy batched FK/Jacobian and solves).

    Same algorithm and options as `solve`, run in lock-step for all unconverged targets; a target
    whose attempt ends without success is restarted (vectorised) from a random configuration.
    Batches of fewer than `SCALAR_BATCH_BELOW` targets are solved one by one with the scalar
    solver instead (faster there; each then gets `options.timeout`, within the batch budget).
    Time budget: `options.batch_timeout` for the whole call if set, else `options.timeout` × N.
    Only mode "speed" with num_solutions = 1 is supported here (use `ik` per target otherwise).

    Args:
        T_targets: (N, 4, 4) rigid transforms. q_seeds: (N, n) or None (middle of the limits).

    Raises:
        InvalidInputError: bad targets, seeds or options (including mode "distance").
    """
    opts = _options(options)
    if opts.mode != "speed" or opts.num_solutions != 1:
        raise InvalidInputError(
            "ik_batch supports mode='speed' with num_solutions=1 only; "
            f"got mode={opts.mode!r}, num_solutions={opts.num_solutions} (call ik per target)"
        )
    T = chain.check_target(T_targets, "T_targets")
    if T.ndim != 3:
        raise InvalidInputError(f"T_targets must have shape (N, 4, 4), got {T.shape}")
    N = T.shape[0]
    seeds = check_seed(chain, q_seeds, "q_seeds", N)
    start = time.perf_counter()
    budget = opts.batch_timeout if opts.batch_timeout is not None else opts.timeout * max(N, 1)
    problem = IKProblem.build(chain, opts)
    if N < SCALAR_BATCH_BELOW:
        out = _solve_each(problem, T, seeds, start + budget)
    else:
        out = BatchSolver(problem, T, seeds).run(start + budget)
    elapsed_ms = (time.perf_counter() - start) * 1e3
    n_ok = int(out.success.sum())
    msg = f"{n_ok}/{N} targets solved in {elapsed_ms:.1f} ms"
    if n_ok < N:
        msg += f" ({out.stop_reason})"
    return IKBatchResult(
        q=readonly(out.q),
        success=readonly(out.success, np.bool_),
        position_error=readonly(out.position_error),
        orientation_error=readonly(out.orientation_error),
        iterations=readonly(out.iterations, np.int64),
        restarts=readonly(out.restarts, np.int64),
        message=msg,
    )


def _solve_each(
    problem: IKProblem, T: FloatArray, seeds: FloatArray, deadline: float
) -> BatchOutcome:
    """Small batches: the scalar solver per target, each with `opts.timeout` but never past the
    batch's deadline. Results equal those of `ik` on each target whenever neither budget binds."""
    outs = []
    for T_k, seed_k in zip(T, seeds, strict=True):
        own = min(time.perf_counter() + problem.opts.timeout, deadline)
        outs.append(SingleSolver(problem, T_k, seed_k).run(own))
    failed = [o.stop_reason for o in outs if not o.success]
    return BatchOutcome(
        q=np.array([o.q for o in outs]).reshape(len(outs), len(problem.lower)),
        success=np.array([o.success for o in outs], dtype=bool),
        position_error=np.array([o.position_error for o in outs], dtype=np.float64),
        orientation_error=np.array([o.orientation_error for o in outs], dtype=np.float64),
        iterations=np.array([o.iterations for o in outs], dtype=np.int64),
        restarts=np.array([o.restarts for o in outs], dtype=np.int64),
        stop_reason=failed[0] if failed else "done",
    )


__all__: Sequence[str] = [
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "check_seed",
    "default_seed",
    "solve",
    "solve_batch",
]
