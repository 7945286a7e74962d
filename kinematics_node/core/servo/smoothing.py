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
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..exceptions import KinematicsError
from .limits import ServoLimits, braking_reach

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
        # An upper bound on the braking distance from any state within the limits: the speed
        # never exceeds v_max + A²/(2J) while braking, which lasts at most 3A/J + that speed / A.
        A, J = limits.acceleration, limits.jerk
        top = limits.velocity + A * A / (2 * J)
        zone = top * (3 * A / J + top / A) + 1e-6
        self._near_low = limits.lower + zone  # at or beyond these a joint may reach a bound
        self._near_high = limits.upper - zone
        self._v_low = -limits.velocity
        self._v_tolerated = limits.velocity * (1 + 1e-12)
        self._acc_high = 0.9 * A
        self._acc_low = -0.9 * A
        self._half_inv_jerk = 0.5 / J
        self._half_inv_acc = 0.5 / A
        self._half_acc_over_jerk = 0.5 * A / J
        self._zeros = _frozen(np.zeros(n))
        # The commanded state (read-only arrays, replaced each period, never written to).
        self.q = _frozen(positions)
        self.v = self._zeros
        self.a = self._zeros
        self._reach_lo = self.q  # extent of the braking motion from the current state
        self._reach_hi = self.q

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
        self.q = _frozen(positions)
        self.v = self._zeros
        self.a = self._zeros
        self._reach_lo = self.q
        self._reach_hi = self.q

    @property
    def at_rest(self) -> bool:
        return not (self.v.any() or self.a.any())

    def step(
        self, target_velocity: FloatArray, target_acceleration: FloatArray | None = None
    ) -> NDArray[np.bool_]:
        """Advance one period toward `target_velocity` (n,) [rad/s or m/s], arriving there with
        `target_acceleration` (n,) [rad/s² or m/s²] (default 0): a target that moves at a steady
        rate is then followed without lag. Returns the mask of joints that the position guard made
        brake (their targets become 0).

        Two guards check the planned period, joint by joint, and re-plan a joint on its own
        (unsynchronised, time-optimal, as Ruckig guarantees its limits for one joint alone):
        * velocity: Ruckig's velocity interface bounds acceleration and jerk, not velocity, so the
          speed the joint would reach by bringing its acceleration to zero at full jerk,
          |v + a|a|/(2J)|, must stay within the velocity limit; a joint that would pass it heads
          for its (clipped) target with no target acceleration instead;
        * position: see the module docstring; a joint that would pass it brakes to a stop.
        """
        lim = self.limits
        n = self._n
        braking = np.zeros(n, dtype=bool)
        alone = np.zeros(n, dtype=bool)
        target = np.minimum(np.maximum(target_velocity, self._v_low), lim.velocity)
        if target_acceleration is None:
            acc = self._zeros
        else:
            # Within the limit, and none where the velocity limit would be passed before the
            # acceleration could return to zero (Ruckig could not reach such a target state).
            acc = np.minimum(np.maximum(target_acceleration, self._acc_low), self._acc_high)
            over = np.abs(target + acc * np.abs(acc) * self._half_inv_jerk) >= lim.velocity
            if over.any():
                acc = np.where(over, 0.0, acc)
        q, v, a = self._advance(target, acc, alone)
        reach: tuple[FloatArray, FloatArray] | None = None
        for _ in range(n + 1):
            bad = np.abs(v + a * np.abs(a) * self._half_inv_jerk) > self._v_tolerated
            bad &= ~alone
            near = (q <= self._near_low) | (q >= self._near_high)
            if near.any():
                lo, hi = reach = self._reach(q, v, a, near)
                bad_p = near & ~braking
                bad_p &= (hi > np.maximum(lim.upper, self._reach_hi) + _TOL) | (
                    lo < np.minimum(lim.lower, self._reach_lo) - _TOL
                )
                braking |= bad_p
                bad |= bad_p
            else:
                reach = (q, q)
            if not bad.any():
                break
            alone |= bad
            target = np.where(braking, 0.0, target)
            acc = np.where(alone, 0.0, acc)
            q, v, a = self._advance(target, acc, alone)
            reach = None
        if reach is None:  # the last re-plan was not checked (n + 1 rounds): check it now
            near = (q <= self._near_low) | (q >= self._near_high)
            reach = self._reach(q, v, a, near)
        self._reach_lo, self._reach_hi = reach
        # Ruckig ends a stop within rounding of zero: call it zero, so that "at rest" is exact.
        if not target.any() and np.abs(v).max() < 1e-12 and np.abs(a).max() < 1e-9:
            v, a = self._zeros, self._zeros  # a stop ends within rounding of zero
        self.q, self.v, self.a = q, v, a
        return braking

    def _advance(
        self, target: FloatArray, acc: FloatArray, alone: NDArray[np.bool_]
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        assert _ruckig is not None
        inp = self._inp
        inp.current_position = self.q.tolist()
        inp.current_velocity = self.v.tolist()
        inp.current_acceleration = self.a.tolist()
        inp.target_velocity = target.tolist()
        inp.target_acceleration = acc.tolist()
        # A joint re-planned by a guard must follow its own time-optimal motion, not a
        # synchronised one. (Measured: phase synchronisation otherwise tracks a moving target
        # better than none, on the UR5e, Panda and iiwa.)
        inp.synchronization = (
            _ruckig.Synchronization.No if alone.any() else _ruckig.Synchronization.Phase
        )
        result = self._otg.update(inp, self._out)
        if result not in (_ruckig.Result.Working, _ruckig.Result.Finished):
            # Ruckig refuses only inputs outside its limits; they come from our own state, so this
            # is rounding: plan every joint on its own, with no target acceleration.
            inp.synchronization = _ruckig.Synchronization.No
            inp.target_acceleration = [0.0] * self._n
            self._otg.update(inp, self._out)
        out = self._out
        return _frozen(out.new_position), _frozen(out.new_velocity), _frozen(out.new_acceleration)

    def _reach(
        self, q: FloatArray, v: FloatArray, a: FloatArray, which: NDArray[np.bool_]
    ) -> tuple[FloatArray, FloatArray]:
        """(min, max) position of each joint's time-optimal braking motion from (q, v, a), for
        the joints in `which` (the others: q). A cheap bound first spares the exact reach of a
        joint that cannot get near a bound: cutting the acceleration at full jerk, then braking
        from rest acceleration, goes no further than s|a|/J + s²/(2A) + sA/(2J) with
        s = |v| + a²/(2J) (a feasible stop, so the time-optimal one stops sooner; the last two
        terms bound `braking_distance(s)` by the AM-GM inequality)."""
        lim = self.limits
        speed = np.abs(v) + a * a * self._half_inv_jerk
        bound = speed * (
            speed * self._half_inv_acc + self._half_acc_over_jerk + np.abs(a) / lim.jerk
        )
        room = np.minimum(q - lim.lower, lim.upper - q)
        exact = which & (room <= bound + 1e-9)
        if not exact.any():
            return q, q
        lo, hi = q.copy(), q.copy()
        lo[exact], hi[exact] = braking_reach(
            q[exact], v[exact], a[exact], lim.acceleration[exact], lim.jerk[exact]
        )
        return lo, hi


class VelocityRamp:
    """A velocity (any number of components) moved toward a target within acceleration and jerk
    limits, one period per `step` (Ruckig's velocity interface, phase-synchronised so that the
    vector keeps its direction while its length changes). The servo ramps the commanded twist with
    it, so that the integrated commanded pose moves in a way the joints can follow."""

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
        inp.max_acceleration = [float(x) for x in acceleration]
        inp.max_jerk = [float(x) for x in jerk]
        inp.current_position = [0.0] * n
        inp.target_acceleration = [0.0] * n
        self._inp: Any = inp
        self.v = np.zeros(n)
        self.a = np.zeros(n)

    def reset(self, velocity: FloatArray) -> None:
        """Start from `velocity` with no acceleration."""
        self.v = np.array(velocity, dtype=np.float64)
        self.a = np.zeros(self._n)

    def step(self, target: FloatArray) -> FloatArray:
        """The velocity one period later, on the way to `target`."""
        assert _ruckig is not None
        inp = self._inp
        inp.current_velocity = self.v.tolist()
        inp.current_acceleration = self.a.tolist()
        inp.target_velocity = target.tolist()
        result = self._otg.update(inp, self._out)
        if result not in (_ruckig.Result.Working, _ruckig.Result.Finished):
            inp.synchronization = _ruckig.Synchronization.No
            self._otg.update(inp, self._out)
            inp.synchronization = _ruckig.Synchronization.Phase
        v = np.array(self._out.new_velocity)
        a = np.array(self._out.new_acceleration)
        if not target.any() and np.abs(v).max() < 1e-12 and np.abs(a).max() < 1e-9:
            v, a = np.zeros(self._n), np.zeros(self._n)  # a stop ends within rounding of zero
        self.v, self.a = v, a
        return v
