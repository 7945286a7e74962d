"""A kinematic arm simulator with fixed-step integration, in plain Python (no ROS).

Every step moves each joint from q_k towards a reference q_ref(t_{k+1}) given by the active mode,

    Δ_k     = (q_ref(t_{k+1}) − q_k) / max(1, max_i |q_ref,i − q_k,i| / (q̇_max,i Δt))
                                                      (velocity limit, every joint in proportion)
    q_{k+1} = clip(q_k + Δ_k, q_min, q_max)                           (position limit)
    q̇_{k+1} = (q_{k+1} − q_k) / Δt,

so joint positions never leave [q_min, q_max] and reported velocities never exceed q̇_max, and a
feasible reference is tracked exactly at the sample instants t_k = k Δt. Modes:

* ``"velocity"``: q_ref = q_k + q̇_cmd Δt; a command is held for `command_timeout` seconds of
  simulated time, then the arm stops (mode ``"hold"``).
* ``"position"``: q_ref = q_cmd, the last commanded positions, held until the next command (as
  ros2_control's forward position controller holds its last command).
* ``"trajectory"``: time-parameterised waypoints, cubic Hermite between them (given waypoint
  velocities, or shape-preserving monotone tangents when none are given; zero velocity at the last
  waypoint). The first segment starts from the current state; after the last waypoint the arm holds.
* ``"demo"`` (when nothing is commanded): each joint follows
  q_i(t) = q_s,i + σ_i A_i (1 − cos ω_i (t − t_s)), starting at rest at q_s, periodic, staying
  in [q_s, q_s + 2 σ_i A_i] inside the limits, with A_i ω_i ≤ 0.8 q̇_max,i.
* ``"hold"``: stay at the last target.

Units: joint positions in rad (revolute/continuous) or m (prismatic), velocities per second,
time in s. Continuous joints have infinite position limits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from os import PathLike
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import SerialChain
from ..core._checks import as_float_array, check_finite
from ..core.exceptions import InvalidInputError, UnknownNameError
from ..core.model import middle_of_limits, readonly
from ..core.urdf import RobotDescription

FloatArray = NDArray[np.float64]
MODES = ("demo", "velocity", "position", "trajectory", "hold")


class SimState(NamedTuple):
    """State after a step: simulated time [s], positions q and velocities q̇ (copies)."""

    time: float
    q: FloatArray
    qdot: FloatArray


def _vector(value: Any, n: int, name: str) -> FloatArray:
    arr = as_float_array(value, name)
    if arr.shape != (n,):
        raise InvalidInputError(f"{name} must have {n} values, got shape {arr.shape}")
    check_finite(arr, name)
    return arr


class _Hermite:
    """Piecewise cubic Hermite curve through knots (τ_k, P_k, V_k); constant after the last knot."""

    def __init__(self, tau: FloatArray, P: FloatArray, V: FloatArray) -> None:
        self.tau, self.P, self.V = tau, P, V

    @property
    def duration(self) -> float:
        return float(self.tau[-1])

    def __call__(self, t: float) -> FloatArray:
        tau, P, V = self.tau, self.P, self.V
        if t >= tau[-1]:
            return P[-1].copy()
        k = max(int(np.searchsorted(tau, t, side="right")) - 1, 0)
        h = tau[k + 1] - tau[k]
        s = (t - tau[k]) / h
        # Cubic Hermite basis on s ∈ [0, 1].
        h00 = (1 + 2 * s) * (1 - s) ** 2
        h10 = s * (1 - s) ** 2
        h01 = s * s * (3 - 2 * s)
        h11 = s * s * (s - 1)
        return h00 * P[k] + h10 * h * V[k] + h01 * P[k + 1] + h11 * h * V[k + 1]


def _monotone_tangents(tau: FloatArray, P: FloatArray, v_start: FloatArray) -> FloatArray:
    """Fritsch–Carlson tangents at interior knots (no overshoot), v_start first, zero last."""
    V = np.zeros_like(P)
    V[0] = v_start
    h = np.diff(tau)[:, None]
    delta = np.diff(P, axis=0) / h
    for k in range(1, len(tau) - 1):
        d0, d1 = delta[k - 1], delta[k]
        w1 = 2 * h[k] + h[k - 1]
        w2 = h[k] + 2 * h[k - 1]
        same = d0 * d1 > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            harmonic = (w1 + w2) / (w1 / d0 + w2 / d1)
        V[k] = np.where(same, harmonic, 0.0)
    return V


class ArmSimulator:
    """Kinematic simulation of n joints with position and velocity limits (module docstring).

    Args:
        joint_names: names, in the order of every vector this class takes and returns.
        lower, upper: position limits [rad or m]; ±inf for continuous joints.
        velocity_limit: [rad/s or m/s], > 0; inf (no limit given) is replaced by
            `default_velocity_limit`.
        dt: fixed step [s], > 0.
        q0: initial positions (default: the middle of each range, 0 for continuous joints).
        command_timeout: how long a velocity command is held [s] (simulated time).
        demo: run the demo motion from the start until the first command.
        demo_resume_after: restart the demo after this long [s] without a command (after a
            velocity command timed out or a trajectory ended); None or ≤ 0: never.
        demo_span: largest excursion 2A of a joint in the demo [rad or m].
        demo_period: period of joint 1 in the demo [s]; joint i is 20 % slower per index.
        default_velocity_limit: used where `velocity_limit` is infinite.

    Raises:
        InvalidInputError: inconsistent sizes, non-finite or non-positive values, lower > upper,
            duplicate names, or q0 outside the limits.
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        lower: ArrayLike,
        upper: ArrayLike,
        velocity_limit: ArrayLike,
        dt: float,
        q0: ArrayLike | None = None,
        *,
        command_timeout: float = 0.5,
        demo: bool = True,
        demo_resume_after: float | None = None,
        demo_span: float = 1.0,
        demo_period: float = 6.0,
        default_velocity_limit: float = 1.0,
    ) -> None:
        names = tuple(str(n) for n in joint_names)
        if not names:
            raise InvalidInputError("the simulator needs at least one joint")
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise InvalidInputError(f"duplicate joint names {dup}")
        n = len(names)
        lo = as_float_array(lower, "lower")
        up = as_float_array(upper, "upper")
        vel = as_float_array(velocity_limit, "velocity_limit")
        for arr, what in ((lo, "lower"), (up, "upper"), (vel, "velocity_limit")):
            if arr.shape != (n,):
                raise InvalidInputError(f"{what} must have {n} values, got shape {arr.shape}")
            if np.any(np.isnan(arr)):
                raise InvalidInputError(f"{what} contains NaN: {arr.tolist()}")
        if np.any(lo > up):
            i = int(np.argmax(lo > up))
            raise InvalidInputError(
                f"joint {names[i]!r}: lower limit {lo[i]} > upper limit {up[i]}"
            )
        for value, what in (
            (dt, "dt"),
            (command_timeout, "command_timeout"),
            (demo_span, "demo_span"),
            (demo_period, "demo_period"),
            (default_velocity_limit, "default_velocity_limit"),
        ):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InvalidInputError(f"{what} must be a finite number > 0, got {value!r}")
        if np.any(vel <= 0):
            i = int(np.argmax(vel <= 0))
            raise InvalidInputError(f"joint {names[i]!r}: velocity limit must be > 0, got {vel[i]}")
        vel = np.where(np.isinf(vel), float(default_velocity_limit), vel)

        self.joint_names = names
        self.dof = n
        self.dt = float(dt)
        self.lower = readonly(lo)
        self.upper = readonly(up)
        self.velocity_limit = readonly(vel)
        self.command_timeout = float(command_timeout)
        resume = None if demo_resume_after is None else float(demo_resume_after)
        self.demo_resume_after = resume if resume is not None and resume > 0 else None
        self._demo_span = float(demo_span)
        self._demo_period = float(demo_period)
        self._index = {name: i for i, name in enumerate(names)}

        if q0 is None:
            q = middle_of_limits(lo, up)
        else:
            q = _vector(q0, n, "q0")
            if np.any(q < lo) or np.any(q > up):
                i = int(np.argmax((q < lo) | (q > up)))
                raise InvalidInputError(
                    f"q0[{i}] = {q[i]} for joint {names[i]!r} is outside [{lo[i]}, {up[i]}]"
                )
        self._k = 0  # step counter; time = k dt
        self._q = q.astype(np.float64)
        self._qdot = np.zeros(n)
        self._hold = self._q.copy()
        self._v_cmd = np.zeros(n)
        self._q_cmd = self._q.copy()
        self._k_cmd = 0  # step at which the last command arrived
        self._traj: _Hermite | None = None
        self._k_traj = 0
        self._demo: tuple[FloatArray, FloatArray, FloatArray, FloatArray, int] | None = None
        self._mode = "hold"
        if demo:
            self.start_demo()

    # ------------------------------------------------------------------ construction helpers
    @classmethod
    def from_chain(cls, chain: SerialChain, dt: float, **kwargs: Any) -> ArmSimulator:
        """Simulate the actuated joints of a `SerialChain` with its limits."""
        return cls(chain.joint_names, chain.lower, chain.upper, chain.velocity_limit, dt, **kwargs)

    @classmethod
    def from_urdf(cls, path_or_xml: str | PathLike[str], dt: float, **kwargs: Any) -> ArmSimulator:
        """Simulate every moving, non-mimic joint of a URDF (document order), e.g. arm + gripper.

        These are exactly the joints robot_state_publisher needs in ``joint_states``.
        """
        names, lower, upper, vel = urdf_actuated_joints(path_or_xml)
        return cls(names, lower, upper, vel, dt, **kwargs)

    # ------------------------------------------------------------------ state
    @property
    def time(self) -> float:
        """Simulated time [s] = steps taken × dt."""
        return self._k * self.dt

    @property
    def q(self) -> FloatArray:
        return self._q.copy()

    @property
    def qdot(self) -> FloatArray:
        return self._qdot.copy()

    @property
    def mode(self) -> str:
        """One of `MODES`: "demo", "velocity", "position", "trajectory", "hold"."""
        return self._mode

    @property
    def state(self) -> SimState:
        return SimState(self.time, self.q, self.qdot)

    # ------------------------------------------------------------------ commands
    def command_velocity(self, qdot: ArrayLike) -> None:
        """Move at joint velocities `qdot` (order `joint_names`) for `command_timeout` seconds.

        Values beyond ±velocity_limit are clamped while integrating.

        Raises:
            InvalidInputError: wrong length or non-finite values.
        """
        v = _vector(qdot, self.dof, "velocity command")
        self._v_cmd = v.copy()
        self._k_cmd = self._k
        self._mode = "velocity"

    def command_position(self, q: ArrayLike) -> None:
        """Move to joint positions `q` (order `joint_names`) and hold them until the next command.

        The arm moves there as fast as its velocity limits allow (a position streamed at the
        servo's rate is reached in one step when it is feasible); positions outside the limits
        are clamped while integrating.

        Raises:
            InvalidInputError: wrong length or non-finite values.
        """
        p = _vector(q, self.dof, "position command")
        self._q_cmd = p.copy()
        self._k_cmd = self._k
        self._mode = "position"

    def command_trajectory(
        self,
        times: ArrayLike,
        positions: ArrayLike,
        velocities: ArrayLike | None = None,
        joint_names: Sequence[str] | None = None,
    ) -> None:
        """Follow waypoints `positions[k]` reached `times[k]` seconds after now.

        Args:
            times: (m,) strictly increasing, ≥ 0 [s]. A waypoint at 0 replaces the current state
                (the arm then moves there as fast as its velocity limits allow).
            positions: (m, j) waypoint positions; outside the limits they are clamped.
            velocities: optional (m, j) waypoint velocities; else monotone tangents.
            joint_names: the j joints the columns refer to (default: all, in order). Joints not
                named hold their current position.

        Raises:
            InvalidInputError: empty trajectory, shape mismatch, NaN/inf, times not strictly
                increasing or negative, duplicate names.
            UnknownNameError: a joint name not simulated here.
        """
        cols = self._columns(joint_names)
        t = as_float_array(times, "trajectory times")
        if t.ndim != 1 or t.size == 0:
            raise InvalidInputError(f"a trajectory needs ≥ 1 waypoint time, got shape {t.shape}")
        check_finite(t, "trajectory times")
        if t[0] < 0:
            raise InvalidInputError(f"trajectory times must be ≥ 0, got {t[0]} first")
        if np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0))
            raise InvalidInputError(
                f"trajectory times must be strictly increasing: time[{k + 1}] = {t[k + 1]} "
                f"follows time[{k}] = {t[k]}"
            )
        m, j = t.size, len(cols)
        P_cmd = as_float_array(positions, "trajectory positions")
        if P_cmd.shape != (m, j):
            raise InvalidInputError(
                f"trajectory positions must have shape ({m} waypoints, {j} joints), "
                f"got {P_cmd.shape}"
            )
        check_finite(P_cmd, "trajectory positions")
        V_cmd = None
        if velocities is not None:
            V_cmd = as_float_array(velocities, "trajectory velocities")
            if V_cmd.shape != (m, j):
                raise InvalidInputError(
                    f"trajectory velocities must have shape ({m}, {j}), got {V_cmd.shape}"
                )
            check_finite(V_cmd, "trajectory velocities")

        # Full-width waypoints: unnamed joints hold where they are.
        P = np.tile(self._q, (m, 1))
        P[:, cols] = P_cmd
        P = np.clip(P, self.lower, self.upper)
        starts_now = t[0] == 0.0
        tau = t if starts_now else np.r_[0.0, t]
        if not starts_now:
            P = np.vstack((self._q, P))
        v_start = self._qdot if not starts_now else np.zeros(self.dof)
        if V_cmd is None:
            V = _monotone_tangents(tau, P, v_start)
        else:
            V = np.zeros((m, self.dof))
            V[:, cols] = V_cmd
            if not starts_now:
                V = np.vstack((v_start, V))
        self._traj = _Hermite(tau, P, V)
        self._k_traj = self._k
        self._k_cmd = self._k
        self._mode = "trajectory"

    def start_demo(self) -> None:
        """Start the demo motion from the current position, at rest (module docstring)."""
        q_s = self._q.copy()
        room_up, room_down = self.upper - q_s, q_s - self.lower
        alternate = np.where(np.arange(self.dof) % 2 == 0, 1.0, -1.0)
        sign = np.where(room_up > room_down, 1.0, np.where(room_up < room_down, -1.0, alternate))
        room = np.maximum(room_up, room_down)
        span = np.minimum(np.minimum(0.9 * room, 0.5 * (self.upper - self.lower)), self._demo_span)
        amplitude = 0.5 * span
        omega = 2 * np.pi / (self._demo_period * (1.0 + 0.2 * np.arange(self.dof)))
        with np.errstate(divide="ignore"):  # A = 0 (a joint with no room) needs no cap
            omega_max = np.where(amplitude > 0, 0.8 * self.velocity_limit / amplitude, omega)
        omega = np.minimum(omega, omega_max)
        self._demo = (q_s, sign, amplitude, omega, self._k)
        self._mode = "demo"

    def stop(self) -> None:
        """Hold the current position."""
        self._hold = self._q.copy()
        self._mode = "hold"

    def demo_position(self, t: float) -> FloatArray:
        """Demo reference at simulated time `t` [s] (valid while the demo runs)."""
        if self._demo is None:
            raise InvalidInputError("the demo has not been started")
        q_s, sign, amplitude, omega, k0 = self._demo
        return q_s + sign * amplitude * (1.0 - np.cos(omega * (t - k0 * self.dt)))

    def _columns(self, joint_names: Sequence[str] | None) -> list[int]:
        if joint_names is None:
            return list(range(self.dof))
        names = [str(n) for n in joint_names]
        if not names:
            raise InvalidInputError("a trajectory must name at least one joint")
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise InvalidInputError(f"duplicate joint names in the trajectory: {dup}")
        cols = []
        for name in names:
            if name not in self._index:
                raise UnknownNameError("joint", name, self.joint_names)
            cols.append(self._index[name])
        return cols

    # ------------------------------------------------------------------ integration
    def step(self) -> SimState:
        """Advance one step of `dt`; return the new (time, q, q̇)."""
        t_next = (self._k + 1) * self.dt
        idle_steps = self._k - self._k_cmd
        if self._mode == "velocity":
            if idle_steps * self.dt < self.command_timeout - 1e-12:
                target = self._q + self._v_cmd * self.dt
            else:
                self.stop()
                target = self._hold
        elif self._mode == "position":
            target = self._q_cmd
        elif self._mode == "trajectory":
            if self._traj is None:  # cannot happen: the mode is only set with a trajectory
                raise RuntimeError("trajectory mode without a trajectory")
            target = self._traj(t_next - self._k_traj * self.dt)
            if t_next - self._k_traj * self.dt >= self._traj.duration:
                self._hold = target
                self._mode = "hold"
                self._k_cmd = self._k + 1  # idle time counts from the end of the trajectory
        elif self._mode == "demo":
            target = self.demo_position(t_next)
        else:
            target = self._hold
            resume = self.demo_resume_after
            settled = np.array_equal(self._q, np.clip(self._hold, self.lower, self.upper))
            if resume is not None and idle_steps * self.dt >= resume and settled:
                self.start_demo()
                target = self.demo_position(t_next)

        # Every joint moves toward the reference in proportion, as fast as the slowest allows:
        # a reference out of one step's reach (a position command that came late, after a gap)
        # is approached along the straight line in joint space, not joint by joint (which bent
        # the tool's path by millimetres when the servo's stream of positions was held up).
        max_step = self.velocity_limit * self.dt
        delta = target - self._q
        with np.errstate(divide="ignore", invalid="ignore"):
            reach = np.max(np.where(delta != 0.0, np.abs(delta) / max_step, 0.0))
        if reach > 1.0:
            delta = delta / reach
        q_next = np.clip(self._q + delta, self.lower, self.upper)
        v_max = self.velocity_limit
        self._qdot = np.clip((q_next - self._q) / self.dt, -v_max, v_max)
        self._q = q_next
        self._k += 1
        return self.state


def urdf_actuated_joints(
    path_or_xml: str | PathLike[str],
) -> tuple[list[str], FloatArray, FloatArray, FloatArray]:
    """(names, lower, upper, velocity) of every moving joint without <mimic>, in document order
    (`core.urdf.RobotDescription.actuated_joints`).

    Raises:
        RobotDescriptionError: unreadable/malformed description or no moving joint.
    """
    return RobotDescription(path_or_xml).actuated_joints()
