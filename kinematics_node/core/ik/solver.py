"""Inverse kinematics: the closed form where the arm has one, else (or when it finds nothing)
damped least squares (Levenberg–Marquardt) with random restarts.

Solvers (`IKOptions.method`, default "auto"):

* closed form (`closed_form.nearest`, docs/closed_form.md): for arms whose screw axes form a
  known family, when the whole pose is asked for. A 6R arm's candidates (at most 8 branches, each
  at its whole-turn equivalent within the limits nearest the seed) are ranked by distance to the
  seed and checked by FK in that order, so the answer is the solution nearest the seed, exactly,
  in about a tenth of a millisecond. A 7R arm holds one joint at a few values (the seed's, then
  spread over its range); if none gives a solution, the numeric search below gets half the time
  left, then the closed form sweeps the held joint, then the search gets the rest. A 7R arm whose
  held joint leaves a general 6R arm (each try an eigenvalue problem) starts with the search and
  sweeps only what it misses. A target the closed form cannot reach goes to the search
  (its message starts with the closed form's reason), so near-misses within loose tolerances are
  still found.
* numeric, below.

Sets (num_solutions > 1, or mode "distance") are ranked by the weighted distance to the seed, and
always hold the answer that the same call asking for one solution in mode "speed" gets: so the
first of a set is never farther from the seed than that one (a 7R arm's set, found by the numeric
search, takes in the closed form's answer; a 6R arm's, from its whole solution set, the nearest
branch's refined solution).

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

import math
import time
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..exceptions import InvalidInputError
from ..model import KinematicChain, readonly
from .batch import BatchOutcome, BatchSolver
from .closed_form import (
    DEFAULT_HELD_SAMPLES,
    Nearest,
    family_of,
    held_order,
    nearest,
    nearest_batch,
    no_closed_form_reason,
)
from .options import IKOptions
from .problem import IKProblem
from .result import IKBatchResult, IKResult, check_seed, default_seed
from .single import SingleOutcome, SingleSolver

FloatArray = NDArray[np.float64]
# Below this many targets `ik_batch` solves them one by one with the scalar solver: the lock-step
# NumPy iteration costs ~1 ms whatever the batch size, so it only pays off for larger batches
# (measured on Panda and UR5: 1.4 vs 0.44 ms per target at N = 10, about even at N = 50–64,
# 0.2 vs 0.5 ms at N = 200).
SCALAR_BATCH_BELOW = 48
# On a 7R arm, "auto" gives the numeric search this share of the time left after the closed form
# at `HELD_FIRST_TRIES` values of the held joint, and the closed form's sweep of it the rest.
NUMERIC_SHARE_7R = 0.5
# "auto" first tries a 7R arm's held joint at this many values (`closed_form.held_order`: the
# seed's, then spread over the range). Each try costs about a 6R solve (~50 µs; in `ik_batch` a
# few ms per try on the targets left); on Panda, where a value of joint 7 reaches ~37 % of random
# targets, 4 tries answer ~76 % of them and 16 ~98 %. Measured on Panda with 1000 random targets:
# 16 rather than 4 cut `ik`'s mean from 0.37 to 0.23 ms (median 0.21 → 0.19) and raised
# `ik_batch` from ~7k to ~10k solutions/s (fewer targets left to the numeric search); iiwa
# unchanged (the first value answers 99.8 %), xArm7 mean 0.35 → 0.30 ms.
HELD_FIRST_TRIES = 16
# `ik_batch` sweeps a 7R arm's held joint for this many targets at a time between deadline checks.
SWEEP_CHUNK = 8
# On a 7R arm whose six other joints form no named family ("7r_general_6r": Baxter), each held
# value costs a general 6R solve, an eigenvalue problem (~0.2-0.5 ms), and one value reaches only
# part of the targets, so "auto" gives the numeric search this share of the time first and sweeps
# the held joint only on what it misses. Measured on Baxter's left arm (TRAC-IK protocol, 1000
# targets, 5 ms, one run): the closed form's tries first reached 92.4 % at a median of 1.26 ms,
# where the numeric search alone reached 100 % at 0.27 ms (issue 24: no success rate may drop).
# The share: Baxter, 8000 targets (seeds 777, 779), each solved with every share in turn (the
# machine's pace then the same for all): failures 15 at 0.8, 9 at 0.5, 13 at 0.3, 36 at 0.15, the
# median 0.30-0.32 ms for all. The targets both miss lie near the joint limits, where a held value
# reaches 4-35 % of the held joint's range and the numeric search needs 20-90 restarts.
NUMERIC_SHARE_GENERAL_7R = 0.5


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
    T = _one_target(chain, T_target)
    start = time.perf_counter()  # before `_prepared`: a chain's first call detects its family
    problem, closed, default = _prepared(chain, opts)
    seed = default if q_seed is None else check_seed(chain, q_seed, "q_seed", None)
    if closed.blocker and opts.method == "closed_form":
        raise InvalidInputError(f"IKOptions.method='closed_form' does not apply: {closed.blocker}")
    far = beyond_reach(chain, T, opts)
    if far:  # nothing to find: one descent from the seed for the best effort, not the timeout
        one, _, _ = _prepared(chain, replace(opts, max_restarts=0))
        out = SingleSolver(one, T, seed).run(start + opts.timeout)
        return _numeric_result(out, opts, start, f"unreachable: {far}; ", unreachable=True)
    deadline = start + opts.timeout
    known = _single_answer(chain, problem, closed, T, seed, start, deadline)
    return _solve_one(problem, closed, T, seed, start, deadline, known)


def _single_answer(
    chain: KinematicChain,
    problem: IKProblem,
    closed: _ClosedForm,
    T: FloatArray,
    seed: FloatArray,
    start: float,
    deadline: float,
) -> IKResult | None:
    """For a request of a set (num_solutions > 1, or mode "distance") that the closed form cannot
    give (a 7R arm): the answer of the same request with one solution in mode "speed", which the
    closed form gives, if it succeeds; else None (also where nothing needs it).

    Why: the set comes from the numeric search, whose solutions all start from the seed or
    random restarts; the single-solution request is answered in closed form with the held joint
    at the seed's value first, which is often nearer the seed than anything the search finds.
    The set includes it (`SingleSolver.run`'s `known`), so `solutions[0]` is never farther from
    the seed than the one solution asked alone would be (issue 22). The closed form costs
    ~0.1-1 ms; where its first tries miss, the single request's own search runs here too."""
    opts = problem.opts
    if not closed.blocker or opts.method == "numeric":
        return None  # `_ClosedForm.nearest` includes it itself (6R), or the search subsumes it
    if opts.num_solutions == 1 and opts.mode == "speed":
        return None  # (a single-solution request itself)
    single, single_closed, _ = _prepared(chain, replace(opts, mode="speed", num_solutions=1))
    if single_closed.blocker:
        return None  # no closed form: the set's search begins with the single request's
    out = _solve_one(single, single_closed, T, seed, start, deadline)
    return out if out.success else None


def solve_closed_form(
    chain: KinematicChain,
    T_target: ArrayLike,
    q_seed: ArrayLike | None = None,
    options: IKOptions | None = None,
) -> IKResult | None:
    """`solve`'s answer when the closed form finds one at its first try (a 7R arm: with the held
    joint at the seed's value), else None: no best-effort evaluation, no search, no sweep. So a
    miss is cheap (a UR5e: ~0.03 ms, against ~0.9 ms for `solve` with method "closed_form",
    most of it evaluating the seed as the best effort), and a caller can answer at once where
    this succeeds and hand the rest to `solve` elsewhere (the node's IK workers do that).
    None also where the closed form does not apply (no family, position-only, freed axes,
    method "numeric"). Same arguments and errors as `solve`."""
    opts = _options(options)
    if opts.method == "numeric":
        return None
    T = _one_target(chain, T_target)
    start = time.perf_counter()
    problem, closed, default = _prepared(chain, replace(opts, method="closed_form"))
    if closed.blocker:
        return None
    seed = default if q_seed is None else check_seed(chain, q_seed, "q_seed", None)
    found = closed.nearest(T, seed, start + opts.timeout, 1)
    if not found.solutions:
        return None
    return _closed_form_result(found, problem, T, seed, start)


def _one_target(chain: KinematicChain, T_target: ArrayLike) -> FloatArray:
    """T_target checked as one finite rigid transform (InvalidInputError otherwise)."""
    T = chain.check_target(T_target)
    if T.shape != (4, 4):
        raise InvalidInputError(
            f"T_target must have shape (4, 4) (use ik_batch for many), got {T.shape}"
        )
    return T


def beyond_reach(chain: KinematicChain, T: FloatArray, opts: IKOptions) -> str:
    """Why the position of target T (4×4, base frame) is beyond every configuration of `chain`
    (farther from `chain.reach_sphere`'s centre than its radius plus the position tolerance), or
    "" when it is not: then a search may still fail, but it is not hopeless."""
    if opts.axis_tolerances is not None:
        slack = max(opts.axis_tolerances[3:])  # inf when a position axis is free
    else:
        slack = opts.position_tolerance
    center, radius = chain.reach_sphere
    distance = math.dist(T[:3, 3].tolist(), center.tolist())
    if distance <= radius + slack:
        return ""
    far = f"{distance:.3f}" if distance < 1e6 else f"{distance:.3g}"
    return (
        f"the target is {far} m from the first joint of {chain.base_link!r} → "
        f"{chain.tip_link!r}, which reaches at most {radius:.3f} m"
    )


_PREPARED: weakref.WeakKeyDictionary[
    KinematicChain, dict[IKOptions, tuple[IKProblem, _ClosedForm, FloatArray]]
] = weakref.WeakKeyDictionary()


def _prepared(chain: KinematicChain, opts: IKOptions) -> tuple[IKProblem, _ClosedForm, FloatArray]:
    """The problem of `chain` under `opts`, its closed form and the default seed, worked out once
    per (chain, options) pair and kept while the chain lives (both are immutable): ~20 µs a call
    that the closed form's ~100 µs answers would otherwise pay."""
    per_chain = _PREPARED.get(chain)
    if per_chain is None:
        per_chain = _PREPARED.setdefault(chain, {})
    got = per_chain.get(opts)
    if got is None:
        if len(per_chain) >= 64:  # many distinct options (e.g. a timeout per request): start over
            per_chain.clear()
        problem = IKProblem.build(chain, opts)
        got = (problem, _ClosedForm.of(problem), readonly(default_seed(chain)))
        per_chain[opts] = got
    return got


def _solve_one(
    problem: IKProblem,
    closed: _ClosedForm,
    T: FloatArray,
    seed: FloatArray,
    start: float,
    deadline: float,
    known: IKResult | None = None,
) -> IKResult:
    """One target by the solvers `problem.opts.method` names, within `deadline`. `known`: a
    solution found already (`_single_answer`), which the numeric search counts as one of its own."""
    opts = problem.opts
    if closed.blocker or opts.method == "numeric":
        had = () if known is None else ((known.q, known.position_error, known.orientation_error),)
        return _numeric_result(SingleSolver(problem, T, seed).run(deadline, had), opts, start, "")
    # A 6R arm's closed form is exhaustive; a 7R arm's tries its held joint at a few values
    # (each about a 6R solve), then the numeric search gets half the time, then the closed form sweeps
    # the held joint, then the numeric search gets the rest ("auto": the closed form finds what
    # the search misses, and the search is usually quicker than a sweep). A held general 6R arm
    # ("costly": each try is an eigenvalue problem) skips the first tries: the numeric search
    # gets `NUMERIC_SHARE_GENERAL_7R` of the time, then the sweep, then the search again.
    searches: list[SingleSolver] = []  # built when first needed (the closed form usually answers)

    def search(until: float) -> SingleOutcome:
        """The numeric search until `until`; run again, it goes on where it stopped."""
        if not searches:
            searches.append(SingleSolver(problem, T, seed))
        return searches[0].run(until)

    if closed.costly and opts.method == "auto":
        share = NUMERIC_SHARE_GENERAL_7R
        out = search(start + share * (deadline - start))
        if out.success:
            return _numeric_result(out, opts, start, "")
    else:
        tries = 1 + DEFAULT_HELD_SAMPLES if opts.method == "closed_form" else HELD_FIRST_TRIES
        found = closed.nearest(T, seed, deadline, tries)
        if found.solutions or opts.method == "closed_form":
            return _closed_form_result(found, problem, T, seed, start)
        prefix = f"closed form: {found.reason}; numeric search: "
        if not closed.held:
            return _numeric_result(search(deadline), opts, start, prefix)
        out = search(start + NUMERIC_SHARE_7R * (deadline - start))
        if out.success:
            return _numeric_result(out, opts, start, "")
    found = closed.nearest(T, seed, deadline, 1 + DEFAULT_HELD_SAMPLES)
    if found.solutions:
        return _closed_form_result(found, problem, T, seed, start)
    prefix = f"closed form: {found.reason}; numeric search: "
    return _numeric_result(search(deadline), opts, start, prefix)


def duration_text(seconds: float) -> str:
    """A duration for people, in the unit that suits it: "0.31 ms", "1.52 ms", "50.1 ms", "2.05 s"."""
    if seconds < 0.01:
        return f"{seconds * 1e3:.2f} ms"
    if seconds < 1.0:
        return f"{seconds * 1e3:.1f} ms"
    return f"{seconds:.2f} s"


def _stop_text(reason: str, opts: IKOptions) -> str:
    """Why a numeric search stopped, in words ("timeout": the timeout named with its value)."""
    if reason == "timeout":
        t = opts.timeout
        return (
            f"the {t * 1e3:.3g} ms timeout ran out" if t < 1.0 else f"the {t:.3g} s timeout ran out"
        )
    return reason


def _residual_text(position_error: float, orientation_error: float, opts: IKOptions) -> str:
    """The errors [m, rad] of a configuration against what the options ask for."""
    if opts.position_only:
        return f"{position_error:.3g} m (tolerance {opts.position_tolerance:g} m, orientation free)"
    errors = f"{position_error:.3g} m / {orientation_error:.3g} rad"
    if opts.axis_tolerances is not None:
        return f"{errors} (per-axis bounds {', '.join(f'{b:g}' for b in opts.axis_tolerances)})"
    return (
        f"{errors} (tolerances {opts.position_tolerance:g} m / {opts.orientation_tolerance:g} rad)"
    )


def _numeric_result(
    out: SingleOutcome, opts: IKOptions, start: float, prefix: str, unreachable: bool = False
) -> IKResult:
    """The `IKResult` of a numeric search's outcome, with its message: on failure why the search
    stopped (said once, with the time it took) and the best residual against what was asked.
    `unreachable`: the search was the one descent from the seed made for a target out of reach
    (`prefix` says why), not a search that ran out of restarts."""
    elapsed = duration_text(time.perf_counter() - start)
    solutions = tuple(readonly(s) for s in out.solutions)
    if out.success:
        n_found = len(solutions)
        msg = f"found {n_found} solution{'s' if n_found > 1 else ''} in {elapsed}"
        if n_found < opts.num_solutions:
            msg += f" ({opts.num_solutions} requested; {_stop_text(out.stop_reason, opts)})"
        msg += f", {out.restarts} restarts, {out.iterations} iterations"
    elif unreachable:
        msg = (
            f"best effort from the seed in {elapsed}: residual "
            f"{_residual_text(out.position_error, out.orientation_error, opts)}"
        )
    else:
        restarts = f"{out.restarts} restart{'' if out.restarts == 1 else 's'}"
        msg = (
            f"no solution: {_stop_text(out.stop_reason, opts)} after {elapsed}, {restarts}; "
            f"best residual {_residual_text(out.position_error, out.orientation_error, opts)}"
        )
    return IKResult(
        q=readonly(out.q),
        success=out.success,
        position_error=out.position_error,
        orientation_error=out.orientation_error,
        iterations=out.iterations,
        restarts=out.restarts,
        solutions=solutions,
        message=prefix + msg,
    )


@dataclass(frozen=True)
class _ClosedForm:
    """The closed form as an IK solver for one problem (`closed_form.nearest`).

    It applies to chains with a closed-form family when the whole pose is asked for: not
    position-only and no freed component (zero weight or infinite axis bound), since a freed
    component leaves infinitely many solutions. A 6R arm's closed form finds every solution, so it
    answers any mode and number of solutions; a 7R arm's one solution in "speed" mode. Finite axis
    bounds are met by requiring the position and rotation errors within the smallest bound of
    each (the solutions are exact to ~1e-12 anyway). `blocker` says why it does not apply ("" if
    it does).
    """

    problem: IKProblem
    blocker: str
    held: bool
    tolerances: tuple[float, float]
    # A 7R arm whose held joint leaves a general 6R arm: each try costs an eigenvalue problem, so
    # "auto" searches numerically first (`NUMERIC_SHARE_GENERAL_7R`).
    costly: bool = False

    @classmethod
    def of(cls, problem: IKProblem) -> _ClosedForm:
        opts = problem.opts
        tols = (opts.position_tolerance, opts.orientation_tolerance)
        if problem.axis_tol is not None:
            tols = (float(problem.axis_tol[3:].min()), float(problem.axis_tol[:3].min()))
        held = costly = False
        if problem.position_only:
            blocker = "position_only leaves infinitely many solutions"
        elif not problem.all_weighted:
            blocker = "a freed pose component leaves infinitely many solutions"
        else:
            family = family_of(problem.chain)
            if family is None:
                blocker = no_closed_form_reason(problem.chain)
            elif family.held_joint is not None and (
                opts.mode != "speed" or opts.num_solutions != 1
            ):
                blocker = (
                    "on a 7R arm it gives one solution in mode 'speed' (chain.ik_all sweeps the "
                    "held joint for sets)"
                )
            else:
                blocker, held = "", family.held_joint is not None
                costly = held and family.name == "7r_general_6r"
        return cls(problem, blocker, held, tols, costly)

    def nearest(
        self, T: FloatArray, seed: FloatArray, deadline: float, tries: int, first: int = 0
    ) -> Nearest:
        p = self.problem
        count, w, separation = p.opts.num_solutions, p.joint_weights, p.opts.solution_separation
        found = nearest(
            p.chain, T, seed, count, *self.tolerances, w, separation, deadline, tries, first
        )
        assert found is not None  # the family was found in `of`
        if count == 1:
            return found
        # A set is ranked from the whole solution set (`closed_form.api`'s `_nearest_of_all`), one
        # solution from the nearest branches, refined where it is a near miss: at a singular
        # target the two can differ by ~1e-8 rad, so the set takes the single one in (issue 22).
        one = nearest(p.chain, T, seed, 1, *self.tolerances, w, separation, deadline, tries, first)
        assert one is not None
        if not one.solutions:
            return found
        order, new = nearest_first(one.solutions[0], found.solutions, seed, w, separation)
        every = [one.solutions[0], *found.solutions]
        errors = [one.errors[0], *found.errors]
        return Nearest(
            [every[i] for i in order][:count],
            [errors[i] for i in order][:count],
            found.complete and not new,  # (a new one: the whole set had missed it)
            found.reason,
        )


def nearest_first(
    q_first: ArrayLike,
    others: Sequence[ArrayLike] | FloatArray,
    seed: ArrayLike,
    joint_weights: ArrayLike,
    separation: float,
) -> tuple[list[int], bool]:
    """How to merge the solution `q_first` (n,) into a set `others` (K, n) of solutions of one
    target: indices into [q_first, *others], nearest the seed first by the weighted distance
    Σ wⱼ (qⱼ − seedⱼ)² that `ik` ranks by (ties: `q_first`, then the set's order), leaving out the
    members of `others` within `separation` of `q_first` in every joint (the same solution). The
    second value says whether `q_first` was new (no such member)."""
    Q = np.array([np.asarray(q_first, dtype=np.float64), *others], dtype=np.float64)
    Q = Q.reshape(len(Q), -1)
    same = np.max(np.abs(Q[1:] - Q[0]), axis=1, initial=0.0) <= separation
    keep = np.concatenate(([0], 1 + np.flatnonzero(~same)))
    w = np.asarray(joint_weights, dtype=np.float64)
    cost = ((Q[keep] - np.asarray(seed, dtype=np.float64)) ** 2 * w).sum(axis=1)
    order = keep[np.argsort(cost, kind="stable")]
    return [int(i) for i in order], not bool(same.any())


def _closed_form_result(
    found: Nearest, problem: IKProblem, T: FloatArray, seed: FloatArray, start: float
) -> IKResult:
    opts = problem.opts
    elapsed = duration_text(time.perf_counter() - start)
    k = len(found.solutions)
    if not k:  # method "closed_form" only
        E, _, pos, ori, _, _ = problem.evaluate_batch(seed[None], T[None, :3, :3], T[None, :3, 3])
        return IKResult(
            q=readonly(seed), success=False, position_error=float(pos[0]),
            orientation_error=float(ori[0]), iterations=0, restarts=0,
            message=f"no solution in closed form in {elapsed}: {found.reason}; residual of "
            f"the seed {_residual_text(float(pos[0]), float(ori[0]), opts)}",
        )  # fmt: skip
    msg = f"found {k} solution{'s' if k > 1 else ''} in closed form in {elapsed}"
    if k < opts.num_solutions:
        msg += f" ({opts.num_solutions} requested; the arm has no more within the limits)"
    ep, er = found.errors[0]
    solutions = tuple(readonly(s) for s in found.solutions)
    return IKResult(
        q=solutions[0],  # read-only: q may be the same array as solutions[0]
        success=True,
        position_error=ep,
        orientation_error=er,
        iterations=0,
        restarts=0,
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
    problem, closed, _ = _prepared(chain, opts)
    if closed.blocker and opts.method == "closed_form":
        raise InvalidInputError(f"IKOptions.method='closed_form' does not apply: {closed.blocker}")
    if N < SCALAR_BATCH_BELOW:
        out, n_closed = _solve_each(problem, closed, T, seeds, start + budget)
    else:
        out, n_closed = _solve_vectorised(problem, closed, T, seeds, start, start + budget)
    elapsed_ms = (time.perf_counter() - start) * 1e3
    n_ok = int(out.success.sum())
    msg = f"{n_ok}/{N} targets solved in {elapsed_ms:.1f} ms"
    if n_closed:
        msg += f", {n_closed} in closed form"
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
    problem: IKProblem, closed: _ClosedForm, T: FloatArray, seeds: FloatArray, deadline: float
) -> tuple[BatchOutcome, int]:
    """Small batches: `ik` per target, each with `opts.timeout` but never past the batch's
    deadline. Results equal those of `ik` on each target whenever neither budget binds."""
    outs = []
    for T_k, seed_k in zip(T, seeds, strict=True):
        now = time.perf_counter()
        own = min(now + problem.opts.timeout, deadline)
        outs.append(_solve_one(problem, closed, T_k, seed_k, now, own))
    failed = [o.message for o in outs if not o.success]
    outcome = _stacked(outs, len(problem.lower), failed[0] if failed else "done")
    return outcome, sum(1 for o in outs if o.success and "closed form" in o.message)


def _stacked(
    outs: Sequence[IKResult] | Sequence[SingleOutcome], n: int, stop_reason: str
) -> BatchOutcome:
    """Per-target outcomes (each with q, success, errors, iterations, restarts) as one batch."""
    return BatchOutcome(
        q=np.array([o.q for o in outs]).reshape(len(outs), n),
        success=np.array([o.success for o in outs], dtype=bool),
        position_error=np.array([o.position_error for o in outs], dtype=np.float64),
        orientation_error=np.array([o.orientation_error for o in outs], dtype=np.float64),
        iterations=np.array([o.iterations for o in outs], dtype=np.int64),
        restarts=np.array([o.restarts for o in outs], dtype=np.int64),
        stop_reason=stop_reason,
    )


def _solve_vectorised(
    problem: IKProblem,
    closed: _ClosedForm,
    T: FloatArray,
    seeds: FloatArray,
    start: float,
    deadline: float,
) -> tuple[BatchOutcome, int]:
    """Large batches, vectorised over the targets, in the order of `_solve_one`: the closed form
    (a 7R arm's held joint at `HELD_FIRST_TRIES` values, each value on the targets the earlier
    ones left), the numeric search on the targets left (a 7R arm: half the time left), a 7R arm's
    sweep of the held joint on those still left, the numeric search again. A held general 6R arm
    (`_ClosedForm.costly`) starts with the numeric search instead of the first tries. Returns the
    outcome and how many targets the closed form solved."""
    opts = problem.opts
    if closed.blocker or opts.method == "numeric":
        return BatchSolver(problem, T, seeds).run(deadline), 0
    chain, w = problem.chain, problem.joint_weights
    costly = closed.costly and opts.method == "auto"
    if costly:  # a held general 6R arm: the numeric search first (as `_solve_one`)
        now = time.perf_counter()
        out = BatchSolver(problem, T, seeds).run(now + NUMERIC_SHARE_GENERAL_7R * (deadline - now))
    else:
        first = nearest_batch(chain, T, seeds, *closed.tolerances, w)  # 7R: the seeds' held values
        assert first is not None  # the family was found in _ClosedForm.of
        N = T.shape[0]
        out = BatchOutcome(
            q=first.q.copy(),
            success=first.found.copy(),
            position_error=first.position_error.copy(),
            orientation_error=first.orientation_error.copy(),
            iterations=np.zeros(N, dtype=np.int64),
            restarts=np.zeros(N, dtype=np.int64),
            stop_reason="done",
        )
    if closed.held and not costly:  # the next held values, each on the targets still unsolved
        order = held_order(chain, seeds, HELD_FIRST_TRIES)
        for k in range(1, HELD_FIRST_TRIES):
            if time.perf_counter() >= deadline:  # each try costs ~2 ms on 50 targets
                break
            left = np.flatnonzero(~out.success)
            if left.size < SCALAR_BATCH_BELOW:  # a vectorised try costs ~1.5 ms even for 1 target
                _take_each(out, closed, T, seeds, left, k, deadline)
                break
            _take(out, chain, T, seeds, closed, w, left, order[left, k : k + 1])
    n_closed = 0 if costly else int(out.success.sum())
    numeric = opts.method == "auto"
    if numeric and not closed.held:
        _numeric_on(problem, T, seeds, out, deadline)
        return out, n_closed
    if numeric and not costly:
        now = time.perf_counter()
        _numeric_on(problem, T, seeds, out, now + NUMERIC_SHARE_7R * (deadline - now))
    left = np.flatnonzero(~out.success)
    # The sweep costs ~1 ms per target (36 held values); in chunks, so the deadline holds.
    chunks = np.array_split(left, -(-left.size // SWEEP_CHUNK)) if closed.held and left.size else []
    for part in chunks:
        if time.perf_counter() >= deadline:
            break
        sweep = held_order(chain, seeds[part], 1 + DEFAULT_HELD_SAMPLES)
        n_closed += _take(out, chain, T, seeds, closed, w, part, sweep)
    if numeric:
        _numeric_on(problem, T, seeds, out, deadline)
    if not out.success.all() and out.stop_reason == "done":
        out.stop_reason = "no solution in closed form"
    return out, n_closed


def _take(
    out: BatchOutcome,
    chain: KinematicChain,
    T: FloatArray,
    seeds: FloatArray,
    closed: _ClosedForm,
    w: FloatArray,
    idx: NDArray[np.int64],
    held: FloatArray,
) -> int:
    """The closed form on targets `idx` of a 7R arm with its held joint at `held` (len(idx), K)
    values, written into `out` where it finds a solution; how many it found."""
    if not idx.size:
        return 0
    got = nearest_batch(chain, T[idx], seeds[idx], *closed.tolerances, w, held)
    assert got is not None
    hit = idx[got.found]
    out.q[hit] = got.q[got.found]
    out.position_error[hit] = got.position_error[got.found]
    out.orientation_error[hit] = got.orientation_error[got.found]
    out.success[hit] = True
    return int(hit.size)


def _take_each(
    out: BatchOutcome,
    closed: _ClosedForm,
    T: FloatArray,
    seeds: FloatArray,
    idx: NDArray[np.int64],
    first: int,
    deadline: float,
) -> None:
    """The closed form on the few targets `idx` of a 7R arm one by one (as `ik` does), at the
    held values `first` … `HELD_FIRST_TRIES` − 1 of `held_order`, written into `out`."""
    for i in idx.tolist():
        found = closed.nearest(T[i], seeds[i], deadline, HELD_FIRST_TRIES, first)
        if found.solutions:
            out.q[i] = found.solutions[0]
            out.position_error[i], out.orientation_error[i] = found.errors[0]
            out.success[i] = True


def _numeric_on(
    problem: IKProblem, T: FloatArray, seeds: FloatArray, out: BatchOutcome, deadline: float
) -> None:
    """The numeric search on the targets `out` has not solved, written into `out` (a failure
    keeps the best configuration found)."""
    left = np.flatnonzero(~out.success)
    if not left.size:
        return
    if left.size >= SCALAR_BATCH_BELOW:
        part = BatchSolver(problem, T[left], seeds[left]).run(deadline)
    else:
        runs = [SingleSolver(problem, T[i], seeds[i]).run(deadline) for i in left]
        reason = next((r.stop_reason for r in runs if not r.success), "done")
        part = _stacked(runs, len(problem.lower), reason)
    out.q[left] = part.q
    out.success[left] = part.success
    out.position_error[left] = part.position_error
    out.orientation_error[left] = part.orientation_error
    out.iterations[left] += part.iterations
    out.restarts[left] += part.restarts
    out.stop_reason = part.stop_reason


__all__: Sequence[str] = [
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "beyond_reach",
    "nearest_first",
    "check_seed",
    "default_seed",
    "duration_text",
    "solve",
    "solve_batch",
    "solve_closed_form",
]
