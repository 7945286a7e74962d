"""Joint limits as the servo uses them: positions less a margin, and velocity, acceleration and
jerk limits, taken from the robot description with `ServoConfig` overrides.

A URDF gives position and velocity limits only; acceleration and jerk limits come from the
overrides, else from the velocity limit and the ramp times of `ServoConfig`
(a = v / acceleration_time_s, j = a / jerk_time_s).

`braking_speed` is the speed from which a joint at rest acceleration can still stop within a
distance under these limits: the servo asks no more of a joint near its limit, so it decelerates
before the limit instead of at it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..chain import SerialChain
from ..exceptions import InvalidInputError, UnknownNameError
from ..model import readonly
from .config import ServoConfig

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ServoLimits:
    """Per-joint limits of one chain, in the chain's joint order (read-only arrays).

    Attributes:
        joint_names: the chain's actuated joints.
        lower, upper: position bounds the servo keeps to: the description's limits moved inwards by
            the margin [rad or m]; ±inf for continuous joints.
        velocity: [rad/s or m/s], > 0, already multiplied by `ServoConfig.velocity_scale`.
        acceleration: [rad/s² or m/s²], > 0.
        jerk: [rad/s³ or m/s³], > 0.
    """

    joint_names: tuple[str, ...]
    lower: FloatArray
    upper: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    jerk: FloatArray

    @classmethod
    def from_chain(cls, chain: SerialChain, config: ServoConfig) -> ServoLimits:
        """The limits of `chain` under `config`.

        Raises:
            UnknownNameError: an override names a joint that is not in the chain.
            InvalidInputError: a joint's range is narrower than twice its margin.
        """
        names = chain.joint_names
        for field_name in ("velocity_limits", "acceleration_limits", "jerk_limits"):
            for joint in getattr(config, field_name):
                if joint not in names:
                    raise UnknownNameError("joint", joint, names)
        prismatic = np.array([t == "prismatic" for t in chain.joint_types])
        margin = np.where(prismatic, config.position_margin_m, config.position_margin_rad)
        lower = np.asarray(chain.lower, dtype=np.float64) + margin
        upper = np.asarray(chain.upper, dtype=np.float64) - margin
        for k, name in enumerate(names):
            if lower[k] > upper[k]:
                raise InvalidInputError(
                    f"joint {name!r} has limits [{chain.lower[k]:g}, {chain.upper[k]:g}], narrower "
                    f"than twice the servo's margin {margin[k]:g}; lower the margin"
                )
        given = np.asarray(chain.velocity_limit, dtype=np.float64)
        velocity = np.where(
            np.isfinite(given) & (given > 0), given, config.default_velocity_limit
        ).astype(np.float64)
        for joint, value in config.velocity_limits.items():
            velocity[names.index(joint)] = value
        velocity = velocity * config.velocity_scale
        acceleration = velocity / config.acceleration_time_s
        for joint, value in config.acceleration_limits.items():
            acceleration[names.index(joint)] = value
        jerk = acceleration / config.jerk_time_s
        for joint, value in config.jerk_limits.items():
            jerk[names.index(joint)] = value
        return cls(
            joint_names=tuple(names),
            lower=readonly(lower),
            upper=readonly(upper),
            velocity=readonly(velocity),
            acceleration=readonly(acceleration),
            jerk=readonly(jerk),
        )


def braking_distance(speed: FloatArray, acceleration: FloatArray, jerk: FloatArray) -> FloatArray:
    """Distance to stop from `speed` ≥ 0 at zero acceleration, braking as hard as the acceleration
    limit A and jerk limit J allow (jerk −J, then −A held, then +J).

    d = v √(v/J) when v ≤ A²/J (the acceleration never reaches −A), else v²/(2A) + vA/(2J).
    """
    v, A, J = speed, acceleration, jerk
    short = v <= A * A / J
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(short, v * np.sqrt(v / J), v * v / (2 * A) + v * A / (2 * J))


def braking_speed(distance: FloatArray, acceleration: FloatArray, jerk: FloatArray) -> FloatArray:
    """The inverse of `braking_distance`: the highest speed (at zero acceleration) from which a
    joint stops within `distance` ≥ 0 [rad or m]; inf where the distance is inf.

    v = (d √J)^(2/3) when that is ≤ A²/J, else the positive root of v² + (A²/J) v − 2 A d = 0.
    """
    d, A, J = np.maximum(distance, 0.0), acceleration, jerk
    with np.errstate(invalid="ignore", over="ignore"):
        v_short = np.cbrt(d * d * J)  # (d √J)^(2/3)
        b = A * A / J
        v_long = 0.5 * (-b + np.sqrt(b * b + 8.0 * A * d))
        out = np.where(v_short <= b, v_short, v_long)
    return np.where(np.isinf(d), np.inf, out)


def free_distances(
    velocity: FloatArray, acceleration: FloatArray, jerk: FloatArray, lead_time_s: float
) -> tuple[FloatArray, FloatArray]:
    """(d_free, d_rest): beyond both d_free and d_rest + lead_time_s × |v| from a bound, a joint
    moving at speed |v| is not limited by braking: the speed it may take toward the bound,
    min(v_max, s(d − t_lead max(|v|, s(d)))) with s = `braking_speed`, is v_max itself.

    Why: s(d) ≤ √(2 A d) (the stop without a jerk limit is shorter), and s grows with d, so the
    speed is v_max wherever d − t_lead max(|v|, √(2 A d)) ≥ D, the braking distance from v_max:
    d_rest = D, and d_free solves d − t_lead √(2 A d) = D (a quadratic in √d). Both carry a
    relative margin of 1e-9, far above the rounding of `braking_speed`.
    """
    D = braking_distance(velocity, acceleration, jerk) * (1.0 + 1e-9) + 1e-12
    c = lead_time_s * np.sqrt(2.0 * acceleration)
    free = (0.5 * (c + np.sqrt(c * c + 4.0 * D))) ** 2 * (1.0 + 1e-9) + 1e-12
    return free, D


def braking_speed_one(d: float, A: float, J: float, b: float) -> float:
    """`braking_speed` of one joint on floats, the same floats: distance d [rad or m], limits A
    and J, and b = A * A / J (precomputed). The cube root, NumPy's as in `braking_speed`, is
    taken only where it may decide: where d²J exceeds b³ by more than rounding, the short
    profile's speed (d²J)^⅓ is surely above b and the long profile's applies."""
    if not d > 0.0:
        d = 0.0
    elif d == math.inf:
        return math.inf
    y = d * d * J
    if y <= b * b * b * (1.0 + 1e-12):
        v_short = float(np.cbrt(y))
        if v_short <= b:
            return v_short
    return 0.5 * (-b + math.sqrt(b * b + 8.0 * A * d))


def _phase(x: float, v: float, a: float, j: float, t: float) -> tuple[float, float, float]:
    """State (x, v, a) after `t` [s] of constant jerk `j`."""
    return x + t * (v + t * (a / 2 + t * j / 6)), v + t * (a + t * j / 2), a + t * j


def _forward_reach(v0: float, a0: float, A: float, J: float) -> tuple[float, float]:
    """(lowest, highest) position, relative to the start, of the time-optimal stop (v = a = 0)
    from (v0, a0) when it ends moving forward (v0 + a0|a0|/(2J) ≥ 0): jerk −J down to the peak
    deceleration a_p = −√(J v0 + a0²/2) (or −A, held as long as needed), then +J to a = 0."""
    a0 = min(max(a0, -A), A)
    peak2 = J * v0 + a0 * a0 / 2
    a_p = -math.sqrt(max(peak2, 0.0))
    if a_p >= -A:
        x, v, a = _phase(0.0, v0, a0, -J, max((a0 - a_p) / J, 0.0))
    else:
        x, v, a = _phase(0.0, v0, a0, -J, (a0 + A) / J)
        x, v, a = _phase(x, v, a, 0.0, max((v - A * A / (2 * J)) / A, 0.0))
    x_end, _, _ = _phase(x, v, a, J, max(-a / J, 0.0))
    lowest = 0.0
    disc = a0 * a0 + 2 * J * v0
    if v0 < 0.0 and disc >= 0.0:  # moving back at first: it turns where v = 0 during phase 1
        t = (a0 - math.sqrt(disc)) / J
        lowest = min(0.0, _phase(0.0, v0, a0, -J, max(t, 0.0))[0])
    return lowest, max(0.0, x_end)


def braking_reach_one(q: float, v: float, a: float, A: float, J: float) -> tuple[float, float]:
    """`braking_reach` of one joint, on floats: (lowest, highest) position of its fastest stop
    from position q, velocity v and acceleration a under acceleration limit A and jerk limit J."""
    if v + a * abs(a) / (2 * J) >= 0.0:
        low, high = _forward_reach(v, a, A, J)
    else:
        neg_high, neg_low = _forward_reach(-v, -a, A, J)
        low, high = -neg_low, -neg_high
    return q + low, q + high


def braking_reach(
    q: FloatArray, v: FloatArray, a: FloatArray, acceleration: FloatArray, jerk: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(lowest, highest) position each joint passes while it stops as fast as its acceleration
    and jerk limits allow, from position q, velocity v and acceleration a (the motion Ruckig's
    velocity interface plans for a target velocity of 0; bang-bang jerk, see `_forward_reach`)."""
    lo = np.empty_like(q)
    hi = np.empty_like(q)
    for k, (qk, vk, ak, A, J) in enumerate(
        zip(q.tolist(), v.tolist(), a.tolist(), acceleration.tolist(), jerk.tolist(), strict=True)
    ):
        lo[k], hi[k] = braking_reach_one(qk, vk, ak, A, J)
    return lo, hi
