"""Entry points of the closed form: every solution (`solve_all`, `solve_all_batch`), the
nearest ones for `ik` / `ik_batch` (`nearest`, `nearest_batch`), and the distinct branches within
the limits for reachability maps (`branches_within_limits`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..._checks import rigid_on_floats
from ...exceptions import InvalidInputError
from ...model import TWO_PI, KinematicChain, readonly
from ..result import check_seed
from .chain_solver import (
    NEAREST_REFINE_ABOVE,
    REFINE_BELOW,
    SOLVE_CHUNK,
    ChainSolver,
    fk_check,
    fk_errors,
    general_solutions,
    refine_until,
    scalar_candidates,
    solve_arrays,
    solve_branches,
    solve_single,
)
from .detection import require_solver, solver_of
from .geometry import INV_TWO_PI, BoolArray, FloatArray, IntArray, Stages, pose_errors_list
from .held import DEFAULT_HELD_SAMPLES, held_order_one, held_values_of
from .solution_set import (
    ClosedFormBatchResult,
    ClosedFormResult,
    duplicate_branches,
    empty_reason,
    rank_array,
    rank_candidates,
)


def _orthonormal(T: FloatArray) -> FloatArray:
    """Targets with their rotation projected onto SO(3) (R = U Vᵀ of its SVD) when it is off by
    more than round-off; check_transform accepts ‖RᵀR − I‖ up to 1e-6."""
    R = T[:, :3, :3]
    err = np.abs(R.swapaxes(1, 2) @ R - np.eye(3)).max()
    if err <= 1e-13:
        return T
    U, _, Vt = np.linalg.svd(R)
    out = T.copy()
    out[:, :3, :3] = U @ Vt
    return out


def _exact_transform(T: object) -> list[list[float]] | None:
    """T as nested lists if it is a float (4, 4) array with a last row (0, 0, 0, 1), finite, and a
    rotation orthonormal to round-off (‖RᵀR − I‖ ≤ 1e-13, det R > 0); else None, and the caller
    runs the full `check_transform` (which explains what is wrong) and projects R onto SO(3)."""
    if not isinstance(T, np.ndarray) or T.shape != (4, 4) or T.dtype != np.float64:
        return None
    Tl: list[list[float]] = T.tolist()
    return Tl if rigid_on_floats(Tl, 1e-13, 0.0) else None


def _check_tolerance(tolerance: float) -> float:
    if not isinstance(tolerance, (int, float)) or not (0 < tolerance < 1e-2):
        raise InvalidInputError(
            f"tolerance must be a number in (0, 0.01) [m and rad], got {tolerance!r}"
        )
    return float(tolerance)


_NO_HELD_VALUES = readonly(np.empty(0))


def solve_all(
    chain: KinematicChain,
    T_target: ArrayLike,
    q_seed: ArrayLike | None = None,
    held: ArrayLike | None = None,
    tolerance: float = 1e-9,
) -> ClosedFormResult:
    """Every joint solution q within the limits with T_base_tip(q) = T_target, in closed form.

    Args:
        chain: a chain with a closed-form family (`family_of(chain)` is not None).
        T_target: (4, 4) tip pose in the base frame.
        q_seed: (n,) reference: solutions are sorted by ‖q − q_seed‖ and an angle that a singular
            target leaves undetermined takes its value from it. Default: the middle of the limits.
        held: 7R arms only: the held joint's value(s) [rad], scalar or (K,); default
            `DEFAULT_HELD_SAMPLES` values spread evenly over its limits.
        tolerance: a solution must reproduce the target to this, in position [m] and rotation
            angle [rad].

    Returns:
        `ClosedFormResult`: `solutions` all solutions, nearest the seed first (empty if none, with
        the reason in `message`); `singular` flags singular targets.

    Raises:
        NoClosedFormError: the chain has no closed-form family (the message says what is missing).
        InvalidInputError: bad target, seed, held values or tolerance.
    """

    solver = require_solver(chain)
    tol = _check_tolerance(tolerance)
    Tl = _exact_transform(T_target)  # fast path for a clean 4×4 array
    if Tl is None:
        T = chain.check_target(T_target)
        if T.shape != (4, 4):
            raise InvalidInputError(
                f"T_target must have shape (4, 4) (use ik_all_batch for many), got {T.shape}"
            )
        Tl = _orthonormal(T[None])[0].tolist()
    if q_seed is None:
        seed, seed_list = solver.default_seed, solver.default_seed_list
    else:
        seed = check_seed(chain, q_seed, "q_seed", None)
        seed_list = seed.tolist()
    held_arr = None if held is None and solver.held is None else held_values_of(solver, held, None)
    family = solver.info
    if solver.held is None:
        sol_arr, (ep, er), singular_why, reason = solve_single(solver, Tl, seed_list, tol)
        held_used = _NO_HELD_VALUES
    else:
        out = solve_arrays(solver, np.array([Tl]), seed[None], held_arr, tol)
        sol_arr, held_used = out.solutions, out.held_values
        singular_why = out.singular_reasons[0] if out.singular[0] else ""
        reason = out.reasons[0]
        ep = er = math.inf
        if sol_arr.shape[0]:
            ep, er = pose_errors_list(chain.fk(sol_arr[0]).tolist(), Tl)
    k = sol_arr.shape[0]
    sol_arr.setflags(write=False)
    if k:
        q = sol_arr[0]  # a read-only view
        msg = f"{k} solution{'s' if k > 1 else ''} ({family.name}), nearest the seed first"
        if held_arr is not None:
            msg += f"; {held_arr.size} value{'s' if held_arr.size > 1 else ''} of {family.held_joint} swept"
        if singular_why:
            msg += (
                f"; singular target: {singular_why} — the undetermined joint values "
                "were taken from the seed"
            )
    else:
        q = readonly(seed)
        ep, er = fk_errors(solver, seed_list, Tl)
        msg = reason
    return ClosedFormResult(
        q=q,
        success=bool(k),
        position_error=float(ep),
        orientation_error=float(er),
        iterations=0,
        restarts=0,
        solutions=tuple(sol_arr),  # rows of a read-only array are read-only views
        message=msg,
        singular=bool(singular_why),
        family=family.name,
        held_values=held_used if held_used is _NO_HELD_VALUES else readonly(held_used),
    )


def solve_all_batch(
    chain: KinematicChain,
    T_targets: ArrayLike,
    q_seeds: ArrayLike | None = None,
    held: ArrayLike | None = None,
    tolerance: float = 1e-9,
) -> ClosedFormBatchResult:
    """`solve_all` for N targets at once, vectorised over targets (and held values).

    Args:
        T_targets: (N, 4, 4) tip poses in the base frame. q_seeds: (N, n) or None (middle of the
            limits). held (7R arms): one value, (K,) values swept for every target, or (N, K)
            values per target [rad]. tolerance: as in `solve_all`.

    Raises:
        NoClosedFormError, InvalidInputError: as `solve_all`.
    """

    solver, T, seeds, held_arr, tol = _batch_inputs(chain, T_targets, q_seeds, held, tolerance)
    N = T.shape[0]
    out = solve_arrays(solver, T, seeds, held_arr, tol)
    success = out.count > 0
    q = seeds.copy()
    q[success] = out.solutions[out.offsets[:-1][success]]
    n_ok = int(success.sum())
    msg = (
        f"{n_ok}/{N} targets solved ({solver.info.name}), {out.solutions.shape[0]} solutions, "
        f"{int(out.singular.sum())} singular"
    )
    return ClosedFormBatchResult(
        q=readonly(q),
        success=readonly(success, np.bool_),
        count=readonly(out.count, np.int64),
        offsets=readonly(out.offsets, np.int64),
        solutions=readonly(out.solutions),
        singular=readonly(out.singular, np.bool_),
        message=msg,
    )


def _batch_inputs(
    chain: KinematicChain,
    T_targets: ArrayLike,
    q_seeds: ArrayLike | None,
    held: ArrayLike | None,
    tolerance: float,
) -> tuple[ChainSolver, FloatArray, FloatArray, FloatArray | None, float]:
    """The checked inputs of a batched call: the chain's solver, the targets (N, 4, 4) with
    orthonormal rotations, the seeds (N, n), the held values and the tolerance.

    Raises:
        NoClosedFormError, InvalidInputError: as `solve_all`.
    """
    solver = require_solver(chain)
    tol = _check_tolerance(tolerance)
    T = chain.check_target(T_targets, "T_targets")
    if T.ndim != 3:
        raise InvalidInputError(f"T_targets must have shape (N, 4, 4), got {T.shape}")
    N = T.shape[0]
    seeds = check_seed(chain, q_seeds, "q_seeds", N)
    return solver, _orthonormal(T), seeds, held_values_of(solver, held, N), tol


@dataclass(frozen=True)
class Nearest:
    """What `ik` takes from the closed form for one target.

    Attributes:
        solutions: configurations (n,) within the limits that reproduce the target to the
            tolerances, nearest the seed first (weighted distance), pairwise more than the
            separation apart; at most the number asked for.
        errors: (position [m], rotation angle [rad]) of each.
        complete: the solutions are every one there is (a 6R arm); False for a 7R arm, whose held
            joint was tried at a few values only.
        reason: why there are none ("" otherwise).
    """

    solutions: list[FloatArray]
    errors: list[tuple[float, float]]
    complete: bool
    reason: str


def nearest(
    chain: KinematicChain,
    T_target: FloatArray,
    q_seed: FloatArray,
    count: int,
    position_tolerance: float,
    orientation_tolerance: float,
    joint_weights: FloatArray,
    separation: float,
    deadline: float,
    tries: int = 1 + DEFAULT_HELD_SAMPLES,
    first: int = 0,
) -> Nearest | None:
    """The `count` solutions nearest `q_seed` of one target, in closed form; None if the chain has
    no closed-form family. For `ik`: its inputs are already checked (T_target a rigid (4, 4)
    transform, q_seed (n,) within the limits).

    Candidates are ranked by the weighted distance Σ wⱼ (qⱼ − q_seedⱼ)² of their nearest whole-turn
    equivalent within the limits, and checked by forward kinematics in that order (near misses
    refined, as in `solve_all`) until `count` pass, so one call usually runs one FK. A 7R arm holds
    its held joint at up to `tries` values of `held_order` (the seed's first) until one gives a
    solution or `deadline` (`time.perf_counter`) passes, starting at value `first` of them (the
    earlier ones already tried, as by `ik_batch`).
    """
    solver = solver_of(chain)
    if solver is None:
        return None
    Tl = T_target.tolist()
    seed = q_seed.tolist()
    w = joint_weights.tolist()
    tols = (position_tolerance, orientation_tolerance)
    if solver.held is None and count > 1:
        return _nearest_of_all(solver, Tl, seed, count, tols, joint_weights, separation)
    if solver.held is None:
        sols, reason = _nearest_at(solver, Tl, T_target, seed, None, count, tols, w, separation)
        return Nearest([s for s, _ in sols], [e for _, e in sols], True, reason)
    j = solver.held
    values = held_order_one(solver, seed[j], tries)[first:]
    if solver.structure.kind == "general_6r":  # each value an eigenvalue problem: in chunks
        return _nearest_in_chunks(
            chain, solver, T_target, q_seed, values, tols, joint_weights, deadline
        )
    found: list[tuple[FloatArray, tuple[float, float]]] = []
    first_reason = ""
    tried = 0
    for value in values:
        if tried and time.perf_counter() > deadline:
            break
        found, reason = _nearest_at(solver, Tl, T_target, seed, value, 1, tols, w, separation)
        first_reason = first_reason or reason
        tried += 1
        if found:
            break
    if found:
        return Nearest([found[0][0]], [found[0][1]], False, "")
    more = f", and at {tried - 1} more values" if tried > 1 else ""
    why = f"{first_reason} (with {chain.joint_names[j]} held at the seed's value{more})"
    return Nearest([], [], False, why)


#: Held values solved at once by `_nearest_in_chunks`, at most: a chunk's cost is nearly fixed
#: plus a little per value, so larger chunks cost less a value (and the most a sweep of 36 values
#: solves twice).
MAX_CHUNK = 16
#: A chunk's expected cost [s]: fixed, and per held value. Baxter's left arm, one target, its
#: arms kept (`ChainSolver.held_general`): 0.45 ms for one value, 1.1 for 4, 1.7 for 8, 2.8 for
#: 16 (one run; the same machine gave 1.25, 1.9, 2.55 and 3.8 ms before the arms were kept per
#: value and the candidates checked by the scalar FK). `_nearest_in_chunks` scales both by how
#: long its chunks took against this estimate (another arm, another machine).
CHUNK_FIXED_COST, CHUNK_VALUE_COST = 3.0e-4, 1.6e-4


def _nearest_in_chunks(
    chain: KinematicChain,
    solver: ChainSolver,
    T_target: FloatArray,
    q_seed: FloatArray,
    values: list[float],
    tols: tuple[float, float],
    joint_weights: FloatArray,
    deadline: float,
) -> Nearest:
    """`nearest` for a 7R arm whose held joint leaves a general 6R arm: its held joint at
    `values` in turn, several at once (`nearest_batch`, whose solution is the nearest the seed
    of the chunk's), each chunk the largest that the time left allows by the cost estimate
    (`CHUNK_FIXED_COST`, `CHUNK_VALUE_COST`, scaled by the chunks' measured costs: the solver's
    `chunk_speed`, a running mean kept from call to call, or this call's last chunk's where that
    was slower), until one gives a solution or `deadline` passes (the first value is always
    solved)."""
    tried = 0
    speed = solver.chunk_speed  # measured cost over the estimate
    while tried < len(values):
        left = deadline - time.perf_counter()
        if tried and left <= 0.0:
            break
        fits = (left / speed - CHUNK_FIXED_COST) / CHUNK_VALUE_COST  # values that fit
        if tried and fits < 1.0:
            break  # not one more value before the deadline
        k = MAX_CHUNK if fits >= MAX_CHUNK else max(1, int(fits))
        chunk = values[tried : tried + k]
        start = time.perf_counter()
        out = nearest_batch(
            chain, T_target[None], q_seed[None], *tols, joint_weights, np.array([chunk])
        )
        assert out is not None
        estimate = CHUNK_FIXED_COST + len(chunk) * CHUNK_VALUE_COST
        measured = min(max((time.perf_counter() - start) / estimate, 0.1), 10.0)
        solver.chunk_speed = 0.7 * solver.chunk_speed + 0.3 * measured
        speed = max(solver.chunk_speed, measured)  # (a machine slower just now: its pace)
        tried += len(chunk)
        if out.found[0]:
            errors = (float(out.position_error[0]), float(out.orientation_error[0]))
            return Nearest([out.q[0]], [errors], False, "")
    name = chain.joint_names[solver.held or 0]
    why = (
        f"no solution within the limits and tolerances with {name} held at {tried} values "
        "(the seed's first)"
    )
    return Nearest([], [], False, why)


def _nearest_of_all(
    solver: ChainSolver,
    Tl: list[list[float]],
    seed: list[float],
    count: int,
    tols: tuple[float, float],
    joint_weights: FloatArray,
    separation: float,
) -> Nearest:
    """`nearest` for several solutions of a 6R arm: from the whole set of `solve_all` (every
    whole-turn equivalent too, which the nearest-turn ranking of `_nearest_at` leaves out),
    ranked by the weighted distance, taken greedily when more than `separation` from those taken."""
    sols, _, _, reason = solve_single(solver, Tl, seed, min(tols[0], tols[1], 1e-3))
    if not sols.shape[0]:
        return Nearest([], [], True, reason)
    cost = ((sols - np.asarray(seed)) ** 2 * joint_weights).sum(axis=1)
    taken: list[FloatArray] = []
    errors: list[tuple[float, float]] = []
    for i in np.argsort(cost, kind="stable"):
        q = sols[i]
        if any(np.abs(q - t).max() <= separation for t in taken):
            continue
        taken.append(q)
        errors.append(fk_errors(solver, q.tolist(), Tl))
        if len(taken) >= count:
            break
    return Nearest(taken, errors, True, "")


def _nearest_at(
    solver: ChainSolver,
    Tl: list[list[float]],
    T_target: FloatArray,
    seed: list[float],
    held_value: float | None,
    count: int,
    tols: tuple[float, float],
    w: list[float],
    separation: float,
) -> tuple[list[tuple[FloatArray, tuple[float, float]]], str]:
    """`nearest` for one value of the held joint (None for a 6R arm): the solutions with their
    (position, rotation) errors, and why there are none ("" if there are)."""
    # The general 6R solver's roots unpolished: only the one taken is checked, and refined if
    # off (its polish step costs a third of the solve, for every root); ranked as an array.
    Q1 = general_solutions(solver, Tl, polish=False) if held_value is None else None
    if Q1 is not None:
        stages = Stages(("reach",))
        stages.passed["reach"] = n_cands = Q1.shape[0]
        ranked = rank_array(Q1, seed, solver, w)
    else:
        cands, stages = scalar_candidates(solver, Tl, seed, held_value, polish=False)
        ranked = rank_candidates(cands, seed, solver, w)
        n_cands = len(cands)
    found: list[tuple[FloatArray, tuple[float, float]]] = []
    for _, q in ranked:
        if any(np.abs(np.asarray(q) - f).max() <= separation for f, _ in found):
            continue  # the same solution as one already taken (branches may coincide)
        ep, er = fk_errors(solver, q, Tl)
        if (
            (ep > NEAREST_REFINE_ABOVE * solver.scale or er > NEAREST_REFINE_ABOVE)
            and ep < REFINE_BELOW * solver.scale
            and er < REFINE_BELOW
        ):
            q, ep, er = refine_until(solver, q, Tl, (ep, er), NEAREST_REFINE_ABOVE, solver.clipped)
        if ep > tols[0] or er > tols[1]:
            continue
        found.append((np.array(q), (ep, er)))
        if len(found) >= count:
            break
    if found:
        return found, ""
    if stages.first_dead() is not None:
        return found, empty_reason(stages.first_dead(), 0)
    if len(ranked) < n_cands:
        return found, empty_reason(None, n_cands - len(ranked))
    return found, "no closed-form candidate reproduced the target to the tolerances"


@dataclass(frozen=True)
class NearestBatch:
    """What `ik_batch` takes from the closed form for N targets: `q` (N, n) the solution nearest
    each seed where `found` (N,), else the seed; position [m] and rotation [rad] errors (inf where
    not found)."""

    q: FloatArray
    found: BoolArray
    position_error: FloatArray
    orientation_error: FloatArray


def nearest_batch(
    chain: KinematicChain,
    T_targets: FloatArray,
    q_seeds: FloatArray,
    position_tolerance: float,
    orientation_tolerance: float,
    joint_weights: FloatArray,
    held: FloatArray | None = None,
) -> NearestBatch | None:
    """`nearest` (one solution) for N targets, vectorised over targets; None without a family.

    Inputs are checked by `ik_batch`: T_targets (N, 4, 4) rigid, q_seeds (N, n) within the limits.
    A 7R arm holds its held joint at each seed's value, or at `held` (N, K) values per target
    (`held_order`).
    """
    solver = solver_of(chain)
    if solver is None:
        return None
    N, n = q_seeds.shape
    if solver.held is not None and held is None:
        held = q_seeds[:, solver.held : solver.held + 1]
    Q, ok, owner_lane, _, _ = solve_branches(solver, T_targets, q_seeds, held)
    Qc, own, ep, er = _checked_equivalents(solver, Q, ok, owner_lane, q_seeds, T_targets)
    acc = (ep <= position_tolerance) & (er <= orientation_tolerance)
    Qc, own, ep, er = Qc[acc], own[acc], ep[acc], er[acc]
    dist = (((Qc - q_seeds[own]) ** 2) * joint_weights).sum(axis=1)
    order = np.lexsort((dist, own))
    first = order[np.r_[True, own[order][1:] != own[order][:-1]]] if order.size else order
    q = q_seeds.copy()
    found = np.zeros(N, dtype=bool)
    pos, ori = np.full(N, np.inf), np.full(N, np.inf)
    t = own[first]
    q[t], found[t], pos[t], ori[t] = Qc[first], True, ep[first], er[first]
    return NearestBatch(q, found, pos, ori)


@dataclass(frozen=True)
class Branches:
    """The distinct solutions of N targets within the limits, one configuration per branch: rows
    `q` (S, n), the target of each `target` (S,) in order, and their position [m] and rotation
    [rad] errors. Whole-turn equivalents of a branch count once (the one nearest the middle of the
    limits stands for them); a 7R arm's branches at different held values count apart."""

    q: FloatArray
    target: IntArray
    position_error: FloatArray
    orientation_error: FloatArray


def branches_within_limits(
    chain: KinematicChain,
    T_targets: ArrayLike,
    held: ArrayLike | None = None,
    tolerance: float = 1e-9,
) -> Branches:
    """Which of N targets (N, 4, 4) are reachable within the limits, and by which branches.

    What a reachability map asks: `solve_all_batch` without the whole-turn equivalents (an arm
    with ±2π limits has ~230 of them per target where 8 branches differ), so its cost stays that
    of the ≤ 8 (16: general 6R) branches of each lane. Each branch with an equivalent within the
    limits is checked by forward kinematics (near misses refined) and kept when it reproduces the
    target to `tolerance` [m, rad]. `held` as in `solve_all_batch` (default: 36 values across the
    held joint's limits). Works in passes of about `SOLVE_CHUNK` lanes.

    Raises:
        NoClosedFormError, InvalidInputError: as `solve_all_batch`.
    """
    solver, T, seeds, held_arr, tol = _batch_inputs(chain, T_targets, None, held, tolerance)
    N = T.shape[0]
    K = 1 if held_arr is None else held_arr.shape[-1]
    step = max(1, SOLVE_CHUNK // K)
    parts = []
    for i in range(0, N, step):
        h = held_arr[i : i + step] if held_arr is not None and held_arr.ndim == 2 else held_arr
        parts.append(_branches_once(solver, T[i : i + step], seeds[i : i + step], h, tol, i))
    if not parts:
        n = chain.dof
        return Branches(np.empty((0, n)), np.empty(0, np.int64), np.empty(0), np.empty(0))
    return Branches(*(np.concatenate(column) for column in zip(*parts, strict=True)))


def _branches_once(
    solver: ChainSolver,
    T: FloatArray,
    seeds: FloatArray,
    held: FloatArray | None,
    tol: float,
    first: int,
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """`branches_within_limits` of one pass; targets numbered from `first`."""
    Q, ok, owner_lane, _, _ = solve_branches(solver, T, seeds, held)
    ok = ok & ~duplicate_branches(Q, ok)  # the same branch twice in a lane (mod 2π)
    Qc, own, ep, er = _checked_equivalents(solver, Q, ok, owner_lane, seeds, T)
    acc = (ep <= tol) & (er <= tol)
    return Qc[acc], own[acc] + first, ep[acc], er[acc]


def _checked_equivalents(
    solver: ChainSolver,
    Q: FloatArray,
    ok: BoolArray,
    owner_lane: IntArray,
    seeds: FloatArray,
    T: FloatArray,
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """The branches Q (L, B, n) that passed every subproblem (`ok`), each as its whole-turn
    equivalent within the limits nearest its target's seed, joint by joint (`_nearest_turn`;
    branches without one left out), checked by FK against their targets: (q, target, position
    error, rotation error) of each."""
    n = Q.shape[-1]
    Qf = Q.reshape(-1, n)
    owner = np.repeat(owner_lane, Q.shape[1])
    S = seeds[owner]
    lo = np.where(np.isfinite(solver.lower_arr), solver.lower_arr, S - math.pi)
    hi = np.where(np.isfinite(solver.upper_arr), solver.upper_arr, S + math.pi)
    k_lo = np.ceil((lo - 1e-10 - Qf) * INV_TWO_PI)
    k_hi = np.floor((hi + 1e-10 - Qf) * INV_TWO_PI)
    k = np.clip(np.round((S - Qf) * INV_TWO_PI), k_lo, k_hi)
    cand = np.flatnonzero(ok.reshape(-1) & (k_lo <= k_hi).all(axis=1))
    Qc = np.clip(Qf[cand] + TWO_PI * k[cand], lo[cand], hi[cand])
    own = owner[cand]
    Qc, ep, er = fk_check(
        solver, Qc, T[own], lambda A: np.clip(A, solver.lower_arr, solver.upper_arr)
    )
    return Qc, own, ep, er
