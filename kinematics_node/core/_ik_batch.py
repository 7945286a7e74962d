"""Vectorised Levenberg–Marquardt IK for N targets in lock-step (algorithm: see `ik`'s docstring).

Every iteration evaluates FK and the body Jacobian of all still-active targets with the chain's
batched NumPy kernel, solves the (k, m, m) damped normal equations with one batched
`np.linalg.solve`, and accepts or rejects each target's step on its own. Targets whose attempt is
stuck or out of iterations restart from random configurations together.

Work is organised in *lanes*: one lane = one attempt for one target. At first there is one lane per
target (starting at its seed). When fewer than `MIN_LANES` lanes are still running, unsolved
targets get extra lanes from random configurations, so the slow tail of hard targets runs several
restarts in parallel instead of one after another at a high per-iteration overhead. A target is
solved by its first converged lane; its other lanes are dropped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from . import se3, so3
from ._ik_single import (
    LAMBDA_INIT,
    LAMBDA_MAX,
    LAMBDA_MIN,
    MAX_STEP,
    PINNED_STEPS,
    STALL_FRACTION,
    STALL_STEPS,
)
from ._joint_space import (
    into_limits_batch,
    nearest_equivalent_batch,
    periodic_mask,
    pinnable_mask,
    sample_bounds,
)

if TYPE_CHECKING:
    from .chain import SerialChain
    from .ik import IKOptions

FloatArray = NDArray[np.float64]


@dataclass
class BatchOutcome:
    q: FloatArray
    success: NDArray[np.bool_]
    position_error: FloatArray
    orientation_error: FloatArray
    iterations: NDArray[np.int64]
    restarts: NDArray[np.int64]
    stop_reason: str


class _BatchProblem:
    """Constant data of one batch call and the vectorised error/Jacobian evaluation."""

    def __init__(self, chain: SerialChain, T: FloatArray, opts: IKOptions) -> None:
        self.chain = chain
        self.R_t = T[:, :3, :3]
        self.p_t = T[:, :3, 3]
        w = np.array(opts.weights if opts.weights is not None else (1.0,) * 6)
        self.position_only = bool(opts.position_only)
        self.tol_p, self.tol_o = opts.position_tolerance, opts.orientation_tolerance
        # per-axis bounds as in `SingleSolver`: inf frees the axis like a zero weight
        self.axis_tol: FloatArray | None = None
        if opts.axis_tolerances is not None:
            bounds = np.array(opts.axis_tolerances)
            w = np.where(np.isinf(bounds), 0.0, w)
            self.axis_tol = np.where(w > 0, bounds, np.inf)
        self.coupled = not self.position_only and bool(np.all(w > 0)) and self.axis_tol is None
        self.w = w[3:] if self.position_only else w
        self.sw = np.sqrt(self.w)
        self.pos_mask = (w[3:] > 0).astype(np.float64)
        self.ori_mask = (w[:3] > 0).astype(np.float64)
        self.all_ori = bool(np.all(w[:3] > 0))

    def evaluate(
        self, Q: FloatArray, idx: NDArray[np.intp]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_], FloatArray]:
        """At Q (k, n) for targets idx: E, e (k, m), pos [m], ori [rad], within tolerance,
        W^½J (k, m, n)."""
        T_c, J = self.chain.fk_jacobian(Q, "body")
        R_c, p_c = T_c[:, :3, :3], T_c[:, :3, 3]
        R_cT = np.swapaxes(R_c, 1, 2)
        R_e = R_cT @ self.R_t[idx]  # T_err = T_c⁻¹ T_t
        p_e = (R_cT @ (self.p_t[idx] - p_c)[:, :, None])[:, :, 0]
        if self.coupled:
            T_e = se3.make_transform(R_e, p_e)
            e = se3.log(T_e)
            phi = e[:, :3]
        else:
            phi = so3.log(R_e)
            e = p_e if self.position_only else np.concatenate((phi, p_e), axis=1)
            # body Jacobian of the target point attached to the tip: J_v + J_ω × p_err
            Jw, Jv = J[:, :3, :], J[:, 3:, :]
            Jv = Jv + np.swapaxes(np.cross(np.swapaxes(Jw, 1, 2), p_e[:, None, :]), 1, 2)
            J = Jv if self.position_only else np.concatenate((Jw, Jv), axis=1)
        within: NDArray[np.bool_] | None = None
        if self.axis_tol is not None:  # a component within its bound is met and exerts no pull
            within = np.abs(e) <= self.axis_tol  # False for NaN
            e = np.where(within, 0.0, e)
        E = np.einsum("km,m->k", e * e, self.w)
        pos = np.sqrt(np.einsum("kj,j->k", p_e * p_e, self.pos_mask))
        if self.position_only:
            ori = np.zeros(Q.shape[0])
        elif self.all_ori:
            ori = np.linalg.norm(phi, axis=1)
        else:
            ori = np.sqrt(np.einsum("kj,j->k", phi * phi, self.ori_mask))
        ok: NDArray[np.bool_]
        if within is not None:
            ok = np.all(within, axis=1)
        else:
            ok = (pos <= self.tol_p) & (ori <= self.tol_o)
        return E, e, pos, ori, ok, J * self.sw[None, :, None]


def _lm_steps(
    J: FloatArray, r: FloatArray, lam: FloatArray, eye: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Batched Δq = Jᵀ(J Jᵀ + λI)⁻¹ r (k, n) and the predicted decrease Δqᵀ(λΔq + Jᵀr) (k,)."""
    JT = np.swapaxes(J, 1, 2)
    A = J @ JT + lam[:, None, None] * eye
    try:
        y = np.linalg.solve(A, r[:, :, None])
    except np.linalg.LinAlgError:  # an exactly singular member: least squares for all
        y = np.linalg.pinv(A) @ r[:, :, None]
    dq = (JT @ y)[:, :, 0]
    predicted = np.einsum("kn,kn->k", dq, lam[:, None] * dq + (JT @ r[:, :, None])[:, :, 0])
    return dq, predicted


MIN_LANES = 256  # top up the running attempts to this many while targets remain unsolved


@dataclass
class _Lanes:
    """Per-attempt state, one row per lane."""

    tgt: NDArray[np.intp]
    Q: FloatArray
    E: FloatArray
    e: FloatArray
    pos: FloatArray
    ori: FloatArray
    ok: NDArray[np.bool_]
    J: FloatArray
    lam: FloatArray
    nu: FloatArray
    stall: NDArray[np.int64]
    pinned: NDArray[np.int64]
    it: NDArray[np.int64]

    def keep(self, mask: NDArray[np.bool_]) -> _Lanes:
        return _Lanes(*(getattr(self, f)[mask] for f in _LANE_FIELDS))

    @staticmethod
    def concat(a: _Lanes, b: _Lanes) -> _Lanes:
        return _Lanes(*(np.concatenate((getattr(a, f), getattr(b, f))) for f in _LANE_FIELDS))


_LANE_FIELDS = ("tgt", "Q", "E", "e", "pos", "ori", "ok", "J", "lam", "nu", "stall", "pinned", "it")


def solve_batch_arrays(
    chain: SerialChain, T: FloatArray, seeds: FloatArray, opts: IKOptions, deadline: float
) -> BatchOutcome:
    """Solve all targets (inputs already validated); see `ik.solve_batch`."""
    N, n = seeds.shape
    prob = _BatchProblem(chain, T, opts)
    lower, upper = np.asarray(chain.lower), np.asarray(chain.upper)
    periodic = periodic_mask(chain)
    can_pin = pinnable_mask(chain, periodic)
    lo, hi = sample_bounds(lower, upper, seeds)
    rng = np.random.default_rng(opts.rng_seed)

    success = np.zeros(N, dtype=bool)
    q_sol = seeds.copy()
    sol_pos, sol_ori = np.full(N, np.inf), np.full(N, np.inf)
    best_E, best_Q = np.full(N, np.inf), seeds.copy()
    best_pos, best_ori = np.full(N, np.inf), np.full(N, np.inf)
    iterations = np.zeros(N, dtype=np.int64)
    restarts = np.zeros(N, dtype=np.int64)
    m = 3 if opts.position_only else 6
    eye = np.eye(m)

    def new_lanes(tgt: NDArray[np.intp], Q: FloatArray) -> _Lanes:
        E, e, pos, ori, ok, J = prob.evaluate(Q, tgt)
        k = tgt.size
        return _Lanes(
            tgt, Q, E, e, pos, ori, ok, J, np.full(k, LAMBDA_INIT), np.full(k, 2.0),
            np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64),
        )  # fmt: skip

    def record(L: _Lanes) -> None:
        """Update best-so-far and solutions from the lanes' current states."""
        order = np.argsort(L.E, kind="stable")[::-1]  # the smallest E is written last
        t = L.tgt[order]
        better = L.E[order] < best_E[t]
        tb, ob = t[better], order[better]
        best_E[tb], best_Q[tb], best_pos[tb], best_ori[tb] = L.E[ob], L.Q[ob], L.pos[ob], L.ori[ob]
        conv = L.ok & ~success[L.tgt]
        if conv.any():
            ci = np.flatnonzero(conv)
            tc, first = np.unique(L.tgt[ci], return_index=True)
            ci = ci[first]
            success[tc] = True
            q_sol[tc], sol_pos[tc], sol_ori[tc] = L.Q[ci], L.pos[ci], L.ori[ci]

    lanes = new_lanes(np.arange(N), seeds.copy()) if N else None
    if lanes is not None:
        record(lanes)
    reason = "done"
    while lanes is not None:
        lanes = lanes.keep(~success[lanes.tgt])
        # top up with random restarts of unsolved targets that still have restarts left
        if lanes.tgt.size < MIN_LANES:
            open_t = np.flatnonzero(~success & (restarts < opts.max_restarts))
            if open_t.size:
                # round-robin over open targets, fewest lanes first
                k = MIN_LANES - lanes.tgt.size
                cand = np.tile(open_t, -(-k // open_t.size))[:k]
                # at most max_restarts per target
                counts = np.bincount(cand, minlength=N)
                allowed = np.minimum(counts, opts.max_restarts - restarts)
                cand = np.repeat(np.arange(N), np.maximum(allowed, 0))
                if cand.size:
                    np.add.at(restarts, cand, 1)
                    Qn = rng.uniform(lo[cand], hi[cand])
                    fresh = new_lanes(cand, Qn)
                    record(fresh)
                    lanes = _Lanes.concat(lanes, fresh).keep(~success[np.r_[lanes.tgt, cand]])
        if lanes.tgt.size == 0:
            if not success.all():
                reason = "max_restarts reached"
            break
        if time.perf_counter() > deadline:
            reason = "timeout"
            break
        dq, predicted = _lm_steps(lanes.J, lanes.e * prob.sw, lanes.lam, eye)
        # active set: freeze joints at a limit that the step pushes outwards (and that a whole
        # turn would not bring back inside), then re-solve
        blocked = ((dq < 0.0) & (lanes.Q <= lower)) | ((dq > 0.0) & (lanes.Q >= upper))
        if blocked.any():
            turned = into_limits_batch(lanes.Q + dq, lower, upper, periodic)
            blocked &= (turned <= lower) | (turned >= upper)
        rows = np.flatnonzero(blocked.any(axis=1))
        if rows.size:
            Jf = lanes.J[rows] * (~blocked[rows])[:, None, :]
            r_rows = lanes.e[rows] * prob.sw
            dq[rows], predicted[rows] = _lm_steps(Jf, r_rows, lanes.lam[rows], eye)
        big = np.abs(dq).max(axis=1)
        scale = np.where(big > MAX_STEP, MAX_STEP / np.where(big > 0, big, 1.0), 1.0)
        dq *= scale[:, None]
        predicted *= scale
        Q_try = into_limits_batch(lanes.Q + dq, lower, upper, periodic)
        ok_rows = np.all(np.isfinite(Q_try), axis=1)
        Q_try = np.where(ok_rows[:, None], Q_try, lanes.Q)  # non-finite step: stay, reject
        E_t, e_t, pos_t, ori_t, ok_t, J_t = prob.evaluate(Q_try, lanes.tgt)
        E_a = lanes.E
        acc = ok_rows & (E_t < E_a)  # NaN compares False: rejected
        np.add.at(iterations, lanes.tgt, 1)
        lanes.it += 1
        # Nielsen's damping update on accepted lanes; λ ← ν λ, ν ← 2ν on rejected ones
        rho = np.where(predicted > 0, (E_a - E_t) / np.where(predicted > 0, predicted, 1.0), 0.0)
        factor = np.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
        slow = acc & (E_a - E_t < STALL_FRACTION * E_a)
        lanes.stall = np.where(slow, lanes.stall + 1, np.where(acc, 0, lanes.stall))
        lanes.lam = np.where(acc, np.maximum(lanes.lam * factor, LAMBDA_MIN), lanes.lam * lanes.nu)
        lanes.nu = np.where(acc, 2.0, lanes.nu * 2.0)
        lanes.Q[acc], lanes.E[acc], lanes.e[acc] = Q_try[acc], E_t[acc], e_t[acc]
        lanes.pos[acc], lanes.ori[acc], lanes.J[acc] = pos_t[acc], ori_t[acc], J_t[acc]
        lanes.ok[acc] = ok_t[acc]
        record(lanes.keep(acc))
        at_limit = ((lanes.Q <= lower) | (lanes.Q >= upper)) & can_pin
        pinned = at_limit.sum(axis=1) > max(n - m, 0)  # more pinned joints than spare DOF
        lanes.pinned = np.where(acc, np.where(pinned, lanes.pinned + 1, 0), lanes.pinned)
        ended = (lanes.lam > LAMBDA_MAX) | (lanes.it >= opts.max_iterations)
        ended |= (lanes.stall >= STALL_STEPS) | (lanes.pinned >= PINNED_STEPS)
        lanes = lanes.keep(~ended)

    q_out = np.where(success[:, None], q_sol, best_Q)
    # periodic joints: the whole-turn equivalent within limits closest to the seed
    q_out = nearest_equivalent_batch(q_out, seeds, lower, upper, periodic)
    return BatchOutcome(
        q=q_out,
        success=success,
        position_error=np.where(success, sol_pos, best_pos),
        orientation_error=np.where(success, sol_ori, best_ori),
        iterations=iterations,
        restarts=restarts,
        stop_reason=reason,
    )
