"""Single-target Levenberg–Marquardt IK on plain Python floats (algorithm: `ik`'s docstring).

Why plain floats: one 6- or 7-joint iteration is a few hundred flops, so NumPy's ~1 µs per-call
overhead would dominate. Forward kinematics with the world Jacobian's columns (or the joint axes,
for weighted and position-only errors) comes from the chain's generated scalar kernel
(`Kernel.fk_world` / `Kernel.fk_axes`; inputs validated once at the boundary in `ik.solve`), the
pose error from `_pose_error` (scalar SE(3)/SO(3) log), and only the m×m damped normal equations
(m = 6, or 3 position-only) go to NumPy/LAPACK. They are symmetric positive definite for λ > 0, so
they are solved by Cholesky with LAPACK's `dposv` called directly through SciPy (~1.3 µs on a 6×6,
against ~4.5 µs for `numpy.linalg.solve`'s generic wrapper, and far less than a Cholesky in
interpreted Python); a failed factorisation is a rejected step.

Random restarts run one after another. Advancing them together as lanes of one vectorised LM on
the one target was measured slower on scara (TRAC-IK protocol, 5 ms; 23 % of targets need a
restart): serial restarts are short (~6 iterations, ~30 µs each) while a lock-step of K lanes costs
~300 µs in NumPy even with a dedicated kernel (`BatchSolver` itself: ~1 ms), so the lanes were
slower on the targets that need them (p95 1.9–2.1 → 3.5–5.9 ms) and missed more deadlines.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg.lapack import dposv

from ..model import TWO_PI
from .joint_space import into_limits, nearest_equivalent, sample_bounds
from .pose_error import relative_pose, se3_log, so3_log
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


def _lm_step(
    Jt: FloatArray, r: FloatArray, lam: float, eye: FloatArray
) -> tuple[list[float], FloatArray | None] | None:
    """Δq = Jᵀ(J Jᵀ + λI)⁻¹ r from Jt = Jᵀ (n × m), as a list, and Jᵀr if it came for free (else
    None); None if the factorisation fails. With fewer joints than error rows (n < m) the same
    step is solved as (JᵀJ + λI) Δq = Jᵀr, n × n, which also gives Jᵀr for the gain ratio.
    `eye` is the identity of the system's size (adding λ·eye is cheaper than updating A's diagonal
    in place)."""
    if eye.shape[0] < Jt.shape[1]:
        g = Jt @ r
        _, dq, info = dposv(Jt @ Jt.T + lam * eye, g)
        return None if info != 0 else (dq.tolist(), g)
    _, y, info = dposv(Jt.T @ Jt + lam * eye, r)
    if info != 0:
        return None
    return (Jt @ y).tolist(), None


@dataclass
class SingleOutcome:
    q: FloatArray
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    restarts: int
    solutions: list[FloatArray] = field(default_factory=list)
    stop_reason: str = ""  # "done", "timeout" or "max_restarts=N reached"


class SingleSolver:
    """State of one IK call (never shared between calls or threads)."""

    def __init__(self, problem: IKProblem, T_target: FloatArray, seed: FloatArray) -> None:
        self.opts = opts = problem.opts
        model = problem.model
        self.internal = model.to_internal
        self.G = model.G
        self.prismatic = model.kernel.prismatic
        R, p = T_target[:3, :3], T_target[:3, 3]
        self.target = tuple(R.ravel().tolist() + p.tolist())
        self.seed: list[float] = seed.tolist()
        c = problem.scalar  # plain-Python constants, shared by the problem's calls: read only
        self.lower, self.upper = c.lower, c.upper
        self.periodic, self.pinnable = c.periodic, c.pinnable
        self.joint_weights = c.joint_weights
        self.spare = problem.spare
        self._sampler: tuple[np.random.Generator, FloatArray, FloatArray] | None = None

        # The error and its weights, as `problem` defines them (plain floats for this solver).
        self.position_only = problem.position_only
        self.coupled = problem.coupled
        self.axis_tol = c.axis_tol
        self.w = c.w
        self.sw = problem.sw
        self.pos_mask, self.ori_mask, self.all_ori = c.pos_mask, c.ori_mask, c.all_ori
        self.tol_p = opts.position_tolerance
        self.tol_o = opts.orientation_tolerance
        # Speed-ups of this solver, chosen once per problem; none changes the step: unit weights,
        # and J and r in base axes (`IKProblem.scalar`).
        self.unit_weights = c.unit_weights
        self.base_axes = c.base_axes
        # Coupled error in base axes: J is the world Jacobian at the tip, which the generated
        # kernel returns directly; otherwise it is assembled from the joint axes.
        world_columns = self.coupled and self.base_axes
        self.fk = model.kernel.fk_world if world_columns else model.kernel.fk_axes
        self.jacobian = self._world_jacobian if world_columns else self._axes_jacobian
        # The default (full pose, unit weights) has its own short evaluation.
        plain = self.coupled and self.unit_weights
        self.evaluate = self._evaluate_plain if plain else self._evaluate_weighted
        self.eye = c.eye  # the damped system's size
        self.iterations = 0
        self.restarts = 0  # over every `run` of this call
        self.best: tuple[float, list[float], float, float] | None = None  # (E, q, pos, ori)

    # ------------------------------------------------------------------ evaluation
    def _evaluate_plain(
        self, q: list[float]
    ) -> tuple[float, list[float], float, float, bool, tuple, list]:  # type: ignore[type-arg]
        """`_evaluate_weighted` for the default problem: full pose, unit weights (E = ‖V_b‖²)."""
        t, axes = self.fk(q if self.internal is None else self.internal(q))
        Te = relative_pose(t, self.target)
        px, py, pz = Te[9], Te[10], Te[11]
        e0, e1, e2, e3, e4, e5, theta = se3_log(Te)
        E = e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3 + e4 * e4 + e5 * e5
        pos = math.sqrt(px * px + py * py + pz * pz)
        ok = pos <= self.tol_p and theta <= self.tol_o
        return E, [e0, e1, e2, e3, e4, e5], pos, theta, ok, t, axes

    def _evaluate_weighted(
        self, q: list[float]
    ) -> tuple[float, list[float], float, float, bool, tuple, list]:  # type: ignore[type-arg]
        """(E = Σ wᵢ eᵢ², e, position error [m], orientation error [rad], within tolerance, pose,
        joint axes or, with the world Jacobian, its columns) at q."""
        t, axes = self.fk(q if self.internal is None else self.internal(q))
        Te = relative_pose(t, self.target)
        px, py, pz = Te[9], Te[10], Te[11]
        if self.coupled:
            e0, e1, e2, e3, e4, e5, theta = se3_log(Te)
            e = [e0, e1, e2, e3, e4, e5]
            phi = e[:3]
        else:
            f0, f1, f2, theta = so3_log(Te)
            phi = [f0, f1, f2]
            e = [px, py, pz] if self.position_only else [f0, f1, f2, px, py, pz]
        if self.axis_tol is not None:  # a component within its bound is met and exerts no pull
            ok = True
            for i, bound in enumerate(self.axis_tol):
                if abs(e[i]) <= bound:
                    e[i] = 0.0
                else:
                    ok = False  # also for NaN
        E = 0.0
        for wi, ei in zip(self.w, e, strict=True):
            E += wi * ei * ei
        pm = self.pos_mask
        pos = math.sqrt(
            (px * px if pm[0] else 0.0) + (py * py if pm[1] else 0.0) + (pz * pz if pm[2] else 0.0)
        )
        if self.position_only:
            ori = 0.0
        elif self.all_ori:
            ori = theta
        else:
            ori = math.sqrt(sum(f * f for f, m in zip(phi, self.ori_mask, strict=True) if m))
        if self.axis_tol is None:
            ok = pos <= self.tol_p and ori <= self.tol_o
        return E, e, pos, ori, ok, t, axes

    def _world_jacobian(self, t: tuple, axes: list) -> FloatArray:  # type: ignore[type-arg]
        """`_axes_jacobian` for the coupled error in base axes: `axes` already holds the world
        Jacobian's columns."""
        Jt = np.array(axes)
        if self.G is not None:
            Jt = self.G.T @ Jt
        return Jt if self.unit_weights else Jt * self.sw

    def _axes_jacobian(self, t: tuple, axes: list) -> FloatArray:  # type: ignore[type-arg]
        """Transposed weighted Jacobian (W^½ J)ᵀ (n × m) of the error (see `ik`), in tip axes or,
        if `base_axes`, in base axes, from each joint's axis and point."""
        r00, r01, r02, r10, r11, r12, r20, r21, r22, cx, cy, cz = t
        if self.coupled:  # body Jacobian: reference point = tip origin
            qx, qy, qz = cx, cy, cz
        else:  # body Jacobian of the target point rigidly attached to the tip
            qx, qy, qz = self.target[9], self.target[10], self.target[11]
        cols: list[tuple[float, ...]] = []
        position_only, base_axes = self.position_only, self.base_axes
        for (zx, zy, zz, ox, oy, oz), prism in zip(axes, self.prismatic, strict=True):
            if prism:
                wx = wy = wz = 0.0
                vx, vy, vz = zx, zy, zz
            else:
                wx, wy, wz = zx, zy, zz
                dx, dy, dz = qx - ox, qy - oy, qz - oz
                vx, vy, vz = zy * dz - zz * dy, zz * dx - zx * dz, zx * dy - zy * dx
            if base_axes:
                cols.append((vx, vy, vz) if position_only else (wx, wy, wz, vx, vy, vz))
                continue
            # rotate into tip axes: Rᵀ x
            vb = (
                r00 * vx + r10 * vy + r20 * vz,
                r01 * vx + r11 * vy + r21 * vz,
                r02 * vx + r12 * vy + r22 * vz,
            )
            if position_only:
                cols.append(vb)
            else:
                cols.append(
                    (
                        r00 * wx + r10 * wy + r20 * wz,
                        r01 * wx + r11 * wy + r21 * wz,
                        r02 * wx + r12 * wy + r22 * wz,
                    )
                    + vb
                )
        Jt = np.array(cols)
        if self.G is not None:  # internal joints → actuated variables (mimic joints)
            Jt = self.G.T @ Jt
        return Jt if self.unit_weights else Jt * self.sw

    def residual(self, e: list[float], t: tuple) -> FloatArray:  # type: ignore[type-arg]
        """r = W^½ e, in the axes of `jacobian` (tip-frame e rotated by R if `base_axes`)."""
        if self.base_axes:
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = t[:9]
            rot: list[float] = []
            for k in range(0, len(e), 3):
                x, y, z = e[k], e[k + 1], e[k + 2]
                rot += (
                    r00 * x + r01 * y + r02 * z,
                    r10 * x + r11 * y + r12 * z,
                    r20 * x + r21 * y + r22 * z,
                )
            e = rot
        return np.array(e) if self.unit_weights else self.sw * np.array(e)

    # ------------------------------------------------------------------ one attempt
    def attempt(self, q: list[float], deadline: float) -> tuple[bool, list[float], float, float]:
        """LM from q until converged, stuck, out of iterations or past the deadline."""
        E, e, pos, ori, ok, t, axes = self.evaluate(q)
        self._offer(E, q, pos, ori)
        if ok:
            return True, q, pos, ori
        Jt = self.jacobian(t, axes)
        lam = LAMBDA_INIT
        nu = 2.0
        stall = 0
        pinned_run = 0
        spare = self.spare  # redundant degrees of freedom
        lower, upper, periodic, pinnable = self.lower, self.upper, self.periodic, self.pinnable
        edge = [i for i, v in enumerate(q) if v <= lower[i] or v >= upper[i]]  # joints at a limit
        eye = self.eye
        small = eye.shape[0] < Jt.shape[1]  # fewer joints than error rows: the n × n system
        perf = time.perf_counter
        for _ in range(self.opts.max_iterations):
            if perf() > deadline:
                break
            self.iterations += 1
            r = self.residual(e, t)
            Ju = Jt  # the Jacobian the step was computed with
            # `_lm_step`, inlined (this is the hot path)
            if small:
                g_arr: FloatArray | None = Jt @ r
                _, x, info = dposv(Jt @ Jt.T + lam * eye, g_arr)
                step = None if info != 0 else (x.tolist(), g_arr)
            else:
                _, x, info = dposv(Jt.T @ Jt + lam * eye, r)
                step = None if info != 0 else ((Jt @ x).tolist(), None)
            if step is not None and edge:
                # Joints at a limit that the step pushes outwards are frozen (their rows of Jᵀ
                # zeroed) and the step is recomputed, so the other joints compensate. A periodic
                # joint is not blocked if a whole turn takes it back inside.
                dq = step[0]
                blocked = [
                    i
                    for i in edge
                    if ((dq[i] < 0.0 and q[i] <= lower[i]) or (dq[i] > 0.0 and q[i] >= upper[i]))
                    and into_limits(q[i] + dq[i], lower[i], upper[i], periodic[i])
                    in (lower[i], upper[i])
                ]
                if blocked:
                    Ju = Jt.copy()
                    Ju[blocked] = 0.0
                    step = _lm_step(Ju, r, lam, eye)
            if step is not None:
                dq, g_arr = step
                big = max(map(abs, dq))
                if big > MAX_STEP:
                    dq = [d * (MAX_STEP / big) for d in dq]
                q_try = []
                edge_try = []
                for i, (a, d) in enumerate(zip(q, dq, strict=True)):
                    v = a + d
                    if v <= lower[i] or v >= upper[i]:
                        v = into_limits(v, lower[i], upper[i], periodic[i])
                        if v <= lower[i] or v >= upper[i]:
                            edge_try.append(i)
                    q_try.append(v)
                E_try, e_try, pos_t, ori_t, ok, t_try, axes_try = self.evaluate(q_try)
                if E_try < E:  # False for NaN: a non-finite trial is rejected
                    # gain ratio ρ = actual / predicted decrease, predicted = Δqᵀ(λΔq + Jᵀr)
                    g = (Ju @ r if g_arr is None else g_arr).tolist()
                    predicted = sum([d * (lam * d + gi) for d, gi in zip(dq, g, strict=True)])
                    rho = (E - E_try) / predicted if predicted > 0.0 else 0.0
                    stall = stall + 1 if E - E_try < STALL_FRACTION * E else 0
                    q, E, e, pos, ori, t, edge = q_try, E_try, e_try, pos_t, ori_t, t_try, edge_try
                    self._offer(E, q, pos, ori)
                    if ok:
                        return True, q, pos, ori
                    if stall >= STALL_STEPS:
                        break
                    pinned = sum([pinnable[i] for i in edge])
                    pinned_run = pinned_run + 1 if pinned > spare else 0
                    if pinned_run >= PINNED_STEPS:
                        break
                    Jt = self.jacobian(t_try, axes_try)
                    # Nielsen's update (Madsen, Nielsen & Tingleff, "Methods for non-linear least
                    # squares problems", 2004, §3.2)
                    lam = max(lam * max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), LAMBDA_MIN)
                    nu = 2.0
                    continue
            lam *= nu
            nu *= 2.0
            if lam > LAMBDA_MAX:
                break
        return False, q, pos, ori

    def _random_start(self) -> list[float]:
        """A configuration drawn uniformly within the limits (unbounded sides: seed ± π)."""
        if self._sampler is None:  # built on the first restart: most calls never need it
            lo, hi = sample_bounds(np.array(self.lower), np.array(self.upper), np.array(self.seed))
            self._sampler = (np.random.default_rng(self.opts.rng_seed), lo, hi)
        rng, lo_a, hi_a = self._sampler
        q: list[float] = rng.uniform(lo_a, hi_a).tolist()
        return q

    def _offer(self, E: float, q: list[float], pos: float, ori: float) -> None:
        if self.best is None or E < self.best[0]:
            self.best = (E, q, pos, ori)

    def _nearest_seed(self, q: list[float]) -> list[float]:
        """Each periodic joint turned by whole turns to the value closest to the seed in limits."""
        return [
            nearest_equivalent(v, s, lo, hi, per)
            for v, s, lo, hi, per in zip(
                q, self.seed, self.lower, self.upper, self.periodic, strict=True
            )
        ]

    def _distance(self, q: list[float]) -> float:
        return math.sqrt(
            sum(w * (a - s) ** 2 for a, s, w in zip(q, self.seed, self.joint_weights, strict=True))
        )

    def _same(self, a: list[float], b: list[float]) -> bool:
        sep = self.opts.solution_separation
        for x, y, c in zip(a, b, self.periodic, strict=True):
            d = abs(x - y)
            if c:
                d %= TWO_PI
                d = min(d, TWO_PI - d)
            if d > sep:
                return False
        return True

    def _found(
        self,
        found: list[tuple[float, list[float], float, float]],
        q: list[float],
        pos: float,
        ori: float,
    ) -> None:
        """Add solution q to `found` ((distance, q, pos, ori) each), or, if it is the same as one
        there (`_same`), keep the nearer of the two. A q the same as two or more members (they
        are distinct, but q lies between them) is left out: in place of either it would be the
        same as the other, and the set would no longer be distinct (a free axis's samples, 9 mrad
        apart, were both returned)."""
        d = self._distance(q)
        same = [i for i, (_, q_old, _, _) in enumerate(found) if self._same(q, q_old)]
        if not same:
            found.append((d, q, pos, ori))
        elif len(same) == 1 and d < found[same[0]][0]:
            found[same[0]] = (d, q, pos, ori)

    # ------------------------------------------------------------------ restarts
    def run(
        self, deadline: float, known: Sequence[tuple[ArrayLike, float, float]] = ()
    ) -> SingleOutcome:
        """Attempts from the seed, then from random restarts, until `num_solutions` are found
        (mode "speed"), or until the deadline or `max_restarts` (mode "distance").

        `known`: solutions found already, as (q (n,), position error [m], orientation error
        [rad]); they count as found by the search (so a single-solution request's closed-form
        answer takes part in the ranking of a set). Called again (after the closed form had its
        turn), the search goes on where it stopped: the next restarts of its random stream, not
        the seed and the same restarts again (with `rng_seed` set they would repeat exactly)."""
        opts = self.opts
        found: list[tuple[float, list[float], float, float]] = []  # (distance, q, pos, ori)
        want = opts.num_solutions
        distance_mode = opts.mode == "distance"
        for q_known, pos_known, ori_known in known:
            self._found(
                found, self._nearest_seed(np.asarray(q_known).tolist()), pos_known, ori_known
            )
        restarts = self.restarts
        reason = f"max_restarts={opts.max_restarts} reached"
        q0: list[float] | None = None
        if self.best is None:  # the first run (its first attempt evaluates the seed)
            q0 = list(self.seed)
        elif restarts < opts.max_restarts:  # run again: the search's next restart
            restarts += 1
            q0 = self._random_start()
        while q0 is not None:
            ok, q, pos, ori = self.attempt(q0, deadline)
            if ok:
                self._found(found, self._nearest_seed(q), pos, ori)
                if not distance_mode and len(found) >= want:
                    reason = "done"
                    break
            if time.perf_counter() > deadline:
                reason = "timeout"
                break
            if restarts >= opts.max_restarts:
                reason = f"max_restarts={opts.max_restarts} reached"
                break
            restarts += 1
            q0 = self._random_start()
        self.restarts = restarts
        if found:
            found.sort(key=lambda s: s[0])
            found = found[:want]
            _, q, pos, ori = found[0]
            return SingleOutcome(
                q=np.array(q),
                success=True,
                position_error=pos,
                orientation_error=ori,
                iterations=self.iterations,
                restarts=restarts,
                solutions=[np.array(s[1]) for s in found],
                stop_reason=reason,
            )
        assert self.best is not None  # the first attempt always evaluates the seed
        _, q, pos, ori = self.best
        return SingleOutcome(
            q=np.array(self._nearest_seed(q)),
            success=False,
            position_error=pos,
            orientation_error=ori,
            iterations=self.iterations,
            restarts=restarts,
            stop_reason=reason,
        )
