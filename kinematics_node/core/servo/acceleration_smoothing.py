"""Acceleration-limited joint motion toward a target velocity, one period at a time, without Ruckig.

The servo's fallback where Ruckig (`smoothing`, jerk-limited) is not installed: Ruckig has no
rosdep key and pip will not install into Ubuntu 24.04's system Python without being told to
(PEP 668), so a ROS user who installed the package with rosdep does not have it. It is written
here by hand because it is what runs when the library is absent; it keeps exactly the limits
Ruckig's path keeps (the same `ServoLimits`: positions less the margin, velocity, acceleration)
except the jerk limit, and has the same interface, so `Servo` does not care which it has.

Each period, every joint's velocity moves toward its target (clipped to the velocity limit) by at
most its acceleration limit × the period. The change is phase-synchronised as Ruckig's is: one
share s ∈ (0, 1] of every joint's change, the largest no joint's acceleration limit forbids, so
the joint velocities move along a straight line in joint space and a change of speed does not
bend the tool's path. The velocity is constant-acceleration within a period, so the position is
integrated exactly: q' = q + dt (v + v') / 2, and the commanded positions' finite differences
stay within the velocity and acceleration limits too. The acceleration reported is that of the
period just commanded, (v' − v) / dt; it jumps from one period to the next (no jerk limit).

Position limits, as Ruckig's path checks them: from the new state, the joint's fastest stop (its
velocity brought to zero by A·dt per period, the last step shorter) must stay inside
[lower, upper] (or reach no further out than the stop from the previous state, for a joint that
starts outside). That stop covers (v² + r (A·dt − r)) / (2A), r = |v| mod A·dt: the continuous
stop's v²/(2A) plus at most A·dt²/8 for the last, shorter step. A joint that would break this
brakes instead, from the previous state, along that stop, which by induction stays inside; the
others are then synchronised among themselves and checked again. The servo's velocity planning
(`limits.braking_speed`, at half the acceleration and with a jerk limit, so more cautious than
this stop needs) slows the joints before this guard has to act.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .limits import ServoLimits

FloatArray = NDArray[np.float64]

_TOL = 1e-9  # [rad or m] slack on the position checks (rounding)


def _frozen(values: Any) -> FloatArray:
    arr = np.array(values, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def stopping_distance(speed: float, acceleration: float, period_s: float) -> float:
    """Distance [rad or m] covered while a joint at `speed` ≥ 0 stops, its velocity lowered by
    `acceleration` × `period_s` per period (the last period by what is left, r), at constant
    acceleration within each period: (v² + r (A·dt − r)) / (2A)."""
    step = acceleration * period_s
    r = math.fmod(speed, step)
    return (speed * speed + r * (step - r)) / (2.0 * acceleration)


def _synchronised_share(
    v: Sequence[float], target: Sequence[float], step: Sequence[float], skip: list[bool] | None
) -> float:
    """The largest s ∈ [0, 1] with |s (target − v)| ≤ step for every joint not in `skip`."""
    s = 1.0
    for k, (vk, tk, hk) in enumerate(zip(v, target, step, strict=True)):
        if skip is not None and skip[k]:
            continue
        change = abs(tk - vk)
        if change * s > hk:
            s = hk / change
    return s


class AccelerationLimitedIntegrator:
    """The commanded joint state (q, q̇, q̈) of the servo, advanced one period per `step`, within
    the position, velocity and acceleration limits of `limits` (not its jerk limits).

    The interface of `smoothing.JerkLimitedIntegrator`: `q`, `v`, `a` (read-only arrays), their
    lists `q_list`, `v_list`, `a_list`, `at_rest`, `reset`, `step`. Mutable; not thread-safe.
    """

    jerk_limited = False

    def __init__(self, limits: ServoLimits, period_s: float, positions: FloatArray) -> None:
        n = len(limits.joint_names)
        self.limits = limits
        self.period_s = period_s
        self._n = n
        self._lower: list[float] = limits.lower.tolist()
        self._upper: list[float] = limits.upper.tolist()
        self._acc: list[float] = limits.acceleration.tolist()
        self._step: list[float] = (limits.acceleration * period_s).tolist()  # A·dt
        self._v_high: list[float] = limits.velocity.tolist()
        self._v_low: list[float] = (-limits.velocity).tolist()
        self._zeros = _frozen(np.zeros(n))
        self._zero_list = [0.0] * n
        self.reset(positions)

    def reset(self, positions: FloatArray) -> None:
        """At rest at `positions` (no velocity, no acceleration)."""
        self.q = _frozen(positions)
        self.v = self._zeros
        self.a = self._zeros
        self.q_list: list[float] = self.q.tolist()
        self.v_list: list[float] = self._zero_list
        self.a_list: list[float] = self._zero_list
        self.at_rest = True
        self._reach_lo = self.q_list  # extent of the stop from the current state
        self._reach_hi = self.q_list

    def step(
        self,
        target_velocity: Sequence[float],
        target_acceleration: Sequence[float] | None = None,
    ) -> list[bool] | None:
        """Advance one period toward `target_velocity` (n,) [rad/s or m/s]. Returns which joints
        the position guard made brake, or None when none did.

        `target_acceleration` is taken for the interface's sake and not used: without a jerk
        limit, a target within A·dt of the velocity is reached in one period, so a target that
        moves at a steady rate (below the acceleration limit) is followed without lag anyway."""
        del target_acceleration
        n, dt = self._n, self.period_s
        v0, q0 = self.v_list, self.q_list
        target = [
            lo if x < lo else hi if x > hi else float(x)
            for x, lo, hi in zip(target_velocity, self._v_low, self._v_high, strict=True)
        ]
        step = self._step
        braking: list[bool] | None = None
        for _ in range(n + 1):
            s = _synchronised_share(v0, target, step, braking)
            v = []
            for k in range(n):
                vk = v0[k]
                if braking is not None and braking[k]:
                    h = step[k]
                    v.append(vk - h if vk > h else vk + h if vk < -h else 0.0)
                else:
                    v.append(target[k] if s == 1.0 else vk + s * (target[k] - vk))
            q = [qk + 0.5 * dt * (a + b) for qk, a, b in zip(q0, v0, v, strict=True)]
            lo, hi, bad = self._reach(q, v, braking)
            if bad is None:
                break
            braking = (
                bad if braking is None else [x or y for x, y in zip(braking, bad, strict=True)]
            )
        self._reach_lo, self._reach_hi = lo, hi
        inv_dt = 1.0 / dt
        a = [(b - c) * inv_dt for b, c in zip(v, v0, strict=True)]
        if not any(v) and not any(a):
            self.q, self.v, self.a = _frozen(q), self._zeros, self._zeros
            v, a = self._zero_list, self._zero_list
        else:
            state = _frozen(q + v + a)
            self.q, self.v, self.a = state[:n], state[n : 2 * n], state[2 * n :]
        self.q_list, self.v_list, self.a_list = q, v, a
        self.at_rest = not (any(v) or any(a))
        return braking

    def reachable(self, periods: float = 1.0) -> tuple[list[float], list[float]]:
        """(lo, hi): per joint, the velocities `step` reaches exactly within `periods` periods
        from the current velocity: v ± A·dt·periods, within the velocity limit (the interface
        `JerkLimitedIntegrator.reachable` gives with a jerk limit)."""
        lo, hi = [], []
        for v, s, v_low, v_high in zip(
            self.v_list, self._step, self._v_low, self._v_high, strict=True
        ):
            lo.append(max(v - s * periods, v_low))
            hi.append(min(v + s * periods, v_high))
        return lo, hi

    def follow(self, target_velocity: Sequence[float]) -> list[bool] | None:
        """Advance one period to exactly `target_velocity` where it lies in `reachable()`: with no
        jerk limit that is what `step` does (constant acceleration, every joint arriving at the
        end of the period); outside it, `step` toward it. Returns what `step` returns."""
        return self.step(target_velocity)

    def _reach(
        self, q: list[float], v: list[float], braking: list[bool] | None
    ) -> tuple[list[float], list[float], list[bool] | None]:
        """(lowest, highest) position of each joint's stop from (q, v), and the joints not yet
        braking whose stop leaves the bounds (or reaches further out than the previous
        state's), or None."""
        lo, hi = list(q), list(q)
        bad: list[bool] | None = None
        for k, (qk, vk) in enumerate(zip(q, v, strict=True)):
            if vk != 0.0:
                d = stopping_distance(abs(vk), self._acc[k], self.period_s)
                if vk > 0.0:
                    hi[k] = qk + d
                else:
                    lo[k] = qk - d
            if braking is not None and braking[k]:
                continue
            if hi[k] > max(self._upper[k], self._reach_hi[k]) + _TOL or lo[k] < (
                min(self._lower[k], self._reach_lo[k]) - _TOL
            ):
                if bad is None:
                    bad = [False] * self._n
                bad[k] = True
        return lo, hi, bad


class AccelerationRamp:
    """A velocity (any number of components) moved toward a target within acceleration limits,
    one period per `step`, phase-synchronised (the vector keeps its direction while its length
    changes). The interface of `smoothing.VelocityRamp`; its jerk limits are taken and not used.

    `v` and `a`, the velocity and acceleration after the last step, are lists of floats.
    """

    def __init__(self, acceleration: FloatArray, jerk: FloatArray, period_s: float) -> None:
        del jerk  # (no jerk limit without Ruckig)
        n = len(acceleration)
        self._n = n
        self._period_s = period_s
        self._acceleration = [float(x) for x in acceleration]
        self._step = [x * period_s for x in self._acceleration]
        self.slowed = False  # the limits are scaled down (`slow`) until `restore`
        self._zeros = [0.0] * n
        self.zeros: Sequence[float] = self._zeros  # (read-only by convention)
        self.v: list[float] = self._zeros
        self.a: list[float] = self._zeros

    def reset(self, velocity: Sequence[float] | FloatArray) -> None:
        """Start from `velocity` with no acceleration."""
        self.v = [float(x) for x in velocity]
        self.a = self._zeros

    def slow(self, acceleration_factor: float, jerk_factor: float) -> None:
        """Scale the acceleration limits by `acceleration_factor` in (0, 1] until `restore`."""
        del jerk_factor
        self._step = [x * acceleration_factor * self._period_s for x in self._acceleration]
        self.slowed = True

    def restore(self) -> None:
        """The acceleration limits given to the constructor again."""
        self._step = [x * self._period_s for x in self._acceleration]
        self.slowed = False

    def step(self, target: list[float]) -> list[float]:
        """The velocity one period later, on the way to `target`."""
        v0 = self.v
        if target == v0:
            self.a = self._zeros
            return v0
        s = _synchronised_share(v0, target, self._step, None)
        v = list(target) if s == 1.0 else [x + s * (t - x) for x, t in zip(v0, target, strict=True)]
        inv_dt = 1.0 / self._period_s
        self.a = [(x - y) * inv_dt for x, y in zip(v, v0, strict=True)]
        self.v = v
        return v
