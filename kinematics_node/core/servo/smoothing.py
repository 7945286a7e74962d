"""Jerk-limited joint motion toward a target velocity, one period at a time, with Ruckig.

Ruckig (Berscheid & Kröger 2021, "Jerk-limited real-time trajectory generation with arbitrary
target states"; `pip install ruckig`, the smoothing moveit_servo offers too) plans, from the last
commanded state (q, q̇, q̈), the time-optimal motion to a target velocity within the velocity,
acceleration and jerk limits, and the servo takes its first period. The commanded trajectory is
therefore continuous in acceleration with bounded jerk, so its samples' finite differences stay
within the limits too. Phase synchronisation moves all joints' velocities along one straight line
in joint space, so a change of speed does not bend the tool's path.

Ruckig's velocity interface does not know position limits, so each period is checked here: from
the new state, each joint's time-optimal braking motion (`limits.braking_reach`, in closed form)
must stay inside [lower, upper] (or not reach further out than the braking motion from the previous
state, for a joint that starts outside).
A joint that would break this brakes instead, from the previous state, along that braking motion;
it then stops inside the bound. The servo's velocity planning (`limits.braking_speed`) slows the
joints before this guard has to act, so it only catches what the planning could not foresee.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..exceptions import KinematicsError
from .limits import ServoLimits, braking_reach_one

FloatArray = NDArray[np.float64]

try:  # an optional dependency: kinematics_service[servo]
    import ruckig as _ruckig
except ImportError:  # pragma: no cover - exercised where ruckig is missing
    _ruckig = None

_TOL = 1e-9  # [rad or m] slack on the position checks (rounding of Ruckig's profiles)


def _frozen(values: Any) -> FloatArray:
    """A read-only float64 array of `values` (the integrator's states are never written to, so
    they can be handed out without copies)."""
    arr = np.array(values, dtype=np.float64)
    arr.setflags(write=False)
    return arr


class MissingDependencyError(KinematicsError, ImportError):
    """A feature needs a package that is not installed; the message says which and how."""


def ruckig_available() -> bool:
    """True if the `ruckig` package can be imported."""
    return _ruckig is not None


class JerkLimitedIntegrator:
    """The commanded joint state (q, q̇, q̈) of the servo, advanced one period per `step`.

    Mutable on purpose: it is the servo's memory between periods. Not thread-safe.

    The state is kept twice: as read-only arrays (`q`, `v`, `a`, handed out without copies) and
    as lists of floats (`q_list`, `v_list`, `a_list`) for the per-joint arithmetic of a period,
    which on 6 or 7 joints costs less in plain Python than in NumPy calls (each ~1 µs).
    """

    def __init__(self, limits: ServoLimits, period_s: float, positions: FloatArray) -> None:
        if _ruckig is None:
            raise MissingDependencyError(
                "the servo's jerk-limited smoothing needs Ruckig: pip install ruckig "
                "(or pip install 'kinematics_service[servo]')"
            )
        n = len(limits.joint_names)
        self.limits = limits
        self.period_s = period_s
        self._n = n
        self._otg: Any = _ruckig.Ruckig(n, period_s)
        self._inp: Any = self._make_input()
        self._out: Any = _ruckig.OutputParameter(n)
        self._phase = _ruckig.Synchronization.Phase
        self._unsynchronised = _ruckig.Synchronization.No
        self._good_results = (_ruckig.Result.Working, _ruckig.Result.Finished)
        # An upper bound on the braking distance from any state within the limits: the speed
        # never exceeds v_max + A²/(2J) while braking, which lasts at most 3A/J + that speed / A.
        A, J = limits.acceleration, limits.jerk
        top = limits.velocity + A * A / (2 * J)
        zone = top * (3 * A / J + top / A) + 1e-6
        # Per-joint constants as lists of floats (see the class docstring).
        self._near_low: list[float] = (limits.lower + zone).tolist()  # at or beyond these a
        self._near_high: list[float] = (limits.upper - zone).tolist()  # joint may reach a bound
        self._lower: list[float] = limits.lower.tolist()
        self._upper: list[float] = limits.upper.tolist()
        self._acc: list[float] = A.tolist()
        self._jerk: list[float] = J.tolist()
        self._v_high: list[float] = limits.velocity.tolist()
        self._v_low: list[float] = (-limits.velocity).tolist()
        self._v_tolerated: list[float] = (limits.velocity * (1 + 1e-12)).tolist()
        self._acc_high: list[float] = (0.9 * A).tolist()
        self._acc_low: list[float] = (-0.9 * A).tolist()
        self._half_inv_jerk: list[float] = (0.5 / J).tolist()
        self._half_inv_acc: list[float] = (0.5 / A).tolist()
        self._half_acc_over_jerk: list[float] = (0.5 * A / J).tolist()
        # per joint, for `_reach`: (near_low, near_high, 1/(2J), 1/(2A), A/(2J), J, lower, upper, A)
        self._reach_constants = list(
            zip(
                self._near_low,
                self._near_high,
                self._half_inv_jerk,
                self._half_inv_acc,
                self._half_acc_over_jerk,
                self._jerk,
                self._lower,
                self._upper,
                self._acc,
                strict=True,
            )
        )
        self._zeros = _frozen(np.zeros(n))
        self._zero_list = [0.0] * n
        self.reset(positions)

    def _make_input(self) -> Any:
        assert _ruckig is not None
        inp = _ruckig.InputParameter(self._n)
        inp.control_interface = _ruckig.ControlInterface.Velocity
        inp.synchronization = _ruckig.Synchronization.Phase
        inp.max_velocity = self.limits.velocity.tolist()
        inp.max_acceleration = self.limits.acceleration.tolist()
        inp.max_jerk = self.limits.jerk.tolist()
        inp.target_velocity = [0.0] * self._n
        inp.target_acceleration = [0.0] * self._n
        return inp

    def reset(self, positions: FloatArray) -> None:
        """At rest at `positions` (no velocity, no acceleration)."""
        # The commanded state (read-only arrays, replaced each period, never written to).
        self.q = _frozen(positions)
        self.v = self._zeros
        self.a = self._zeros
        self.q_list: list[float] = self.q.tolist()
        self.v_list: list[float] = self._zero_list
        self.a_list: list[float] = self._zero_list
        self.at_rest = True
        self._reach_lo = self.q_list  # extent of the braking motion from the current state
        self._reach_hi = self.q_list

    def step(
        self,
        target_velocity: Sequence[float],
        target_acceleration: Sequence[float] | None = None,
    ) -> list[bool] | None:
        """Advance one period toward `target_velocity` (n,) [rad/s or m/s], arriving there with
        `target_acceleration` (n,) [rad/s² or m/s²] (default 0): a target that moves at a steady
        rate is then followed without lag. Returns which joints the position guard made brake
        (their targets become 0), or None when none did.

        Two guards check the planned period, joint by joint, and re-plan a joint on its own
        (unsynchronised, time-optimal, as Ruckig guarantees its limits for one joint alone):
        * velocity: Ruckig's velocity interface bounds acceleration and jerk, not velocity, so the
          speed the joint would reach by bringing its acceleration to zero at full jerk,
          |v + a|a|/(2J)|, must stay within the velocity limit; a joint that would pass it heads
          for its (clipped) target with no target acceleration instead;
        * position: see the module docstring; a joint that would pass it brakes to a stop.
        """
        n = self._n
        v_high, v_low = self._v_high, self._v_low
        if target_acceleration is None:
            target = [
                lo if x < lo else hi if x > hi else x
                for x, lo, hi in zip(target_velocity, v_low, v_high, strict=True)
            ]
            acc = self._zero_list
        else:
            # The acceleration within the limit, and none where the velocity limit would be
            # passed before it could return to zero (Ruckig could not reach such a target state).
            target, acc = [], []
            for x, y, lo, hi, a_lo, a_hi, h in zip(
                target_velocity,
                target_acceleration,
                v_low,
                v_high,
                self._acc_low,
                self._acc_high,
                self._half_inv_jerk,
                strict=True,
            ):
                x = lo if x < lo else hi if x > hi else x
                y = a_lo if y < a_lo else a_hi if y > a_hi else y
                target.append(x)
                acc.append(0.0 if abs(x + y * abs(y) * h) >= hi else y)
        braking: list[bool] | None = None
        alone: list[bool] | None = None
        q, v, a = self._advance(target, acc, alone)
        checked: tuple[list[float], list[float], list[bool] | None] | None = None
        for _ in range(n + 1):
            checked, bad = self._check(q, v, a, alone, braking)
            if bad is None:
                break
            alone = bad if alone is None else [x or y for x, y in zip(alone, bad, strict=True)]
            braking = checked[2]
            if braking is not None:
                target = [0.0 if b else t for t, b in zip(target, braking, strict=True)]
            acc = [0.0 if b else x for x, b in zip(acc, alone, strict=True)]
            q, v, a = self._advance(target, acc, alone)
            checked = None
        if checked is None:  # the last re-plan was not checked (n + 1 rounds): check it now
            self._reach_lo, self._reach_hi = self._reach(q, v, a)
        else:
            self._reach_lo, self._reach_hi = checked[0], checked[1]
        # Ruckig ends a stop within rounding of zero: call it zero, so that "at rest" is exact.
        if not any(target) and max(map(abs, v)) < 1e-12 and max(map(abs, a)) < 1e-9:
            v, a = self._zero_list, self._zero_list
            self.q, self.v, self.a = _frozen(q), self._zeros, self._zeros
        else:
            # one read-only array, handed out in three slices (one allocation, not three)
            state = _frozen(q + v + a)
            self.q, self.v, self.a = state[:n], state[n : 2 * n], state[2 * n :]
        self.q_list, self.v_list, self.a_list = q, v, a
        self.at_rest = not (any(v) or any(a))
        return braking

    def reachable(self, periods: float = 1.0) -> tuple[list[float], list[float]]:
        """(lo, hi): per joint, the velocities that `follow` reaches exactly at the end of the next
        period from the current state (v, a): v + a·dt + [j_lo, j_hi]·dt²/2, the jerk j within
        the jerk limit and what keeps the acceleration within its limit, and the velocity within
        its limit less what it may bulge within the period (|a|·dt/2 + J·dt²/8). `periods`: the
        same over that many periods (what `step` reaches, with lag, in that time).

        A target inside it is reached with no lag at all, so a vector of joint velocities that
        keeps the tool on its path at both ends of the period keeps it there in between, up to
        the period's own curvature; `Servo` keeps a joint-limited motion inside it. (Smoothers
        without a jerk limit: v ± A·dt.)"""
        dt = self.period_s * periods
        half = 0.5 * dt * dt
        lo: list[float] = []
        hi: list[float] = []
        for v, a, J, A, vm in zip(
            self.v_list, self.a_list, self._jerk, self._acc, self._v_high, strict=True
        ):
            j_hi = min(J, (A - a) / dt)
            j_lo = max(-J, (-A - a) / dt)
            if j_lo > j_hi:  # pragma: no cover - the state keeps |a| ≤ A
                j_lo = j_hi = 0.0
            centre = v + a * dt
            room = vm - abs(a) * 0.5 * dt - J * dt * dt * 0.125
            lo.append(max(centre + j_lo * half, -room))
            hi.append(min(centre + j_hi * half, room))
        return lo, hi

    def follow(self, target_velocity: Sequence[float]) -> list[bool] | None:
        """Advance one period to exactly `target_velocity` (n,) [rad/s or m/s], which should lie in
        `reachable()`: each joint's jerk is constant over each half of the period (the two
        halves' jerks within the limit), its acceleration ending as near the period's mean
        acceleration (target − v)/dt as they allow, so that no oscillation of the acceleration
        builds up from period to period. Unlike `step`, no joint lags: the joint velocities
        arrive together where the servo put them.

        A target outside `reachable()`, a profile that would pass a velocity or acceleration
        limit, or a joint whose braking motion would then pass a position bound: `step` toward
        the target instead (Ruckig, with its guards). Returns what `step` returns."""
        dt = self.period_s
        h = 0.5 * dt
        q_new: list[float] = []
        v_new: list[float] = []
        a_new: list[float] = []
        for q, v, a, t, J, A, vm in zip(
            self.q_list,
            self.v_list,
            self.a_list,
            target_velocity,
            self._jerk,
            self._acc,
            self._v_tolerated,
            strict=True,
        ):
            # v1 = v + a dt + (3 j1 + j2) dt²/8, a1 = a + (j1 + j2) dt/2: u = 3 j1 + j2, w = j1 + j2
            u = (t - v - a * dt) * 8.0 / (dt * dt)
            if abs(u) > 4.0 * J * (1.0 + 1e-9):
                return self.step(target_velocity)
            w_lo = max(
                u - 2.0 * J, (u - 2.0 * J) / 3.0, 2.0 * (-A - a) / dt, u - 4.0 * (A - a) / dt
            )
            w_hi = min(u + 2.0 * J, (u + 2.0 * J) / 3.0, 2.0 * (A - a) / dt, u + 4.0 * (A + a) / dt)
            w = 2.0 * ((t - v) / dt - a) / dt  # the mean acceleration at the end
            if w_lo <= w_hi:
                w = w_lo if w < w_lo else w_hi if w > w_hi else w
            else:
                w = 0.5 * u  # constant jerk (within the limits where t is reachable)
            j1, j2 = 0.5 * (u - w), 0.5 * (3.0 * w - u)
            j1 = -J if j1 < -J else J if j1 > J else j1
            j2 = -J if j2 < -J else J if j2 > J else j2
            peak = 0.0
            qk, vk, ak = q, v, a
            for j in (j1, j2):
                if j != 0.0 and 0.0 < -ak / j < h:  # the velocity's extremum inside this half
                    peak = max(peak, abs(vk - ak * ak / (2.0 * j)))
                qk += h * (vk + h * (0.5 * ak + h * j / 6.0))
                vk += h * (ak + 0.5 * h * j)
                ak += h * j
            if (
                max(peak, abs(vk)) > vm
                or abs(ak) > A * (1.0 + 1e-12)
                or abs(vk - t) > 1e-9 * (1.0 + abs(t))  # a jerk clipped: not reached
            ):
                return self.step(target_velocity)
            q_new.append(qk)
            v_new.append(t)  # exactly the target (the profile's end, up to rounding)
            a_new.append(ak)
        checked, bad = self._check(q_new, v_new, a_new, None, None)
        if bad is not None:
            return self.step(target_velocity)
        self._reach_lo, self._reach_hi = checked[0], checked[1]
        n = self._n
        state = _frozen(q_new + v_new + a_new)
        self.q, self.v, self.a = state[:n], state[n : 2 * n], state[2 * n :]
        self.q_list, self.v_list, self.a_list = q_new, v_new, a_new
        self.at_rest = not (any(v_new) or any(a_new))
        return None

    def _check(
        self,
        q: list[float],
        v: list[float],
        a: list[float],
        alone: list[bool] | None,
        braking: list[bool] | None,
    ) -> tuple[tuple[list[float], list[float], list[bool] | None], list[bool] | None]:
        """The guards on a planned period: ((braking reach low, high, joints braking after this
        check or None), joints to re-plan or None)."""
        hij, tol = self._half_inv_jerk, self._v_tolerated
        bad = [abs(vk + ak * abs(ak) * h) > t for vk, ak, h, t in zip(v, a, hij, tol, strict=True)]
        if alone is not None:
            bad = [b and not s for b, s in zip(bad, alone, strict=True)]
        lo, hi = self._reach(q, v, a)
        if lo is q and True not in bad:
            return (q, q, braking), None  # the common case: both guards pass
        if lo is not q or hi is not q:
            lower, upper, r_lo, r_hi = self._lower, self._upper, self._reach_lo, self._reach_hi
            for k in range(self._n):
                if braking is not None and braking[k]:
                    continue
                # a joint that starts outside may not reach further out than it did
                if (hi[k] > max(upper[k], r_hi[k]) + _TOL) or (
                    lo[k] < min(lower[k], r_lo[k]) - _TOL
                ):
                    braking = [False] * self._n if braking is None else list(braking)
                    braking[k] = True
                    bad[k] = True
        return (lo, hi, braking), (bad if True in bad else None)

    def _advance(
        self, target: list[float], acc: list[float], alone: list[bool] | None
    ) -> tuple[list[float], list[float], list[float]]:
        inp = self._inp
        inp.current_position = self.q_list
        inp.current_velocity = self.v_list
        inp.current_acceleration = self.a_list
        inp.target_velocity = target
        inp.target_acceleration = acc
        # A joint re-planned by a guard must follow its own time-optimal motion, not a
        # synchronised one. (Measured: phase synchronisation otherwise tracks a moving target
        # better than none, on the UR5e, Panda and iiwa.)
        inp.synchronization = (
            self._unsynchronised if alone is not None and any(alone) else self._phase
        )
        result = self._otg.update(inp, self._out)
        if result not in self._good_results:
            # Ruckig refuses only inputs outside its limits; they come from our own state, so this
            # is rounding: plan every joint on its own, with no target acceleration.
            inp.synchronization = self._unsynchronised
            inp.target_acceleration = self._zero_list
            self._otg.update(inp, self._out)
        out = self._out
        return out.new_position, out.new_velocity, out.new_acceleration

    def _reach(
        self, q: list[float], v: list[float], a: list[float]
    ) -> tuple[list[float], list[float]]:
        """(min, max) position of each joint's time-optimal braking motion from (q, v, a), for
        the joints that may reach a bound (beyond the precomputed thresholds); the others, and
        all when none may: q itself (the same list). A cheap bound first spares the exact reach
        of a joint that cannot get near a bound: cutting the acceleration at full jerk, then
        braking from rest acceleration, goes no further than s|a|/J + s²/(2A) + sA/(2J) with
        s = |v| + a²/(2J) (a feasible stop, so the time-optimal one stops sooner; the last two
        terms bound `braking_distance(s)` by the AM-GM inequality)."""
        lo: list[float] | None = None
        hi = q
        for k, (qk, c) in enumerate(zip(q, self._reach_constants, strict=True)):
            if c[0] < qk < c[1]:
                continue  # not near a bound
            near_low, near_high, h_j, h_a, h_aj, J, lower, upper, A = c
            ak = a[k]
            speed = abs(v[k]) + ak * ak * h_j
            bound = speed * (speed * h_a + h_aj + abs(ak) / J)
            room = min(qk - lower, upper - qk)
            if not room <= bound + 1e-9:
                continue
            if lo is None:
                lo, hi = list(q), list(q)
            lo[k], hi[k] = braking_reach_one(qk, v[k], ak, A, J)
        return (q, q) if lo is None else (lo, hi)


class VelocityRamp:
    """A velocity (any number of components) moved toward a target within acceleration and jerk
    limits, one period per `step` (Ruckig's velocity interface, phase-synchronised so that the
    vector keeps its direction while its length changes). The servo ramps the commanded twist with
    it, so that the integrated commanded pose moves in a way the joints can follow.

    `v` and `a`, the velocity and acceleration after the last step, are lists of floats.
    """

    def __init__(self, acceleration: FloatArray, jerk: FloatArray, period_s: float) -> None:
        if _ruckig is None:
            raise MissingDependencyError(
                "the servo's jerk-limited smoothing needs Ruckig: pip install ruckig "
                "(or pip install 'kinematics_service[servo]')"
            )
        n = len(acceleration)
        self._n = n
        self._otg: Any = _ruckig.Ruckig(n, period_s)
        self._out: Any = _ruckig.OutputParameter(n)
        inp = _ruckig.InputParameter(n)
        inp.control_interface = _ruckig.ControlInterface.Velocity
        inp.synchronization = _ruckig.Synchronization.Phase
        inp.max_velocity = [math.inf] * n
        self._acceleration = [float(x) for x in acceleration]
        self._jerk = [float(x) for x in jerk]
        inp.max_acceleration = self._acceleration
        inp.max_jerk = self._jerk
        self.slowed = False  # the limits are scaled down (`slow`) until `restore`
        inp.current_position = [0.0] * n
        inp.target_acceleration = [0.0] * n
        self._inp: Any = inp
        self._good_results = (_ruckig.Result.Working, _ruckig.Result.Finished)
        self._zeros = [0.0] * n
        self.zeros: Sequence[float] = self._zeros  # (read-only by convention)
        self._arrived = False
        self.v: list[float] = self._zeros
        self.a: list[float] = self._zeros

    def reset(self, velocity: Sequence[float] | FloatArray) -> None:
        """Start from `velocity` with no acceleration."""
        self.v = [float(x) for x in velocity]
        self.a = self._zeros

    def slow(self, acceleration_factor: float, jerk_factor: float) -> None:
        """Scale the acceleration and jerk limits by these factors (in (0, 1]) until `restore`:
        with phase synchronisation every component keeps its share of the change, so the ramp
        takes longer along the same line."""
        inp = self._inp
        inp.max_acceleration = [x * acceleration_factor for x in self._acceleration]
        inp.max_jerk = [x * jerk_factor for x in self._jerk]
        self.slowed = True

    def restore(self) -> None:
        """The acceleration and jerk limits given to the constructor again."""
        inp = self._inp
        inp.max_acceleration = self._acceleration
        inp.max_jerk = self._jerk
        self.slowed = False

    def step(self, target: list[float]) -> list[float]:
        """The velocity one period later, on the way to `target`."""
        assert _ruckig is not None
        if target == self.v and not any(self.a):
            # Arrived (a steady command): Ruckig would return this velocity and no acceleration
            # (checked to the last bit). Ruckig keeps the last input it planned for, and goes on
            # along that plan when given the same input again: it is dropped on arrival, so that
            # whatever comes next is planned afresh.
            if not self._arrived:
                self._otg.reset()
                self._arrived = True
            return self.v
        self._arrived = False
        inp = self._inp
        inp.current_velocity = self.v
        inp.current_acceleration = self.a
        inp.target_velocity = target
        result = self._otg.update(inp, self._out)
        if result not in self._good_results:
            inp.synchronization = _ruckig.Synchronization.No
            self._otg.update(inp, self._out)
            inp.synchronization = _ruckig.Synchronization.Phase
        v = self._out.new_velocity
        a = self._out.new_acceleration
        if not any(target) and max(map(abs, v)) < 1e-12 and max(map(abs, a)) < 1e-9:
            v, a = self._zeros, self._zeros  # a stop ends within rounding of zero
        self.v, self.a = v, a
        return v
