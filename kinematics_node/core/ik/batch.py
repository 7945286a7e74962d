"""Vectorised Levenberg–Marquardt IK for N targets in lock-step (algorithm: see `ik`'s docstring).

Every iteration evaluates FK and the body Jacobian of all still-active targets with the chain's
batched NumPy kernel, solves the (k, m, m) damped normal equations with one batched
`np.linalg.solve`, and accepts or rejects each target's step on its own. Targets whose attempt is
stuck or out of iterations restart from random configurations together.

Work is organised in *lanes*: one lane = one attempt for one target. At first there is one lane per
target (starting at its seed). When fewer than `min_lanes` lanes (256; 384 in a batch of 640
targets or more) are still running, unsolved targets get extra lanes from random configurations,
so the slow tail of hard targets runs several restarts in parallel instead of one after another at
a high per-iteration overhead. A target is solved by its first converged lane; its other lanes are
dropped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .joint_space import into_limits_batch, nearest_equivalent_batch, sample_bounds
from .problem import (
    LAMBDA_INIT,
    LAMBDA_MAX,
    LAMBDA_MIN,
    MAX_STEP,
    PINNED_STEPS,
    STALL_FRACTION,
    STALL_STEPS,
    IKProblem,
)

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


def _lm_steps(
    J: FloatArray, r: FloatArray, lam: FloatArray, eye: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Batched Δq = Jᵀ(J Jᵀ + λI)⁻¹ r (k, n) and the predicted decrease Δqᵀ(λΔq + Jᵀr) (k,).
    With fewer joints than error rows (n < m), the same step as (JᵀJ + λI)Δq = Jᵀr, n × n; `eye`
    is the identity of the system's size."""
    JT = np.swapaxes(J, 1, 2)
    g = (JT @ r[:, :, None])[:, :, 0]
    small = eye.shape[0] < J.shape[1]
    A = (JT @ J if small else J @ JT) + lam[:, None, None] * eye
    rhs = g if small else r
    try:
        y = np.linalg.solve(A, rhs[:, :, None])
    except np.linalg.LinAlgError:  # an exactly singular member: least squares for all
        y = np.linalg.pinv(A) @ rhs[:, :, None]
    dq = np.asarray(y[:, :, 0] if small else (JT @ y)[:, :, 0], dtype=np.float64)
    predicted = np.einsum("kn,kn->k", dq, lam[:, None] * dq + g)
    return dq, predicted


MIN_LANES = 256  # top up the running attempts to this many while targets remain unsolved ...
MIN_LANES_LARGE = 384  # ... and to this many in a batch of at least LARGE_BATCH targets
LARGE_BATCH = 640


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


class BatchSolver:
    """State of one `ik_batch` call: the lanes, and per target the best and the solved state."""

    def __init__(self, problem: IKProblem, T: FloatArray, seeds: FloatArray) -> None:
        self.problem = problem
        self.R_t, self.p_t = T[:, :3, :3], T[:, :3, 3]
        self.seeds = seeds
        N = seeds.shape[0]
        self.min_lanes = MIN_LANES_LARGE if N >= LARGE_BATCH else MIN_LANES
        self.lo, self.hi = sample_bounds(problem.lower, problem.upper, seeds)
        self.rng = np.random.default_rng(problem.opts.rng_seed)
        self.eye = np.eye(min(problem.m, seeds.shape[1]))  # the damped system's size
        self.success = np.zeros(N, dtype=bool)
        self.q_sol = seeds.copy()
        self.sol_pos, self.sol_ori = np.full(N, np.inf), np.full(N, np.inf)
        self.best_E, self.best_Q = np.full(N, np.inf), seeds.copy()
        self.best_pos, self.best_ori = np.full(N, np.inf), np.full(N, np.inf)
        self.iterations = np.zeros(N, dtype=np.int64)
        self.restarts = np.zeros(N, dtype=np.int64)

    def run(self, deadline: float) -> BatchOutcome:
        """Iterate all lanes in lock-step until every target is solved, out of restarts, or the
        deadline passes."""
        N = self.seeds.shape[0]
        lanes = self._new_lanes(np.arange(N), self.seeds.copy()) if N else None
        reason = "done"
        while lanes is not None and not self.success.all():
            if time.perf_counter() > deadline:  # before the restarts' lanes: they cost ~3 ms
                reason = "timeout"
                break
            lanes = self._top_up(lanes.keep(~self.success[lanes.tgt]))
            if lanes.tgt.size == 0:
                reason = "max_restarts reached"
                break
            lanes = self._step(lanes)
        return self._outcome(reason)

    def _new_lanes(self, tgt: NDArray[np.intp], Q: FloatArray) -> _Lanes:
        """Lanes starting at Q (k, n) for targets tgt, evaluated and recorded."""
        E, e, pos, ori, ok, J = self.problem.evaluate_batch(Q, self.R_t[tgt], self.p_t[tgt])
        k = tgt.size
        lanes = _Lanes(
            tgt, Q, E, e, pos, ori, ok, J, np.full(k, LAMBDA_INIT), np.full(k, 2.0),
            np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64),
        )  # fmt: skip
        self._record(lanes)
        return lanes

    def _top_up(self, lanes: _Lanes) -> _Lanes:
        """Add random-restart lanes for unsolved targets with restarts left, up to `min_lanes`
        lanes: round-robin over those targets in index order, at most `max_restarts` each."""
        if lanes.tgt.size >= self.min_lanes:
            return lanes
        max_restarts = self.problem.opts.max_restarts
        open_t = np.flatnonzero(~self.success & (self.restarts < max_restarts))
        if not open_t.size:
            return lanes
        k = self.min_lanes - lanes.tgt.size
        cand = np.tile(open_t, -(-k // open_t.size))[:k]
        counts = np.bincount(cand, minlength=self.seeds.shape[0])
        allowed = np.minimum(counts, max_restarts - self.restarts)
        cand = np.repeat(np.arange(self.seeds.shape[0]), np.maximum(allowed, 0))
        if not cand.size:
            return lanes
        np.add.at(self.restarts, cand, 1)
        fresh = self._new_lanes(cand, self.rng.uniform(self.lo[cand], self.hi[cand]))
        return _Lanes.concat(lanes, fresh).keep(~self.success[np.r_[lanes.tgt, cand]])

    def _record(self, L: _Lanes) -> None:
        """Update best-so-far and solutions from the lanes' current states."""
        order = np.argsort(L.E, kind="stable")[::-1]  # the smallest E is written last
        t = L.tgt[order]
        better = L.E[order] < self.best_E[t]
        tb, ob = t[better], order[better]
        self.best_E[tb], self.best_Q[tb] = L.E[ob], L.Q[ob]
        self.best_pos[tb], self.best_ori[tb] = L.pos[ob], L.ori[ob]
        conv = L.ok & ~self.success[L.tgt]
        if conv.any():
            ci = np.flatnonzero(conv)
            tc, first = np.unique(L.tgt[ci], return_index=True)
            ci = ci[first]
            self.success[tc] = True
            self.q_sol[tc], self.sol_pos[tc], self.sol_ori[tc] = L.Q[ci], L.pos[ci], L.ori[ci]

    def _step(self, lanes: _Lanes) -> _Lanes:
        """One LM iteration of every lane (algorithm: `ik`'s docstring); returns the lanes whose
        attempt goes on."""
        prob, eye = self.problem, self.eye
        lower, upper, periodic = prob.lower, prob.upper, prob.periodic
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
        E_t, e_t, pos_t, ori_t, ok_t, J_t = prob.evaluate_batch(
            Q_try, self.R_t[lanes.tgt], self.p_t[lanes.tgt]
        )
        E_a = lanes.E
        acc = ok_rows & (E_t < E_a)  # NaN compares False: rejected
        np.add.at(self.iterations, lanes.tgt, 1)
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
        self._record(lanes.keep(acc))
        at_limit = ((lanes.Q <= lower) | (lanes.Q >= upper)) & prob.pinnable
        pinned = at_limit.sum(axis=1) > prob.spare  # more pinned joints than spare DOF
        lanes.pinned = np.where(acc, np.where(pinned, lanes.pinned + 1, 0), lanes.pinned)
        ended = (lanes.lam > LAMBDA_MAX) | (lanes.it >= prob.opts.max_iterations)
        ended |= (lanes.stall >= STALL_STEPS) | (lanes.pinned >= PINNED_STEPS)
        return lanes.keep(~ended)

    def _outcome(self, reason: str) -> BatchOutcome:
        success = self.success
        q_out = np.where(success[:, None], self.q_sol, self.best_Q)
        # periodic joints: the whole-turn equivalent within limits closest to the seed
        prob = self.problem
        q_out = nearest_equivalent_batch(q_out, self.seeds, prob.lower, prob.upper, prob.periodic)
        return BatchOutcome(
            q=q_out,
            success=success,
            position_error=np.where(success, self.sol_pos, self.best_pos),
            orientation_error=np.where(success, self.sol_ori, self.best_ori),
            iterations=self.iterations,
            restarts=self.restarts,
            stop_reason=reason,
        )
