"""Vectorised Levenberg–Marquardt IK for N targets in lock-step (algorithm: see `ik`'s docstring).

Every iteration evaluates FK and the body Jacobian of all still-active targets with the chain's
batched NumPy kernel, solves the (k, m, m) damped normal equations with one batched
`np.linalg.solve`, and accepts or rejects each target's step on its own. Targets whose attempt is
stuck or out of iterations restart from random configurations together.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from . import se3, so3
from ._ik_single import LAMBDA_DOWN, LAMBDA_INIT, LAMBDA_MAX, LAMBDA_MIN, LAMBDA_UP

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
        self.coupled = not self.position_only and bool(np.all(w > 0))
        self.w = w[3:] if self.position_only else w
        self.sw = np.sqrt(self.w)
        self.pos_mask = (w[3:] > 0).astype(np.float64)
        self.ori_mask = (w[:3] > 0).astype(np.float64)
        self.all_ori = bool(np.all(w[:3] > 0))

    def evaluate(
        self, Q: FloatArray, idx: NDArray[np.intp]
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """At Q (k, n) for targets idx: E, e (k, m), pos [m], ori [rad], W^½J (k, m, n)."""
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
        E = np.einsum("km,m->k", e * e, self.w)
        pos = np.sqrt(np.einsum("kj,j->k", p_e * p_e, self.pos_mask))
        if self.position_only:
            ori = np.zeros(Q.shape[0])
        elif self.all_ori:
            ori = np.linalg.norm(phi, axis=1)
        else:
            ori = np.sqrt(np.einsum("kj,j->k", phi * phi, self.ori_mask))
        return E, e, pos, ori, J * self.sw[None, :, None]


def solve_batch_arrays(
    chain: SerialChain, T: FloatArray, seeds: FloatArray, opts: IKOptions, deadline: float
) -> BatchOutcome:
    """Solve all targets (inputs already validated); see `ik.solve_batch`."""
    N, n = seeds.shape
    prob = _BatchProblem(chain, T, opts)
    lower, upper = np.asarray(chain.lower), np.asarray(chain.upper)
    finite = np.isfinite(lower) & np.isfinite(upper)
    lo = np.where(finite, lower, np.maximum(lower, seeds - math.pi))
    hi = np.where(finite, upper, np.minimum(upper, seeds + math.pi))
    rng = np.random.default_rng(opts.rng_seed)
    tol_p, tol_o = opts.position_tolerance, opts.orientation_tolerance

    Q = seeds.copy()
    all_idx = np.arange(N)
    E, e, pos, ori, J = prob.evaluate(Q, all_idx) if N else (np.zeros(0),) * 5
    success = (pos <= tol_p) & (ori <= tol_o)
    best_E, best_Q, best_pos, best_ori = E.copy(), Q.copy(), pos.copy(), ori.copy()
    lam = np.full(N, LAMBDA_INIT)
    it_attempt = np.zeros(N, dtype=np.int64)
    iterations = np.zeros(N, dtype=np.int64)
    restarts = np.zeros(N, dtype=np.int64)
    exhausted = np.zeros(N, dtype=bool)
    reason = ""
    m = e.shape[1] if N else 6
    eye = np.eye(m)

    while True:
        active = ~success & ~exhausted
        if not active.any():
            reason = "max_restarts reached" if exhausted.any() else "done"
            break
        if time.perf_counter() > deadline:
            reason = "timeout"
            break
        idx = np.flatnonzero(active)
        Ja = J[idx]
        JaT = np.swapaxes(Ja, 1, 2)
        A = Ja @ JaT + lam[idx, None, None] * eye
        r = e[idx] * prob.sw
        try:
            y = np.linalg.solve(A, r[:, :, None])
        except np.linalg.LinAlgError:  # an exactly singular member: least squares for all
            y = np.linalg.pinv(A) @ r[:, :, None]
        Q_try = np.clip(Q[idx] + (JaT @ y)[:, :, 0], lower, upper)
        ok_rows = np.all(np.isfinite(Q_try), axis=1)
        Q_try = np.where(ok_rows[:, None], Q_try, Q[idx])  # non-finite step: stay (and reject)
        E_t, e_t, pos_t, ori_t, J_t = prob.evaluate(Q_try, idx)
        acc = ok_rows & (E_t < E[idx])  # NaN compares False: rejected
        iterations[idx] += 1
        it_attempt[idx] += 1
        ai = idx[acc]
        Q[ai], E[ai], e[ai], pos[ai], ori[ai], J[ai] = (
            Q_try[acc],
            E_t[acc],
            e_t[acc],
            pos_t[acc],
            ori_t[acc],
            J_t[acc],
        )
        lam[ai] = np.maximum(lam[ai] * LAMBDA_DOWN, LAMBDA_MIN)
        lam[idx[~acc]] *= LAMBDA_UP
        better = ai[E[ai] < best_E[ai]]
        best_E[better], best_Q[better] = E[better], Q[better]
        best_pos[better], best_ori[better] = pos[better], ori[better]
        success[ai] = (pos[ai] <= tol_p) & (ori[ai] <= tol_o)

        stuck = idx[
            ~success[idx] & ((lam[idx] > LAMBDA_MAX) | (it_attempt[idx] >= opts.max_iterations))
        ]
        if stuck.size:
            out_of_restarts = restarts[stuck] >= opts.max_restarts
            exhausted[stuck[out_of_restarts]] = True
            s = stuck[~out_of_restarts]
            if s.size:
                Q[s] = rng.uniform(lo[s], hi[s])
                E[s], e[s], pos[s], ori[s], J[s] = prob.evaluate(Q[s], s)
                lam[s] = LAMBDA_INIT
                it_attempt[s] = 0
                restarts[s] += 1
                success[s] = (pos[s] <= tol_p) & (ori[s] <= tol_o)
                better = s[E[s] < best_E[s]]
                best_E[better], best_Q[better] = E[better], Q[better]
                best_pos[better], best_ori[better] = pos[better], ori[better]

    q_out = np.where(success[:, None], Q, best_Q)
    # continuous joints: wrap to within π of the seed
    cont = np.asarray(chain.continuous)
    if cont.any():
        d = (q_out[:, cont] - seeds[:, cont] + math.pi) % (2.0 * math.pi) - math.pi
        q_out[:, cont] = seeds[:, cont] + d
    return BatchOutcome(
        q=q_out,
        success=success,
        position_error=np.where(success, pos, best_pos),
        orientation_error=np.where(success, ori, best_ori),
        iterations=iterations,
        restarts=restarts,
        stop_reason=reason,
    )
