"""`Servo`: from the measured joint state and a command, the next joint command for one period.

One period (`Servo.step`) does, on the last *commanded* joint state q (so that the output is
continuous whatever the arm's controller does; the measured state is used to start from where
the arm is and to notice an arm that does not follow):

1. Twist: the command is ramped within Cartesian acceleration and jerk limits
   (`twist_acceleration_time_s`), and the commanded pose T_ref is integrated from the ramped
   twist (ω, v) [base axes, about the tip origin]; the loop is closed on it: V = V_ramp + K e,
   e = (log(R_ref Rᵀ), p_ref − p). The error kept is bounded (`max_kept_error_*`): beyond it T_ref
   is pulled back along its own motion (`_pull_back`), so a blocked arm does not wind up, while
   an error across that motion is kept (T_ref stays on the commanded path) and corrected with e
   clipped to the bound, so a pure rotation does not drift. Pose: V points at the target, at
   min(K_pose d, v_max, √(2 a d)) for a distance d, which brakes to zero at the target. Jog: the
   joint velocities as given.
2. The followed rows of V are solved for q̇ by damped least squares (`dls`), which never stops at
   a singularity; near the edge of the workspace a commanded motion along the lost direction is
   braked within what the joints can follow, the commanded pose held back alike so that the tool
   stays on the commanded path (`_brake`); from an exact singularity, a command along the lost
   direction starts a motion along the singular joint direction where its second-order effect
   agrees (`_escape`). A redundant arm adds null-space motion away from its joint limits.
3. Joint limits: a joint near a position limit may move towards it no faster than it can still
   brake (`limits.braking_speed`, at half its acceleration and jerk). When the solution asks more,
   the joint is held at that speed and the other joints carry the largest share of the commanded
   twist they can carry exactly, the loop's correction whole (`task_scaling`, Flacco, De Luca &
   Khatib 2015's SNS with task scaling), each joint's velocity changing by little per period so
   that the smoothing does not lag; the commanded pose advances by the same share, so the tool
   slows along its path and a pure rotation keeps its point (`_scale_task`). The held joint's
   speed toward its bound only falls, and the share brakes ahead (`_share_brake`) before the
   joints taking over reach a singularity of their own or a position bound, so that they slow
   in proportion within their jerk limits; nor does it grow past what the joints taking over
   can follow along the bend of their own path (`_curvature_cap`), and where they lag, the
   smoothing is told the rate at which their targets move. A pure rotation at 0.5 rad/s through
   joint 7's limit (with Ruckig, the joints then stopping before joint 2's limit), arriving at
   it 0.2-1.5 rad after the start: the tool point within 0.025 mm on the Panda and 0.065 mm on
   the iiwa14 at 100 Hz, 500 Hz and 1 kHz (the start's null-space motion included; 9 s from
   the home pose: 0.009/0.030/0.067 and 0.008/0.002/0.002 mm; before, 0.46-0.64 mm arriving
   0.2-0.4 rad after the start). Otherwise the result
   is scaled into the velocity limits, the null-space motion giving way first, then the damped
   directions, then the whole.
4. Ruckig moves the commanded state toward that velocity within the acceleration and jerk limits
   (without Ruckig, a smoothing of our own does, within the acceleration limits: `smoothers`),
   with the joint acceleration J⁺(ẍ − J̇q̇) fed forward so that a ramping twist is followed
   without lag; guards re-plan a joint that would pass its velocity limit or could no longer stop
   inside its position limits (`smoothing`).

Stopping: a twist command that times out ramps to zero with the loop closed, so the tool stops on
its path (a ramp to zero, this one or a zero twist sent, is slowed to what every joint can follow,
so that the joints decelerate in proportion: `_stretch_stop`), and the loop stays closed until the arm is on the commanded pose (at most `_SETTLE_S`);
any other stop (a jog or pose timeout, a refused command, pause, the arm not following,
an unusable measurement) is step 4 with a target velocity of zero: a jerk-limited stop.

Cost: the per-joint arithmetic of a period works on lists of floats, and the forward kinematics
is the chain's generated scalar code called without re-checking the servo's own state; NumPy is
left the matrix products and the SVD (on 6 or 7 joints, a NumPy call costs more than the
arithmetic it does). `benchmarks/servo_benchmark.py --baseline REV` measures a step beside an
older revision's and checks that the outputs are the same.

Not thread-safe: call `submit`, `step`, `pause` and `resume` from one thread (or lock).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import chain as _concat
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import so3
from .._checks import check_transform
from ..chain import SerialChain
from ..exceptions import InvalidInputError, UnknownNameError
from ..model import readonly
from . import _quat, dls, task_scaling
from .axes import select_axes, task_jacobian_rows
from .commands import JointJogCommand, PoseCommand, TwistCommand
from .config import TWIST_AXES, ServoConfig
from .limits import ServoLimits, braking_distance, braking_speed_one, free_distances
from .smoothers import choose_smoothing
from .status import ServoStatus, StatusCode

FloatArray = NDArray[np.float64]

_NULLSPACE_SPEED_FRACTION = 0.05  # null-space motion uses at most this share of a joint's speed
# (a step of 0.2 moved the Panda's tool 0.8 mm as it began; 0.05: 0.04 mm)
_RESYNC_TOLERANCE = 1e-3  # [rad or m] a command starting from rest starts from the measured
# positions when they are farther than this from the last command (the arm was moved meanwhile);
# nearer, from the last command, so that the commanded positions stay continuous
_STOP_SHARE = 0.5  # a twist's ramp to zero asks each joint for at most this share of its
# acceleration and jerk limits, in proportion to its velocity (`Servo._stretch_stop`)
_STOP_SHARE_TAKING_OVER = 0.1  # ... and this share while the other joints carry a joint at its
# limit: they move fast for the twist and follow exactly only what the smoothing reaches within a
# period (a stop at 0.5 left the tool point by up to 0.47 mm on the Panda, at 0.1 by 0.03 mm)
_BRAKE_FROM_SIGMA = 0.08  # [m] a commanded motion toward a boundary singularity (σ_min falling,
# u_min mostly linear) is slowed along u_min from this σ_min (`Servo._brake`) ...
_BRAKE_TO_SIGMA = 0.02  # [m] ... to nothing at this one (0.03-0.04, 0.1-0.12 measured: no better)
_BRAKE_CHECK_SIGMA = 0.2  # [m] below this σ_min the motion along u_min is kept within what the
# joints' acceleration can follow (q̇ = r/σ along v_min), toward the singularity or away from it
_LEAVE_SPEED = 0.1  # [m/s] leaving a singularity, the task speed along u_min is never held below
# this (0.02-0.05 left the iiwa14's straight elbow in 0.53 s, against the test's 0.5 s)
_COMMANDED_SPEED = 0.01  # [m/s] only a commanded linear speed along u_min above this is braked
_RATE_SIGMA = 0.1  # [m] below this σ_min the joint speed along v_min may grow by at most ...
_RATE_SHARE = 0.5  # ... this share of the planning acceleration per period (`Servo._brake`).
# Measured out to the edge and back (benchmarks/servo_benchmark.py, largest distance from the
# line, UR5e/Panda/iiwa14): share 0.5: 6/5/4 mm; 0.25: 6/9/6; 1: 7/5/4. Below σ_min 0.05: 9-11 mm
# on the UR5e; below 0.15, the steps script's path error 92 mm on the UR5e (67 at 0.1); below 0.2,
# 141 mm on the iiwa14 (74)
_REACH_SHARE = 0.5  # a braked motion is slowed along its joint direction to what each joint
# reaches from its velocity within this share of its planning acceleration in one period (1 or 2:
# the same edge figures, the steps script's path error 77-81 mm on the UR5e, 67 at 0.5)
_SLOPE_RATE = 0.05  # [rad/s] joint speed along v_min above which dσ/dθ is read off J̇
_BRAKE_LINEAR_SHARE = 0.5  # only where u_min is mostly linear (|u_lin|² ≥ this): not a wrist
_TASK_REACH_WIDENING = (0.1, 1.0, 2.0, 4.0, 8.0)  # a motion slowed at a joint limit changes each
# joint's velocity by at most the first of these × _REACH_SHARE of its planning acceleration per
# period (the Panda's pure rotation through joint 7's limit: 0.25: 0.01 mm off the point while
# slowed, 0.1: 0.006 mm); the others only where nothing fits within it
_TAKE_OVER_SHARE = 0.25  # at a joint limit, the other joints' velocities change by at most this
# share of their acceleration limits per second (`Servo._exact_motion`): the largest share of
# the task one period ahead, unbounded, spun them up until they could not be slowed in time
_SHARE_BRAKE = 0.5  # the share of the command slows, before a singularity of the joints taking
# over or a position bound, at what every joint follows at this share of its take-over
# acceleration and jerk limit (`Servo._share_brake`)
_SHARE_OVERSHOOT = 1.5  # where the joints cannot slow in time, the share of the command may
# pass what it is allowed (up to this; below 0 down to 1 - this): along the path still
_PERIODS = (1.0, 2.0, 4.0, 8.0, 16.0)  # where nothing the joints reach in one period keeps the
# path, what they reach in this many (the smoothing lags a little): 1 kHz, Panda 3.2 -> 0.8 mm
_TAKE_OVER_TIME_S = 1.0  # at a joint limit the share grows from 0 to 1 in no less than this
# (faster, the joints' take-over gathered more motion than they could slow in time: Panda
# 0.29 mm with no bound, 0.13 with this)
_CURVATURE_STEP = 1e-3  # [rad or m] the largest joint's step along the take-over path over
# which its bend is measured (`Servo._curvature_cap`)
_CURVATURE_SHARE = 0.5  # at a joint limit, the share of the command is kept where following the
# bend of the take-over path needs at most this share of each joint's take-over acceleration
_SETTLE_S = 1.0  # [s] after a twist command's timeout has ramped the twist to zero, the loop stays
# closed at most this long for the arm to reach the reference (K = 10/s leaves e⁻¹⁰ of a gap)


@dataclass(frozen=True)
class ServoOutput:
    """The joint command for the coming period and the servo's status.

    Attributes:
        positions: (n,) joint positions to reach at `time_s` [rad or m], chain joint order.
        velocities: (n,) joint velocities at `time_s` [rad/s or m/s].
        accelerations: (n,) joint accelerations at `time_s` [rad/s² or m/s²].
        time_s: the `now_s` of the step plus one period [s].
        status: what the servo did on this cycle.
    """

    positions: FloatArray
    velocities: FloatArray
    accelerations: FloatArray
    time_s: float
    status: ServoStatus


def _finite_reals(values: Any, count: int | None) -> tuple[float, ...] | None:
    """The values as floats if they are `count` finite real numbers (any count if None)."""
    if (
        (type(values) is tuple or type(values) is list)
        and (count is None or len(values) == count)
        and all(type(x) is float for x in values)
        and math.isfinite(sum(values))  # else one of them is not (or the sum overflows: below)
    ):
        return tuple(values)
    try:
        items = list(values)
    except TypeError:
        return None
    if count is not None and len(items) != count:
        return None
    out = []
    for x in items:
        if type(x) is not float and (
            isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating))
        ):
            return None
        f = float(x)
        if not math.isfinite(f):
            return None
        out.append(f)
    return tuple(out)


def _norm3(x: float, y: float, z: float) -> float:
    return math.sqrt(x * x + y * y + z * z)


def _rotation(t: Sequence[float]) -> FloatArray:
    """The (3, 3) rotation of a pose given as 12 floats (rotation row-major, then position)."""
    return np.array(((t[0], t[1], t[2]), (t[3], t[4], t[5]), (t[6], t[7], t[8])))


def _pull_back(
    error: Sequence[float], norm: float, moving: Sequence[float], bound: float
) -> tuple[tuple[float, float, float], tuple[float, float, float], float]:
    """Bound the kept error e (3,) (the commanded pose less the arm's, angular or linear part)
    by moving the commanded pose back along its own motion `moving` (3,) only.

    The commanded pose runs ahead of an arm held back (a joint limit, the edge of the workspace)
    along the commanded twist: that part of the error is taken back, so the arm does not wind up.
    Across the twist the commanded pose does not move: an error there is the arm's own deviation
    (damped least squares beside a singularity gives up some accuracy), and pulling the commanded
    pose toward the arm would move it off the commanded path for good (14 mm after a spin beside
    the UR5e's wrist singularity, 130-282 mm out to the edge of the workspace and back). It is
    kept, and the loop's correction uses it clipped to the bound.

    Returns (kept error, error for the loop's correction, |kept error|).
    """
    e = (error[0], error[1], error[2])
    if norm <= bound:
        return e, e, norm
    mx, my, mz = moving
    speed = _norm3(mx, my, mz)
    if speed > 0.0:
        dx, dy, dz = mx / speed, my / speed, mz / speed
        along = e[0] * dx + e[1] * dy + e[2] * dz
        px, py, pz = e[0] - along * dx, e[1] - along * dy, e[2] - along * dz
        across = _norm3(px, py, pz)
        room = bound * bound - across * across
        kept_along = min(abs(along), math.sqrt(room)) if room > 0.0 else 0.0
        kept_along = kept_along if along >= 0.0 else -kept_along
        e = (px + kept_along * dx, py + kept_along * dy, pz + kept_along * dz)
        norm = _norm3(*e)
    if norm <= bound:
        return e, e, norm
    s = bound / norm
    return e, (e[0] * s, e[1] * s, e[2] * s), norm


class Servo:
    """Servoing of one serial chain: twist, joint jog and pose commands in, joint commands out.

    Usage (one `step` per `config.period_s`, commands whenever they arrive)::

        servo = Servo(chain, q_measured, ServoConfig(period_s=0.002))
        servo.submit(TwistCommand((0, 0, 0.5), (0.1, 0, 0), "base_link", stamp_s=t), now_s=t)
        out = servo.step(now_s=t, measured_positions=q_measured)
        send(out.positions, out.velocities); publish(out.status)

    Args:
        chain: the arm.
        initial_positions: (n,) measured joint positions; the servo starts at rest there.
        config: settings (defaults: `ServoConfig()`).

    Raises:
        InvalidInputError: bad initial positions, or a configuration the chain cannot meet (a joint
            range narrower than its margins, more task axes than joints).
        UnknownNameError: a limit override names a joint the chain does not have.
        MissingDependencyError: `config.smoothing` is "ruckig" and Ruckig is not installed.
    """

    def __init__(
        self, chain: SerialChain, initial_positions: ArrayLike, config: ServoConfig | None = None
    ) -> None:
        if not isinstance(chain, SerialChain):
            raise InvalidInputError(f"chain must be a SerialChain, got {type(chain).__name__}")
        cfg = ServoConfig() if config is None else config
        if not isinstance(cfg, ServoConfig):
            raise InvalidInputError(f"config must be a ServoConfig, got {type(cfg).__name__}")
        q0 = chain.check_q(initial_positions, "initial_positions")
        if q0.shape != (chain.dof,):
            raise InvalidInputError(
                f"initial_positions must have shape ({chain.dof},), got {q0.shape}"
            )
        self.chain = chain
        self.config = cfg
        self.limits = ServoLimits.from_chain(chain, cfg)
        rows, dropped = select_axes(chain, cfg)
        self._rows = np.array(rows)
        self._all_rows = len(rows) == 6
        self._linear_rows = np.array([i >= 3 for i in rows])
        self.task_axes: tuple[str, ...] = tuple(TWIST_AXES[i] for i in rows)
        self.dropped_axes: tuple[str, ...] = dropped
        self._dropped_note = (
            f"; follows {', '.join(self.task_axes)} in {cfg.task_axes_frame} axes, "
            f"drops {', '.join(dropped)}"
        )
        keep = np.zeros(6, dtype=bool)
        keep[self._rows] = True
        self._dropped_mask = ~keep
        self._dropped: tuple[bool, ...] = tuple(self._dropped_mask.tolist())
        # Ruckig's jerk-limited smoothing, or the acceleration-limited one without it (`smoothers`)
        self.smoothing = choose_smoothing(cfg.smoothing)
        self._integrator = self.smoothing.integrator(self.limits, cfg.period_s, q0)
        n = chain.dof
        lim = self.limits
        # Beyond this distance from a bound, braking never limits a joint's speed.
        # The braking the velocity planning uses (half the joint's acceleration and jerk, see
        # _velocity_box); beyond this distance from a bound it never limits a joint's speed.
        self._plan_acceleration = 0.5 * lim.acceleration
        self._plan_jerk = 0.5 * lim.jerk
        self._plan_acceleration_list: list[float] = self._plan_acceleration.tolist()
        self._take_over_acceleration: list[float] = (_TAKE_OVER_SHARE * lim.acceleration).tolist()
        self._brake_acc: list[float] = (_SHARE_BRAKE * _TAKE_OVER_SHARE * lim.acceleration).tolist()
        self._brake_jerk: list[float] = (_SHARE_BRAKE * lim.jerk).tolist()
        zone = braking_distance(lim.velocity, self._plan_acceleration, self._plan_jerk) + (
            2.0 * cfg.period_s * lim.velocity
        )
        # Per-joint constants of the period as lists of floats: on 6 or 7 joints, plain Python
        # arithmetic costs less than NumPy calls (~1 µs each) and gives the same floats.
        self._slow_low: list[float] = (lim.lower + zone).tolist()
        self._slow_high: list[float] = (lim.upper - zone).tolist()
        self._lower: list[float] = lim.lower.tolist()
        self._upper: list[float] = lim.upper.tolist()
        self._v_high: list[float] = lim.velocity.tolist()
        self._v_low: list[float] = (-lim.velocity).tolist()
        # A side of a joint whose bound is farther than `_free` and `_free_at_rest` + 2 dt × its
        # speed never limits it (`free_distances`): `_velocity_box` skips it.
        free, free_at_rest = free_distances(
            lim.velocity, self._plan_acceleration, self._plan_jerk, 2.0 * cfg.period_s
        )
        self._free: list[float] = free.tolist()
        self._free_at_rest: list[float] = free_at_rest.tolist()
        A, J = self._plan_acceleration, self._plan_jerk
        # per joint, for `_velocity_box`: (lower, upper, free, free_at_rest, A, J, A²/J, v_max)
        self._box_constants = list(
            zip(
                self._lower,
                self._upper,
                self._free,
                self._free_at_rest,
                A.tolist(),
                J.tolist(),
                (A * A / J).tolist(),
                self._v_high,
                strict=True,
            )
        )
        bounded = np.isfinite(lim.lower) & np.isfinite(lim.upper)
        lower_b = np.where(bounded, lim.lower, 0.0)
        upper_b = np.where(bounded, lim.upper, 0.0)
        half = 0.5 * (upper_b - lower_b)
        self._mid: list[float] = (0.5 * (lower_b + upper_b)).tolist()
        self._inv_half: list[float] = np.where(
            half > 0, 1.0 / np.where(half > 0, half, 1.0), 0.0
        ).tolist()
        self._inv_null_cap: list[float] = (
            1.0 / (_NULLSPACE_SPEED_FRACTION * lim.velocity)
        ).tolist()
        self._null_coef: list[float] = (-cfg.nullspace_gain_1_per_s * half).tolist()
        self._zeros = readonly(np.zeros(n))
        self._zero_list = [0.0] * n
        self._no_joint = readonly(np.zeros(n, dtype=bool), np.bool_)
        self._base = chain.link_names[0]
        self._tip = chain.link_names[-1]
        self._links = frozenset(chain.link_names)
        self._n = n
        # The chain's generated forward kinematics on floats (what `chain.fk_jacobian` calls after
        # checking its input, which the servo's own state does not need).
        model = chain.solver_model
        self._fk_world = model.kernel.fk_world
        self._fk_pose = model.kernel.fk_pose
        self._to_internal = model.to_internal
        self._G = model.G
        self._n_internal = model.kernel.n
        self._tip_pose: tuple[float, ...] = ()  # at the commanded q of this period (12 floats)
        # Active command, in the form the steps use.
        self._mode: str | None = None
        self._winding_down = False  # a twist command timed out: its twist is ramping to zero
        self._settle_until: float | None = None  # then the loop stays closed at most until this
        self._stamp = 0.0
        self._twist_frame = self._base
        self._twist: tuple[float, ...] = (
            0.0,
        ) * 6  # (ω, v) in the command frame's axes, already speed-limited
        self._twist_scaled = False
        self._jog: list[float] = [0.0] * n
        self._jog_scaled = False
        self._goal_p = (0.0, 0.0, 0.0)
        self._goal_q: _quat.Quat = (0.0, 0.0, 0.0, 1.0)
        self._ref_valid = False
        lin_a = cfg.max_linear_speed_m_s / cfg.twist_acceleration_time_s
        ang_a = cfg.max_angular_speed_rad_s / cfg.twist_acceleration_time_s
        acc = np.array((ang_a, ang_a, ang_a, lin_a, lin_a, lin_a))
        self._ramp = self.smoothing.ramp(acc, acc / cfg.jerk_time_s, cfg.period_s)
        self._ramp_acc: list[float] = acc.tolist()
        self._ramp_jerk: list[float] = (acc / cfg.jerk_time_s).tolist()
        self._stop_acc: list[float] = (_STOP_SHARE * lim.acceleration).tolist()
        self._stop_jerk: list[float] = (_STOP_SHARE * lim.jerk).tolist()
        self._ramp_valid = False
        self._ramp_held = False  # invalidated by `_hold_ramp` (not by a new command)
        self._ramp_target: list[float] = [0.0] * 6
        self._last_jacobian: FloatArray | None = None  # the task Jacobian of the last period
        self._task_share = 1.0  # the share of the commanded twist of the last period
        self._last_take_over: list[float] | None = None
        self._free_sigma: float | None = None  # the free joints' σ_min then (`_exact_motion`)
        self._exact = False  # the last period's joint velocities were reached exactly (`follow`)
        self._null_ease = 0.0  # share of the null-space speed allowed (eased in per command)
        self._anchor: FloatArray = self._integrator.q  # last well-conditioned configuration
        self._ref_p = (0.0, 0.0, 0.0)
        self._ref_q: _quat.Quat = (0.0, 0.0, 0.0, 1.0)
        self._stop: tuple[StatusCode, str] = (StatusCode.IDLE, "waiting for a command")
        self._paused = False
        self._measured: FloatArray | None = q0.copy()
        self._accepted = {  # what `submit` answers to an accepted command (immutable: shared)
            kind: ServoStatus(StatusCode.OK, f"{kind.__name__} accepted", dropped_axes=dropped)
            for kind in (TwistCommand, JointJogCommand, PoseCommand)
        }

    # ------------------------------------------------------------------ state
    @property
    def positions(self) -> FloatArray:
        """The last commanded joint positions (n,) [rad or m] (read-only)."""
        return self._integrator.q

    @property
    def velocities(self) -> FloatArray:
        """The last commanded joint velocities (n,) [rad/s or m/s] (read-only)."""
        return self._integrator.v

    @property
    def accelerations(self) -> FloatArray:
        """The last commanded joint accelerations (n,) [rad/s² or m/s²] (read-only)."""
        return self._integrator.a

    @property
    def paused(self) -> bool:
        return self._paused

    def reset(self, positions: ArrayLike) -> None:
        """Forget the command and the commanded state: at rest at `positions` (n,), idle.

        Raises:
            InvalidInputError: wrong length or non-finite positions.
        """
        q = self.chain.check_q(positions, "positions")
        if q.shape != (self._n,):
            raise InvalidInputError(f"positions must have shape ({self._n},), got {q.shape}")
        self._integrator.reset(q)
        self._measured = q.copy()
        self._end(StatusCode.IDLE, "reset; waiting for a command")

    def pause(self) -> None:
        """Stop smoothly and refuse commands until `resume`."""
        self._paused = True
        self._end(StatusCode.PAUSED, "paused; commands are refused until resumed")

    def resume(self) -> None:
        """Accept commands again (the command active before the pause is not resumed)."""
        if self._paused:
            self._paused = False
            self._end(StatusCode.IDLE, "resumed; waiting for a command")

    def _end(self, code: StatusCode, message: str) -> None:
        """Drop the active command: the arm stops smoothly, and the status says why."""
        self._mode = None
        self._winding_down = False
        self._last_jacobian = None
        self._task_share = 1.0
        self._last_take_over = None
        self._exact = False
        self._ref_valid = False
        self._ramp_valid = False
        self._ramp_held = False
        self._stop = (code, message)

    # ------------------------------------------------------------------ commands
    def submit(self, command: Any, now_s: float) -> ServoStatus:
        """Take a new command (it replaces the active one) or refuse it.

        A refused command also ends the active one: the arm stops smoothly, and every `step`
        reports the refusal until a command is accepted. A stale one (COMMAND_STALE) is the
        exception: it says nothing about now, so it leaves the active command to its own timeout
        (commands queued while the receiver was held up arrive stale, with fresh ones behind them).
        Never raises.

        Args:
            command: a `TwistCommand`, `JointJogCommand` or `PoseCommand`.
            now_s: the current time [s], on the clock of the command's `stamp_s`.

        Returns:
            OK if accepted; COMMAND_STALE (stamp older than the timeout, or as far in the future)
            or COMMAND_REFUSED (with the reason) otherwise.
        """
        problem = self._check_time(now_s, "now_s")
        if problem is None:
            problem = self._accept(command, float(now_s))
        if problem is not None:
            code, message = problem
            if not self._paused and code != StatusCode.COMMAND_STALE:
                self._end(code, message)
            return ServoStatus(code, message, dropped_axes=self.dropped_axes)
        accepted = self._accepted.get(type(command))
        if accepted is None:  # a subclass of a command type
            accepted = ServoStatus(
                StatusCode.OK, f"{type(command).__name__} accepted", dropped_axes=self.dropped_axes
            )
        return accepted

    @staticmethod
    def _check_time(value: Any, name: str) -> tuple[StatusCode, str] | None:
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float, np.integer, np.floating))
            or not math.isfinite(value)
        ):
            return StatusCode.COMMAND_REFUSED, f"{name} must be a finite number [s], got {value!r}"
        return None

    def _accept(self, command: Any, now: float) -> tuple[StatusCode, str] | None:
        cfg = self.config
        kind = type(command).__name__
        if not isinstance(command, (TwistCommand, JointJogCommand, PoseCommand)):
            return (
                StatusCode.COMMAND_REFUSED,
                f"unknown command type {kind}; expected TwistCommand, JointJogCommand or "
                "PoseCommand",
            )
        if self._paused:
            return StatusCode.COMMAND_REFUSED, f"{kind} refused: the servo is paused"
        stamp = command.stamp_s
        if type(stamp) is not float or not math.isfinite(stamp):
            problem = self._check_time(stamp, f"{kind}.stamp_s")
            if problem is not None:
                return problem
        age = now - float(stamp)
        if age > cfg.command_timeout_s:
            return (
                StatusCode.COMMAND_STALE,
                f"{kind} stamped {age:.3f} s ago, older than the {cfg.command_timeout_s:g} s "
                "command timeout",
            )
        if -age > cfg.command_timeout_s:
            return (
                StatusCode.COMMAND_STALE,
                f"{kind} stamped {-age:.3f} s in the future (beyond the "
                f"{cfg.command_timeout_s:g} s command timeout): is the sender's clock off?",
            )
        if isinstance(command, TwistCommand):
            return self._accept_twist(command)
        if isinstance(command, JointJogCommand):
            return self._accept_jog(command)
        return self._accept_pose(command)

    def _frame_problem(self, kind: str, frame: Any) -> tuple[StatusCode, str] | None:
        if isinstance(frame, str) and frame in self._links:
            return None
        shown = frame if isinstance(frame, str) else repr(frame)
        err = UnknownNameError("frame", str(shown)[:80], self.chain.link_names)
        return StatusCode.COMMAND_REFUSED, f"{kind} refused: {err}"

    def _begin(self, mode: str, stamp: float) -> None:
        """Make `mode` the active command; from rest, start where the arm was measured if it was
        moved meanwhile (see _RESYNC_TOLERANCE)."""
        integ = self._integrator
        if (
            self._mode is None
            and integ.at_rest
            and self._measured is not None
            and np.abs(self._measured - integ.q).max() > _RESYNC_TOLERANCE
        ):
            integ.reset(self._measured)
        if self._mode != mode:
            self._last_jacobian = None
            self._task_share = 1.0
            self._exact = False
            self._null_ease = 0.0
            self._ref_valid = False
            self._ramp_valid = False
            self._ramp_held = False
        self._mode = mode
        self._stamp = stamp
        self._winding_down = False

    def _accept_twist(self, cmd: TwistCommand) -> tuple[StatusCode, str] | None:
        cfg = self.config
        w = _finite_reals(cmd.angular, 3)
        v = _finite_reals(cmd.linear, 3)
        if w is None or v is None:
            bad = "angular" if w is None else "linear"
            return (
                StatusCode.COMMAND_REFUSED,
                f"TwistCommand refused: {bad} must be 3 finite numbers, got {getattr(cmd, bad)!r}"[
                    :300
                ],
            )
        problem = self._frame_problem("TwistCommand", cmd.frame)
        if problem is not None:
            return problem
        speed_w, speed_v = _norm3(*w), _norm3(*v)
        factor = cfg.huge_command_factor
        if (
            speed_v > factor * cfg.max_linear_speed_m_s
            or speed_w > factor * cfg.max_angular_speed_rad_s
        ):
            return (
                StatusCode.COMMAND_REFUSED,
                f"TwistCommand refused: |v| = {speed_v:.4g} m/s, |ω| = {speed_w:.4g} rad/s is more "
                f"than {factor:g}× the maximum ({cfg.max_linear_speed_m_s:g} m/s, "
                f"{cfg.max_angular_speed_rad_s:g} rad/s): a unit error?",
            )
        scale = min(
            1.0,
            cfg.max_linear_speed_m_s / speed_v if speed_v > 0 else 1.0,
            cfg.max_angular_speed_rad_s / speed_w if speed_w > 0 else 1.0,
        )
        self._begin("twist", float(cmd.stamp_s))
        self._twist_frame = cmd.frame
        self._twist = w + v if scale == 1.0 else tuple(x * scale for x in w + v)
        self._twist_scaled = scale < 1.0
        return None

    def _accept_jog(self, cmd: JointJogCommand) -> tuple[StatusCode, str] | None:
        names = cmd.joint_names
        if isinstance(names, str) or not isinstance(names, Sequence):
            return (
                StatusCode.COMMAND_REFUSED,
                f"JointJogCommand refused: joint_names must be a sequence of names, got {names!r}",
            )
        vel = _finite_reals(cmd.velocities, len(names))
        if vel is None:
            return (
                StatusCode.COMMAND_REFUSED,
                f"JointJogCommand refused: velocities must be {len(names)} finite numbers (one per "
                f"joint name), got {cmd.velocities!r}"[:300],
            )
        jog = [0.0] * self._n
        seen: set[str] = set()
        for name, value in zip(names, vel, strict=True):
            if not isinstance(name, str) or name not in self.chain.joint_names:
                err = UnknownNameError("joint", str(name)[:80], self.chain.joint_names)
                return StatusCode.COMMAND_REFUSED, f"JointJogCommand refused: {err}"
            if name in seen:
                return (
                    StatusCode.COMMAND_REFUSED,
                    f"JointJogCommand refused: joint {name!r} is named twice",
                )
            seen.add(name)
            jog[self.chain.joint_names.index(name)] = value
        vmax = self.limits.velocity
        factor = self.config.huge_command_factor
        huge = np.abs(jog) > factor * vmax
        if huge.any():
            k = int(np.flatnonzero(huge)[0])
            return (
                StatusCode.COMMAND_REFUSED,
                f"JointJogCommand refused: joint {self.chain.joint_names[k]!r} at {jog[k]:.4g} is "
                f"more than {factor:g}× its velocity limit {vmax[k]:.4g}: a unit error?",
            )
        self._begin("jog", float(cmd.stamp_s))
        self._jog = jog
        return None

    def _accept_pose(self, cmd: PoseCommand) -> tuple[StatusCode, str] | None:
        problem = self._frame_problem("PoseCommand", cmd.frame)
        if problem is not None:
            return problem
        try:
            T = check_transform(cmd.T_frame_tip, "PoseCommand.T_frame_tip")
        except InvalidInputError as exc:
            return StatusCode.COMMAND_REFUSED, f"PoseCommand refused: {exc}"[:400]
        if T.shape != (4, 4):
            return (
                StatusCode.COMMAND_REFUSED,
                f"PoseCommand refused: T_frame_tip must be one 4×4 transform, got shape {T.shape}",
            )
        if cmd.frame != self._base:
            T = self.chain.link_pose(self._integrator.q, cmd.frame) @ T
        center, radius = self.chain.reach_sphere
        dist = float(np.linalg.norm(T[:3, 3] - center))
        if not dist <= radius + self.config.max_kept_error_m:
            return (
                StatusCode.COMMAND_REFUSED,
                f"PoseCommand refused: the target is {dist:.4g} m from the arm's first joint, out "
                f"of its reach ({radius:.4g} m at most)",
            )
        self._begin("pose", float(cmd.stamp_s))
        self._goal_p = (float(T[0, 3]), float(T[1, 3]), float(T[2, 3]))
        self._goal_q = so3.quaternion_from_rows(T[:3, :3].ravel().tolist())
        return None

    # ------------------------------------------------------------------ the period
    def step(
        self, now_s: float, measured_positions: ArrayLike | None = None, held_up: bool = False
    ) -> ServoOutput:
        """The joint command for the period starting at `now_s`. Never raises; never non-finite.

        Args:
            now_s: the current time [s], on the clock of the commands' stamps.
            measured_positions: (n,) the arm's joint positions now, chain order, if known. Used to
                start from where the arm is and to notice an arm that does not follow; the
                servo's trajectory itself continues from its own commanded state.
            held_up: the caller was held up before this period (a late period, or one made up
                after it): commands sent meanwhile may still wait to be taken, so the command
                timeout is not judged on it. The next period judges it; a sender that did stop
                has the arm move on for the hold-up and one more period.
        """
        cfg = self.config
        integ = self._integrator
        trouble: tuple[StatusCode, str] | None = self._check_time(now_s, "now_s")
        now = float(now_s) if trouble is None else self._stamp
        if trouble is not None:
            trouble = (StatusCode.STATE_REFUSED, trouble[1])
        if measured_positions is not None and trouble is None:
            trouble = self._take_measurement(measured_positions)
        if trouble is not None and self._mode is not None:
            self._end(*trouble)
        if (
            self._mode is not None
            and not self._winding_down
            and not held_up
            and now - self._stamp > cfg.command_timeout_s
        ):
            message = (
                f"no command for {now - self._stamp:.3f} s (timeout {cfg.command_timeout_s:g} s): "
                "stopping"
            )
            if self._mode == "twist":
                # Ramp the twist down to zero with the loop still closed: the tool stops on its
                # path (a joint-space stop would bend it), then the joints come to rest.
                self._winding_down = True
                self._settle_until = None
                self._twist = (0.0,) * 6
                self._stop = (StatusCode.TIMEOUT_STOP, message + " along the path")
            else:
                self._end(StatusCode.TIMEOUT_STOP, message)
        details: dict[str, Any] = {}
        if self._mode is None:
            target = self._zero_list
        elif self._mode == "jog":
            target = self._jog_target(details)
        else:
            target = self._task_target(details)
        if details.get("exact"):
            braking = integ.follow(target)
        else:
            braking = integ.step(target, details.get("target_acceleration"))
        self._exact = bool(details.get("exact"))
        if self._winding_down and not (any(self._ramp.v) or any(self._ramp.a)):
            # The twist is down to zero. The loop stays closed until the arm is on the
            # reference (within a tenth of the pose tolerances), for at most _SETTLE_S: the
            # joints still move when the twist ends, and stopping them joint by joint bent the
            # tool off its path (3.7 mm after 10 s of rotation on the UR5e).
            if self._settle_until is None:
                self._settle_until = now + _SETTLE_S
            pos_err, ang_err = details.get("errors", (0.0, 0.0))
            if (
                pos_err <= 0.1 * cfg.pose_position_tolerance_m
                and ang_err <= 0.1 * cfg.pose_orientation_tolerance_rad
            ) or now >= self._settle_until:
                self._end(*self._stop)  # then the joints settle
        if braking is not None:
            at_limit = details.get("at_limit", self._no_joint) | np.array(braking)
            details["at_limit"] = at_limit
        status = self._status(trouble, details)
        return ServoOutput(integ.q, integ.v, integ.a, now + cfg.period_s, status)

    def _take_measurement(self, measured: ArrayLike) -> tuple[StatusCode, str] | None:
        try:
            q = np.array(measured, dtype=np.float64)  # a copy: the caller may reuse its buffer
        except (TypeError, ValueError):
            return StatusCode.STATE_REFUSED, "measured_positions must be numbers"
        if q.shape != (self._n,):
            return (
                StatusCode.STATE_REFUSED,
                f"measured_positions must have {self._n} values (joints "
                f"{list(self.chain.joint_names)}), got shape {q.shape}",
            )
        values = q.tolist()
        # A non-finite value makes the sum non-finite; a finite sum rules them out (an overflowing
        # sum of finite values is checked one by one).
        if not math.isfinite(sum(values)) and not np.isfinite(q).all():
            return StatusCode.STATE_REFUSED, "measured_positions contains a non-finite value"
        self._measured = q
        integ = self._integrator
        if self._mode is not None and not integ.at_rest:
            dev = [abs(m - c) for m, c in zip(values, integ.q_list, strict=True)]
            worst = max(dev)
            if worst > self.config.max_following_error:
                k = dev.index(worst)
                return (
                    StatusCode.NOT_FOLLOWING,
                    f"joint {self.chain.joint_names[k]!r} is {dev[k]:.3g} from its command (more "
                    f"than {self.config.max_following_error:g}): the arm is not following; stopping",
                )
        return None

    # ------------------------------------------------------------------ velocity bounds
    def _velocity_box(self) -> tuple[list[float], list[float], list[bool] | None]:
        """(lo, hi, position-limited joints or None when none is): the joint velocities allowed
        this period.

        A joint may move toward a bound at d no faster than it can still stop within d less the
        distance covered before a stop could begin (the speed asked now is held for a period: at
        the current speed or the one asked, whichever is higher), braking at half its
        acceleration and jerk: min(v_max, s(d − 2 dt max(|v|, s(d)))), s = `braking_speed`.
        That is v_max itself beyond the distances of `limits.free_distances`; only the other
        sides are computed (the result is the same floats).
        """
        integ = self._integrator
        q = integ.q_list
        v_low, v_high = self._v_low, self._v_high
        if all(a < x < b for x, a, b in zip(q, self._slow_low, self._slow_high, strict=True)):
            return v_low, v_high, None
        dt2 = 2.0 * self.config.period_s
        hi: list[float] | None = None
        lo: list[float] = v_low
        for k, (x, vk, c) in enumerate(zip(q, integ.v_list, self._box_constants, strict=True)):
            lower, upper, free, free_at_rest, A, J, b, vm = c
            speed = abs(vk)
            near = free_at_rest + dt2 * speed * (1.0 + 1e-9)
            for d, up in ((upper - x, True), (x - lower, False)):
                if d >= free and d >= near:
                    continue  # not limited (see above); an infinite distance is never near
                s = braking_speed_one(d, A, J, b)
                s = braking_speed_one(d - dt2 * (s if s > speed else speed), A, J, b)
                if s < vm:
                    if hi is None:
                        hi, lo = list(v_high), list(v_low)
                    if up:
                        hi[k] = s
                    else:
                        lo[k] = -s
        if hi is None:
            return v_low, v_high, None
        limited = [h < vm or lw > -vm for h, lw, vm in zip(hi, lo, v_high, strict=True)]
        return lo, hi, limited

    @staticmethod
    def _max_scale(
        base: Sequence[float], part: Sequence[float], lo: Sequence[float], hi: Sequence[float]
    ) -> float:
        """The largest s ∈ [0, 1] with lo ≤ base + s·part ≤ hi (base inside the box)."""
        if all(a <= b + p <= c for b, p, a, c in zip(base, part, lo, hi, strict=True)):
            return 1.0
        s = math.inf
        for b, p, a, c in zip(base, part, lo, hi, strict=True):
            if p > 0.0:
                s = min(s, (c - b) / p)
            elif p < 0.0:
                s = min(s, (a - b) / p)
        return min(1.0, max(0.0, s))

    # ------------------------------------------------------------------ jog
    def _jog_target(self, details: dict[str, Any]) -> list[float]:
        lo, hi, _ = self._velocity_box()
        want = self._jog
        qd = [a if w < a else b if w > b else w for w, a, b in zip(want, lo, hi, strict=True)]
        held = [abs(d - w) > 1e-12 for d, w in zip(qd, want, strict=True)]
        details["at_limit"] = np.array(held) if any(held) else self._no_joint
        vmax = self._v_high
        if any(abs(d) > vm for d, vm in zip(qd, vmax, strict=True)):
            scale = min(vm / abs(d) for d, vm in zip(qd, vmax, strict=True) if d != 0.0)
            qd = [d * scale for d in qd]
            details["scaled"] = True
        details["condition"] = None
        return qd

    # ------------------------------------------------------------------ twist and pose
    def _task_target(self, details: dict[str, Any]) -> list[float]:
        cfg = self.config
        t, J = self._world_jacobian(self._integrator.q_list)
        self._tip_pose = t
        p = (t[9], t[10], t[11])
        q_now = so3.quaternion_from_rows(t)
        tip_axes = cfg.task_axes_frame == "tip"
        R = (
            _rotation(t)
            if tip_axes or (self._mode == "twist" and self._twist_frame == self._tip)
            else None
        )
        if self._mode == "twist":
            x = self._twist_task(R, p, q_now, tip_axes, details)
        else:
            x = self._pose_task(R, p, q_now, tip_axes, details)
        if tip_axes:
            assert R is not None
            Jt = task_jacobian_rows(J, R, cfg.task_axes_frame)
        else:
            Jt = J
        if not self._all_rows:
            Jt = Jt[self._rows]
            x = x[self._rows]
            if "task_acceleration" in details:
                details["task_acceleration"] = details["task_acceleration"][self._rows]
            if "commanded" in details:
                details["commanded"] = np.asarray(details["commanded"])[self._rows]
        return self._solve(Jt, x, details)

    def _kept_error(
        self, R: FloatArray | None, e: FloatArray, tip_axes: bool
    ) -> tuple[FloatArray, FloatArray]:
        """(error in task axes with dropped components zeroed, the same in base axes)."""
        if tip_axes:
            assert R is not None
            e_task = np.concatenate((R.T @ e[:3], R.T @ e[3:]))
        else:
            e_task = e
        if not self._all_rows:
            e_task = np.where(self._dropped_mask, 0.0, e_task)
            if tip_axes:
                assert R is not None
                e_base = np.concatenate((R @ e_task[:3], R @ e_task[3:]))
            else:
                e_base = e_task
        else:
            e_base = e
        return e_task, e_base

    def _twist_task(
        self,
        R: FloatArray | None,
        p: tuple[float, float, float],
        q_now: _quat.Quat,
        tip_axes: bool,
        details: dict[str, Any],
    ) -> FloatArray:
        """The task velocity (6,): the ramped commanded twist plus the loop closed on the kept
        error. `R`: the tip's orientation, given where tip axes or the tip's frame need it."""
        cfg = self.config
        if not self._ref_valid:
            self._ref_p, self._ref_q, self._ref_valid = p, q_now, True
        # e = (log(R_ref Rᵀ), p_ref − p), base axes
        ew = _quat.to_rotvec(_quat.mul(self._ref_q, _quat.conj(q_now)))
        rp = self._ref_p
        ev = (rp[0] - p[0], rp[1] - p[1], rp[2] - p[2])
        e_task: Sequence[float] | FloatArray
        bw, bv = cfg.max_kept_error_rad, cfg.max_kept_error_m
        moving = self._ramp.v if self._ramp_valid or self._ramp_held else self._ramp.zeros
        if self._all_rows and not tip_axes:  # the common case, on floats
            nw, nv = _norm3(*ew), _norm3(*ev)
            if nw > bw or nv > bv:  # bound the kept error (anti wind-up)
                ew, fw, nw = _pull_back(ew, nw, moving[:3], bw)
                ev, fv, nv = _pull_back(ev, nv, moving[3:], bv)
                self._ref_q = _quat.mul(_quat.from_rotvec(*ew), q_now)
                self._ref_p = (p[0] + ev[0], p[1] + ev[1], p[2] + ev[2])
                e_task = fw + fv
            else:
                e_task = ew + ev
        elif not tip_axes:  # dropped components, base axes: on floats too
            e_w = tuple(0.0 if drop else x for x, drop in zip(ew, self._dropped[:3], strict=True))
            e_v = tuple(0.0 if drop else x for x, drop in zip(ev, self._dropped[3:], strict=True))
            e_w, f_w, nw = _pull_back(e_w, _norm3(*e_w), moving[:3], bw)
            e_v, f_v, nv = _pull_back(e_v, _norm3(*e_v), moving[3:], bv)
            self._ref_q = _quat.mul(_quat.from_rotvec(*e_w), q_now)
            self._ref_p = (p[0] + e_v[0], p[1] + e_v[1], p[2] + e_v[2])
            e_task = f_w + f_v
        else:
            e = np.array(ew + ev)
            e_task, e_base_a = self._kept_error(R, e, tip_axes)
            e_base = e_base_a.tolist()
            e_w, f_w, nw = _pull_back(tuple(e_base[:3]), _norm3(*e_base[:3]), moving[:3], bw)
            e_v, f_v, nv = _pull_back(tuple(e_base[3:]), _norm3(*e_base[3:]), moving[3:], bv)
            self._ref_q = _quat.mul(_quat.from_rotvec(*e_w), q_now)
            self._ref_p = (p[0] + e_v[0], p[1] + e_v[1], p[2] + e_v[2])
            assert R is not None
            f_base = np.array(f_w + f_v)
            e_task = np.concatenate((R.T @ f_base[:3], R.T @ f_base[3:]))
        # the whole kept error (the status's): across the motion it may exceed the bound
        details["errors"] = (nv, nw)
        # The commanded twist in base axes.
        frame = self._twist_frame
        tw = self._twist
        if frame == self._base:
            target = list(tw)
        else:
            if frame == self._tip:
                assert R is not None
                R_bf = R
            else:
                R_bf = self.chain.link_pose(self._integrator.q, frame)[:3, :3]
            target = (R_bf @ tw[:3]).tolist() + (R_bf @ tw[3:]).tolist()
        # Ramp the twist within Cartesian acceleration and jerk limits (base axes).
        ramp = self._ramp
        if not self._ramp_valid:
            tool = self._tool_twist()
            if self._ramp_held:
                # Restart from the share of the command the arm does: the whole tool twist
                # would integrate into the commanded pose what the arm does besides the command
                # (its corrections), and move that pose off the commanded path.
                self._ramp_held = False
                tt = float(np.dot(target, target))
                share = float(np.dot(tool, target)) / tt if tt > 0.0 else 0.0
                share = 0.0 if share < 0.0 else 1.0 if share > 1.0 else share
                ramp.reset([share * x for x in target])
            else:
                ramp.reset(tool)
            if ramp.slowed:
                ramp.restore()
            self._ramp_valid = True
        if any(target):
            if ramp.slowed:
                ramp.restore()
        elif not ramp.slowed and any(ramp.v):
            self._stretch_stop(ramp.v)
        self._ramp_target = target
        ramped = ramp.step(target)
        ramp_acc = self._ramp.a
        self._advance_reference(ramped, cfg.period_s)
        details["scaled"] = self._twist_scaled
        details["ramped"] = ramped  # base axes: what the commanded pose advanced by, per second
        K = cfg.tracking_gain_1_per_s
        if tip_axes:
            assert R is not None
            Rt = R.T
            details["task_acceleration"] = np.concatenate((Rt @ ramp_acc[:3], Rt @ ramp_acc[3:]))
            V_task = np.concatenate((Rt @ ramped[:3], Rt @ ramped[3:]))
            details["commanded"] = V_task
            return V_task + K * np.asarray(e_task)
        details["commanded"] = ramped
        details["task_acceleration"] = np.array(ramp_acc)
        if isinstance(e_task, np.ndarray):
            return np.array(ramped) + K * e_task
        return np.array([v + K * e for v, e in zip(ramped, e_task, strict=True)])

    def _pose_task(
        self,
        R: FloatArray | None,
        p: tuple[float, float, float],
        q_now: _quat.Quat,
        tip_axes: bool,
        details: dict[str, Any],
    ) -> FloatArray:
        cfg = self.config
        ew = _quat.to_rotvec(_quat.mul(self._goal_q, _quat.conj(q_now)))
        g = self._goal_p
        e = (ew[0], ew[1], ew[2], g[0] - p[0], g[1] - p[1], g[2] - p[2])
        if self._all_rows and not tip_axes:
            e_task = e
        else:
            e_task = tuple(self._kept_error(R, np.array(e), tip_axes)[0].tolist())
        ang, dist = _norm3(*e_task[:3]), _norm3(*e_task[3:])
        K = cfg.pose_gain_1_per_s
        speed_v = min(
            cfg.pose_linear_speed_m_s,
            K * dist,
            math.sqrt(2.0 * cfg.pose_linear_acceleration_m_s2 * dist),
        )
        speed_w = min(
            cfg.pose_angular_speed_rad_s,
            K * ang,
            math.sqrt(2.0 * cfg.pose_angular_acceleration_rad_s2 * ang),
        )
        fw = speed_w / ang if ang > 0 else 0.0
        fv = speed_v / dist if dist > 0 else 0.0
        V = np.array([x * fw for x in e_task[:3]] + [x * fv for x in e_task[3:]])
        details["errors"] = (dist, ang)
        details["reached"] = (
            dist <= cfg.pose_position_tolerance_m and ang <= cfg.pose_orientation_tolerance_rad
        )
        return V

    def _stretch_stop(self, twist: list[float]) -> None:
        """Slow the ramp of `twist` (base axes) to zero so that every joint can follow it.

        Ramping the twist down by a share s of itself asks each joint for about s times its
        velocity q̇ₖ: a ramp fast enough for the tool can ask a fast-turning joint for more
        deceleration (or jerk) than it has. The joints' smoothing then limits them one by one,
        they stop out of proportion and the tool leaves its point (0.28 mm after 10 s of rotation
        one way on the UR5e). So the ramp's acceleration and jerk, as a share of the twist per
        second (per second²), are bounded by each joint's, as a share of its velocity
        (`_STOP_SHARE` of its limits: the rest is for the changing configuration and the loop's
        correction), and the whole ramp is slowed alike: every joint decelerates in proportion."""
        a_tool = j_tool = a_joint = j_joint = math.inf
        for x, a, j in zip(twist, self._ramp_acc, self._ramp_jerk, strict=True):
            if x != 0.0:
                x = abs(x)
                a_tool = min(a_tool, a / x)
                j_tool = min(j_tool, j / x)
        for x, a, j in zip(self._integrator.v_list, self._stop_acc, self._stop_jerk, strict=True):
            if x != 0.0:
                x = abs(x)
                a_joint = min(a_joint, a / x)
                j_joint = min(j_joint, j / x)
        if self._exact:  # the other joints carry a joint at its limit (`_scale_task`)
            a_joint *= _STOP_SHARE_TAKING_OVER / _STOP_SHARE
            j_joint *= _STOP_SHARE_TAKING_OVER / _STOP_SHARE
        if a_joint < a_tool or j_joint < j_tool:
            self._ramp.slow(min(1.0, a_joint / a_tool), min(1.0, j_joint / j_tool))

    def _hold_ramp(self) -> None:
        """The arm is held back (a joint limit, a velocity limit) while the ramped twist has
        reached the command: restart the ramp from the share of the command the arm does, so
        that it does not run ahead of the arm (wind up). A ramp still on its way (the command changed, e.g. reversed
        to leave the limit) goes on."""
        if self._mode == "twist" and self._ramp.v == self._ramp_target:
            self._ramp_valid = False
            self._ramp_held = True

    def _tool_twist(self) -> FloatArray:
        """The tip's twist (ω, v) [base axes] at the commanded joint velocities."""
        integ = self._integrator
        return self.chain.jacobian(integ.q, "world") @ integ.v

    def _null_motion(self, active: NDArray[np.bool_] | None, rows: FloatArray) -> FloatArray:
        """Joint velocities in the null space of the task (the `active` joints, None: all) away
        from the limits: (I − V Vᵀ) g, V = the task's right singular vectors `rows`
        (k, n_active) (Liégeois 1977: the projected gradient of a joint-limit cost)."""
        if rows.shape[0] >= rows.shape[1] or self.config.nullspace_gain_1_per_s == 0.0:
            return self._zeros  # no null space (or switched off)
        # −k h x³ with x = (q − mid)/h, h the half range: the gradient of Σ h² x⁴/4, flat in
        # the middle and steep near the limits, so the joints nearest a limit dominate.
        grad_list = []
        for qk, mid, inv_h, coef in zip(
            self._integrator.q_list, self._mid, self._inv_half, self._null_coef, strict=True
        ):
            x = (qk - mid) * inv_h
            grad_list.append(coef * (x * x * x))
        grad = np.array(grad_list)
        if active is not None:
            grad = grad[active]
        motion = grad - rows.T.dot(rows.dot(grad))
        if active is not None:
            out = np.zeros(self._n)
            out[active] = motion
            motion = out
        # Eased in over 0.5 s after a command starts: a step in the null-space speed bends the
        # tool's path while the joints take it up.
        self._null_ease = min(1.0, self._null_ease + self.config.period_s / 0.5)
        peak = (
            max(abs(m) * c for m, c in zip(motion.tolist(), self._inv_null_cap, strict=True))
            / self._null_ease
        )
        return motion / peak if peak > 1.0 else motion

    def _solve(self, Jt: FloatArray, x: FloatArray, details: dict[str, Any]) -> list[float]:
        qd = self._solve_at(Jt, x, details)
        self._last_jacobian = Jt
        if "task_share" not in details:
            self._task_share = 1.0
            self._free_sigma = None
            self._last_take_over = None
        return qd

    def _solve_at(self, Jt: FloatArray, x: FloatArray, details: dict[str, Any]) -> list[float]:
        cfg = self.config
        eps, lam = cfg.singular_value_threshold, cfg.max_damping
        lo, hi, limited = self._velocity_box()
        sol = dls.solve(Jt, x, eps, lam)
        commanded = x  # the escape from an exact singularity goes by the whole command
        braked = None
        if float(sol.singular_values[-1]) < _BRAKE_CHECK_SIGMA and "commanded" in details:
            braked = self._brake(Jt, x, sol, details["commanded"])
            if braked is not None:
                x, slowed = braked
                sol = dls.solve(Jt, x, eps, lam)
                # The braking changes the task velocity faster than the ramp's acceleration,
                # which no longer describes it: no feed-forward (with the ramp's share of it fed
                # forward the joints lagged their solution, and the tool left its line).
                details.pop("task_acceleration", None)
                if slowed < 1.0:
                    self._hold_back(1.0 - slowed, details["ramped"])
        s = sol.singular_values
        s_first, s_last = float(s[0]), float(s[-1])
        details["condition"] = (s_first / s_last if s_last > 0 else math.inf, s_last)
        if s_last >= eps:
            self._anchor = self._integrator.q  # the last well-conditioned configuration
        undamped, damped, rows = sol.undamped, sol.damped, sol.row_basis
        exact = s_last >= eps  # no damped part (zeros)
        if s_last < lam and s.shape[0] == Jt.shape[0]:
            damped = damped + self._escape(commanded, sol, details)
            exact = False
        at_limit = self._no_joint
        if limited is not None:
            qd = (undamped + damped).tolist()
            over = [
                m and (v > h + 1e-12 or v < lw - 1e-12)
                for m, v, lw, h in zip(limited, qd, lo, hi, strict=True)
            ]
            if any(over) or self._exact:
                details["at_limit"] = np.array(over) if any(over) else at_limit
                return self._scale_task(
                    Jt, x, sol, undamped + damped, lo, hi, details, braked[1] if braked else 1.0
                )
        details["at_limit"] = at_limit
        null = self._null_motion(None, rows)
        total = undamped + null if exact else undamped + damped + null
        total_list = total.tolist()
        if braked is not None:
            reach = self._reachable_share(total_list)
            if reach < 1.0:
                total = total * reach
                total_list = total.tolist()
        if all(a <= t <= b for t, a, b in zip(total_list, lo, hi, strict=True)):
            task_acc = details.get("task_acceleration")
            if task_acc is not None and limited is None:
                # q̈ = J⁺ (ẍ − J̇ q̇): the joint acceleration that keeps up with the ramping twist
                # as the arm moves, fed forward to the smoothing; J̇ from the last period's J.
                prev = self._last_jacobian
                if prev is not None:
                    task_acc = task_acc - (Jt - prev).dot(total) / cfg.period_s
                details["target_acceleration"] = dls.apply(sol, task_acc).tolist()
            return total_list
        # Fit into the box: the whole undamped part first (uniform scaling keeps its direction),
        # then as much of the damped part, then of the null-space motion.
        base = undamped
        s_base = self._max_scale(self._zero_list, base.tolist(), lo, hi)
        base = base * s_base
        s_damped = self._max_scale(base.tolist(), damped.tolist(), lo, hi)
        base = base + s_damped * damped
        base = base + self._max_scale(base.tolist(), null.tolist(), lo, hi) * null
        details["scaled"] = details.get("scaled", False) or s_base < 1.0 or s_damped < 1.0
        if s_base < 1.0:
            self._hold_ramp()
        return [
            a if b < a else c if b > c else b for b, a, c in zip(base.tolist(), lo, hi, strict=True)
        ]

    def _world_jacobian(self, q: list[float]) -> tuple[Any, FloatArray]:
        """The tip's pose (12 floats: rotation rows, then position) and the (6, m) Jacobian at
        joint values `q`: rows (ω, v) of the tip origin in base axes, one column per moving
        joint (built from the n columns flattened first: faster than from the tuples)."""
        t, cols = self._fk_world(q if self._to_internal is None else self._to_internal(q))
        J = (
            np.fromiter(_concat.from_iterable(cols), np.float64, 6 * self._n_internal)
            .reshape(-1, 6)
            .T
        )
        if self._G is not None:
            J = J @ self._G
        return t, J

    def _task_jacobian(self, q: list[float]) -> FloatArray:
        """The task Jacobian (the followed rows, task axes) at joint values `q`."""
        t, J = self._world_jacobian(q)
        if self.config.task_axes_frame == "tip":
            J = task_jacobian_rows(J, _rotation(t), "tip")
        return J if self._all_rows else J[self._rows]

    def _brake(
        self, Jt: FloatArray, x: FloatArray, sol: dls.DLSSolution, commanded: Any
    ) -> tuple[FloatArray, float] | None:
        """Brake a commanded motion along the least-singular output direction u_min near a
        boundary singularity (the edge of the workspace: u_min mostly linear).

        Damped least squares alone lets an arm reach the edge at full speed: the joints along
        v_min (q̇ = r/σ for a task speed r = u_minᵀ x) then need more acceleration than they have,
        lag their solution, and the tool leaves its line (52-88 mm out to the edge and back);
        the Panda and iiwa14 went through the singularity onto their other branch. Bounds on r:

        * toward the singularity (σ_min falling along the motion), r is scaled down linearly
          from σ_min = `_BRAKE_FROM_SIGMA` to nothing at `_BRAKE_TO_SIGMA` (a velocity damper:
          the arm stops short of the edge, on its branch);
        * either way, r² |dσ/dθ| / σ³ (how fast q̇ = r/σ must change) stays within the joints'
          planning acceleration along v_min; leaving, this bound never holds r below
          `_LEAVE_SPEED`;
        * below σ_min = `_RATE_SIGMA`, the joint speed along v_min that r asks for grows by at
          most `_RATE_SHARE` of that acceleration per period (toward the singularity at r/σ;
          leaving at the damped solution's gain σ/(σ² + λ²), which vanishes at σ = 0, so a
          singular configuration is still left at once): from rest at the edge, the whole speed
          at once asked the joints for a step they lagged.

        r is brought there by slowing the commanded twist c itself (x = c + K e), keeping the
        share s = (r_braked − u_minᵀ K e) / u_minᵀ c of it, and the commanded pose is held back
        by the rest of its advance (`_hold_back`): the arm slows along the commanded path and the
        commanded pose with it, so the loop does not pull the tool off the path (slowing only
        the u_min part of x let the rest slide the tool along the edge: 13-17 mm off the line).
        A command mostly across u_min keeps at least (1 − |u_minᵀ c| / |c|)² of itself, so one
        along the edge goes on; what x still has along u_min beyond r_braked is taken off.
        Only where the commanded twist (not just the loop's correction) has a linear part along
        u_min: a wrist singularity (u_min rotational) and a pure rotation are left to damped
        least squares as before.

        Returns (the task velocity braked, the share s of the commanded twist kept), or None.
        """
        u, v, sigma = sol.left[:, -1], sol.row_basis[-1], float(sol.singular_values[-1])
        lin = float(np.dot(u[self._linear_rows], u[self._linear_rows]))
        if lin < _BRAKE_LINEAR_SHARE:
            return None  # a loss of rotation (a wrist): damped least squares crosses it
        r = float(u.dot(x))
        cmd_lin = float(u[self._linear_rows].dot(np.asarray(commanded)[self._linear_rows]))
        if r == 0.0 or abs(cmd_lin) < _COMMANDED_SPEED:
            return None  # only the commanded motion is braked, not the loop's correction
        gain = float(sol.gains[-1])
        along = float(v.dot(sol.undamped + sol.damped))
        motion = 1.0 if (along if along != 0.0 else gain * r) >= 0.0 else -1.0  # along v_min
        v_list = v.tolist()
        # dσ/dθ along the motion: from σ̇ = u_minᵀ J̇ v_min (first-order perturbation, J̇ from the
        # last period's Jacobian) where the joints already move along v_min, else by a step of
        # the forward kinematics
        prev = self._last_jacobian
        rate = float(v.dot(self._integrator.v)) * motion
        if prev is not None and prev.shape == Jt.shape and rate > _SLOPE_RATE:
            slope = float(u.dot((Jt - prev).dot(v))) / (self.config.period_s * rate)
        else:
            h = 1e-4
            q = [
                qk + motion * h * vk for qk, vk in zip(self._integrator.q_list, v_list, strict=True)
            ]
            slope = (float(dls.svd(self._task_jacobian(q))[1][-1]) - sigma) / h
        # q̇ = r/σ along v_min changes at r² |dσ/dθ| / σ³: keep that within the joints'
        # acceleration along v_min (half their limits, as the velocity planning does)
        acc = min(
            a / abs(vk) if vk != 0.0 else math.inf
            for a, vk in zip(self._plan_acceleration_list, v_list, strict=True)
        )
        r_acc = math.sqrt(acc * sigma**3 / abs(slope)) if slope != 0.0 else math.inf
        if slope < 0.0:  # toward the singularity: down to nothing at _BRAKE_TO_SIGMA
            damper = (sigma - _BRAKE_TO_SIGMA) / (_BRAKE_FROM_SIGMA - _BRAKE_TO_SIGMA)
            damper = 0.0 if damper < 0.0 else 1.0 if damper > 1.0 else damper
            scale = min(damper, r_acc / abs(r))
        else:  # away from it: never below _LEAVE_SPEED, so a singularity is always left
            scale = min(1.0, max(r_acc, _LEAVE_SPEED) / abs(r))
        if sigma < _RATE_SIGMA:
            # the joint speed along v_min may grow by a share of the acceleration per period
            grown = max(rate, 0.0) + _RATE_SHARE * acc * self.config.period_s
            if slope > 0.0:
                r_rate = grown / gain if gain > 0.0 else math.inf
            else:
                r_rate = grown * sigma
            scale = min(scale, r_rate / abs(r))
        if scale >= 1.0:
            return None
        # Keep the share of the commanded twist c (x = c + K e) that leaves scale * r along u_min.
        c = np.asarray(commanded)
        uc = float(u.dot(c))
        r_braked = scale * r
        floor = 1.0 - abs(uc) / float(np.linalg.norm(c))
        kept = (r_braked - (r - uc)) / uc if uc != 0.0 else 1.0
        kept = max(floor * floor, min(1.0, kept))
        xb = x - (1.0 - kept) * c
        rb = float(u.dot(xb))
        if abs(rb) > abs(r_braked):  # the loop's correction alone leads out faster
            xb = xb + (r_braked - rb) * u
        return xb, kept

    def _advance_reference(self, twist: Sequence[float], dt: float) -> None:
        """Integrate the commanded pose along `twist` (ω, v) [base axes] for `dt` [s]:
        R_ref ← exp([ω] dt) R_ref, p_ref += v dt (a negative dt takes an advance back)."""
        wx, wy, wz, vx, vy, vz = twist
        self._ref_q = _quat.normalized(
            _quat.mul(_quat.from_rotvec(wx * dt, wy * dt, wz * dt), self._ref_q)
        )
        rp = self._ref_p
        self._ref_p = (rp[0] + vx * dt, rp[1] + vy * dt, rp[2] + vz * dt)

    def _hold_back(self, share: float, ramped: Sequence[float]) -> None:
        """Take back `share` of this period's advance of the commanded pose along the ramped
        twist `ramped` (ω, v) [base axes]: the pose moves on along the commanded path, slower."""
        self._advance_reference(ramped, -share * self.config.period_s)

    def _reach_box(
        self, lo: list[float], hi: list[float], widen: float
    ) -> tuple[list[float], list[float]]:
        """The velocity box [lo, hi] narrowed to what each joint reaches from its velocity within
        `_REACH_SHARE` of its planning acceleration in one period (where the two do not meet,
        the bound of [lo, hi] nearest the joint's velocity)."""
        dt = self.config.period_s
        lo_r, hi_r = [], []
        integ = self._integrator
        centre = [v + a * dt for v, a in zip(integ.v_list, integ.a_list, strict=True)]
        for v, a, lw, h in zip(centre, self._plan_acceleration_list, lo, hi, strict=True):
            b = widen * _REACH_SHARE * a * dt
            low, high = max(lw, v - b), min(h, v + b)
            if low > high:
                low = high = h if v > h else lw
            lo_r.append(low)
            hi_r.append(high)
        return lo_r, hi_r

    def _reachable_share(self, qd: list[float]) -> float:
        """The largest share s ≤ 1 of the joint velocities `qd` that every joint reaches from its
        velocity within `_REACH_SHARE` of its planning acceleration in one period (1 if there is
        none): a braked motion is slowed along its own joint direction, and the tool stays on
        its path, where the smoothing would lag the joints one by one and bend it (on floats:
        6-7 joints, cheaper than NumPy calls)."""
        lo_s, hi_s = 0.0, 1.0
        dt = self.config.period_s
        for t, v, a in zip(qd, self._integrator.v_list, self._plan_acceleration_list, strict=True):
            b = _REACH_SHARE * a * dt
            if t > 1e-12:
                lo_s, hi_s = max(lo_s, (v - b) / t), min(hi_s, (v + b) / t)
            elif t < -1e-12:
                lo_s, hi_s = max(lo_s, (v + b) / t), min(hi_s, (v - b) / t)
        return hi_s if lo_s <= hi_s else 1.0

    def _escape(self, x: FloatArray, sol: dls.DLSSolution, details: dict[str, Any]) -> FloatArray:
        """Motion along the singular joint direction v_min that leaves a singularity the way the
        command asks, where the first-order response is nil.

        At σ_min = 0 the lost task direction u_min cannot be produced at first order, so the damped
        solution gives no motion along it, and it takes long to drift off the singularity. Moving
        the joints by θ along v_min moves the tool by ½ θ² H at second order (H = d²x/dθ², the
        same for ±θ). Where H has a component along the command's u_min-part, the joints move
        along v_min at |u_minᵀ x| / (2λ) (what the damped solution gives at σ = λ), weighted down to
        nothing as σ_min grows to λ_max, so the damped solution takes over continuously; the sign
        is the damped solution's, or else the one back toward the last well-conditioned
        configuration, so the arm keeps its branch (elbow up stays up).

        Where H points against it, the command leads out of reach (a straight elbow pulled further
        out: the edge of the workspace): the damped motion along v_min is dropped, since it could
        only throw the arm through the singularity onto its other branch and back, and the tool
        stops at the edge instead (from σ_min < λ_max/10 on: under a millimetre short of full
        stretch on the bundled arms). Where H is nil (a wrist
        singularity: v_min turns two aligned axes against each other) the damped solution stands.
        """
        cfg = self.config
        lam = cfg.max_damping
        u, v, sigma = sol.left[:, -1], sol.row_basis[-1], float(sol.singular_values[-1])
        r = float(u.dot(x))
        if r == 0.0:
            return np.zeros(self._n)
        h = 1e-3
        q = self._integrator.q
        t0 = self._tip_pose  # at q (from this period's forward kinematics)
        p0 = t0[9:]
        w = [0.0, 0.0, 0.0]
        d = [0.0, 0.0, 0.0]
        v_list = v.tolist()
        for sign in (1.0, -1.0):
            step = sign * h
            t = self._pose(
                [qk + step * vk for qk, vk in zip(self._integrator.q_list, v_list, strict=True)]
            )
            # the rotation's second difference: ½ vee(R R0ᵀ − R0 Rᵀ) = ½ (M₂₁ − M₁₂, M₀₂ − M₂₀,
            # M₁₀ − M₀₁), M = R R0ᵀ, Mᵢⱼ = (row i of R)·(row j of R0)
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = t[:9]
            b00, b01, b02, b10, b11, b12, b20, b21, b22 = t0[:9]
            w[0] += 0.5 * (
                (a20 * b10 + a21 * b11 + a22 * b12) - (a10 * b20 + a11 * b21 + a12 * b22)
            )
            w[1] += 0.5 * (
                (a00 * b20 + a01 * b21 + a02 * b22) - (a20 * b00 + a21 * b01 + a22 * b02)
            )
            w[2] += 0.5 * (
                (a10 * b00 + a11 * b01 + a12 * b02) - (a00 * b10 + a01 * b11 + a02 * b12)
            )
            for i in range(3):
                d[i] += t[9 + i] - p0[i]
        second = np.array(w + d)
        if cfg.task_axes_frame == "tip":
            R0 = _rotation(t0)
            second = np.concatenate((R0.T @ second[:3], R0.T @ second[3:]))
        if not self._all_rows:
            second = second[self._rows]
        curvature = r * float(u.dot(second))
        if curvature < -1e-12 and sigma < 0.1 * lam:
            details["out_of_reach"] = True
            return -float(v.dot(sol.damped)) * v
        if curvature <= 1e-12:
            return np.zeros(self._n)
        along = float(v.dot(sol.undamped + sol.damped))
        if abs(along) > 1e-9:
            direction = 1.0 if along > 0.0 else -1.0
        else:
            direction = 1.0 if float(v.dot(self._anchor - q)) >= 0.0 else -1.0
        weight = 1.0 - sigma / lam
        details["escaping"] = True
        return (direction * weight * abs(r) / (2.0 * lam)) * v

    def _pose(self, q: list[float]) -> tuple[float, ...]:
        """The tip pose at joint values `q` as 12 floats (rotation row-major, then position)."""
        return self._fk_pose(q if self._to_internal is None else self._to_internal(q))[0]

    def _scale_task(
        self,
        Jt: FloatArray,
        x: FloatArray,
        sol: dls.DLSSolution,
        first: FloatArray,
        lo: list[float],
        hi: list[float],
        details: dict[str, Any],
        kept: float,
    ) -> list[float]:
        """Joint velocities within [lo, hi] when the solution `first` of the task velocity x
        would take a joint past the speed at which it can still brake before its position bound.

        The joint is held at that speed and the others take over what they can carry exactly
        (`task_scaling`): the largest share s of the commanded twist c, with the loop's
        correction x − c whole, so the tool slows along its path (a pure rotation keeps its
        point) instead of a least-squares fit that leaks into directions nobody commanded. The
        commanded pose advances by the same share (`_hold_back`), so the loop does not pull the
        tool off the path either. Where the correction alone does not fit, the whole task
        velocity is scaled. A pose command's whole task velocity is its command.

        `kept`: the share of c that `_brake` kept (x holds kept·c).
        """
        threshold = self.config.singular_value_threshold
        commanded = details.get("commanded")
        c = x if commanded is None else np.asarray(commanded) * kept
        c_full = c
        a0 = dls.apply(sol, c)
        first_parts = (a0, first - a0, sol.row_basis)
        at_limit = details.get("at_limit")
        held = [False] * self._n if at_limit is None else at_limit.tolist()
        exact = self._exact_motion(Jt, c, x - c, first, lo, hi, held)
        if exact is not None and exact[2]:
            details["lagged"] = True
            # The smoothing heads for the lagged target with the rate at which the targets move
            # (Ruckig's target acceleration), so that it catches up with them: toward a target
            # at rest it lagged a moving target for good, and the tool point drifted off by
            # 0.29 mm (Panda) and 0.64 mm (iiwa14) at 1 kHz from a lag where the limit was met.
            last = self._last_take_over
            if last is not None:
                inv = 1.0 / self.config.period_s
                details["target_acceleration"] = [
                    (t - u) * inv for t, u in zip(exact[0], last, strict=True)
                ]
        self._last_take_over = None if exact is None else exact[0]
        if exact is not None:
            total_list, share, _ = exact
            if share != 1.0 and commanded is not None:  # past 1 (`_SHARE_OVERSHOOT`): ahead
                self._hold_back(kept * (1.0 - share), details["ramped"])
            share = min(1.0, share)
            self._task_share = share
            details["task_share"] = share
            details["exact"] = not details.get("lagged", False)
            if share < 1.0:
                details["scaled"] = True
            return total_list
        # Within what the joints reach from their motion in a period (a target they lag bends
        # the path); where nothing fits there, wider, and then never faster than the last share.
        motion = None
        for widen in _TASK_REACH_WIDENING:
            lo_r, hi_r = self._reach_box(lo, hi, widen)
            motion = task_scaling.scale_into_bounds(
                Jt, c, x - c, lo_r, hi_r, first_parts, threshold
            )
            if motion is not None:
                break
            if widen == _TASK_REACH_WIDENING[0]:
                c = c * self._task_share
                a0 = a0 * self._task_share
                first_parts = (a0, first - a0, sol.row_basis)
        if motion is None:
            lo_r, hi_r = lo, hi
            motion = task_scaling.scale_into_bounds(Jt, c, x - c, lo, hi, first_parts, threshold)
        if motion is None:  # the correction alone asks too much: slow all of x (s = 0 fits)
            motion = task_scaling.scale_into_bounds(
                Jt,
                x,
                np.zeros_like(x),
                lo,
                hi,
                (first, np.zeros(self._n), sol.row_basis),
                threshold,
            )
        if motion is None:  # pragma: no cover - q̇ = 0 is inside every box
            return self._zero_list
        share = motion.share * float(np.linalg.norm(c)) / max(float(np.linalg.norm(c_full)), 1e-300)
        share = min(1.0, share)
        self._task_share = share
        details["task_share"] = share
        if share < 1.0:
            details["scaled"] = True
            if commanded is not None:
                self._hold_back(kept * (1.0 - share), details["ramped"])
        active = None if motion.active.all() else motion.active
        null = self._null_motion(active, motion.row_basis)
        total = motion.velocities
        total_list = total.tolist()
        total = total + self._max_scale(total_list, null.tolist(), lo_r, hi_r) * null
        return [
            a if t < a else b if t > b else t
            for t, a, b in zip(total.tolist(), lo, hi, strict=True)
        ]

    def _exact_motion(
        self,
        Jt: FloatArray,
        command: FloatArray,
        correction: FloatArray,
        first: FloatArray,
        lo: list[float],
        hi: list[float],
        held: list[bool],
    ) -> tuple[list[float], float, bool] | None:
        """(q̇, s, lagged): joint velocities that the smoothing reaches exactly at the end of this
        period (`JerkLimitedIntegrator.reachable`), within [lo, hi], doing the largest share s of
        the command with the correction whole (`task_scaling.exact_share`); the solution `first`
        itself (s = 1) where it fits. Where nothing fits in one period's reach, what the joints
        reach in more of `_PERIODS` (the smoothing then lags a little: `lagged` True). None where
        nothing fits there either: the caller slows the task as it can, and the smoothing lags.

        Per joint, the box is what it reaches, within that [lo, hi] (a joint that cannot get
        into it this period, braking for its position limit, brakes as hard as its jerk
        allows), and within that a velocity change of `_TAKE_OVER_SHARE` of its acceleration
        limit per second. The share is capped as the joints left free (not `held`) near a
        singularity of their own, and grows by at most dt / `_TAKE_OVER_TIME_S` per period.
        Where nothing fits, the share may leave [0, cap] (as little as it can, still along the
        path: `_SHARE_OVERSHOOT`). One linear program serves every box and range
        (`task_scaling.ShareProblem`: one SVD a period)."""
        integ = self._integrator
        dt = self.config.period_s
        want = first.tolist()
        problem: task_scaling.ShareProblem | None = None
        cap = 1.0
        for periods in _PERIODS:
            r_lo, r_hi = integ.reachable(periods)
            span = dt * periods
            c_lo, c_hi = [], []
            for a, b, c, d, v, top, h, vm in zip(
                lo,
                hi,
                r_lo,
                r_hi,
                integ.v_list,
                self._take_over_acceleration,
                held,
                self._v_high,
                strict=True,
            ):
                if h:  # a held joint's speed toward its bound only falls
                    if b < vm and v < b:
                        b = v if v > 0.0 else 0.0
                    if a > -vm and v > a:
                        a = v if v < 0.0 else 0.0
                low, high = (a if a > c else c), (b if b < d else d)
                if low > high:
                    low = high = c if c > b else d
                e, f = v - top * span, v + top * span
                if e > high:
                    e = f = high
                elif f < low:
                    e = f = low
                c_lo.append(low if low > e else e)
                c_hi.append(high if high < f else f)
            if periods == 1.0 and all(
                a <= w <= b for w, a, b in zip(want, c_lo, c_hi, strict=True)
            ):
                return want, 1.0, False
            if problem is None:
                # the velocities are those at the end of the period: so is the Jacobian they go
                # with (at the positions the joints reach at their present acceleration; at the
                # start, the tool point of a fast take-over drifted by J̇ q̇ dt: 0.26 mm in 0.4 s
                # on the Panda)
                half = 0.5 * dt
                q_end = [
                    q + dt * (v + half * a)
                    for q, v, a in zip(integ.q_list, integ.v_list, integ.a_list, strict=True)
                ]
                J_end = self._task_jacobian(q_end)
                # The joints that take over must not run into a singularity of their own (the
                # iiwa14's joints 1-6 without joint 7, σ_min 0.097 to 0.034 in 0.8 s of
                # take-over): the share is bounded as the smallest singular value of the joints
                # left free falls, to nothing at the servo's threshold (a velocity damper, as
                # `_brake`'s at the edge of the workspace)
                free = [not h for h in held]
                eps = self.config.singular_value_threshold
                free_svd = dls.svd(J_end[:, free]) if sum(free) >= J_end.shape[0] else None
                sigma = 0.0 if free_svd is None else float(free_svd[1][-1])
                cap = (sigma - eps) / eps
                cap = 0.0 if cap < 0.0 else 1.0 if cap > 1.0 else cap
                cap = min(cap, self._task_share + dt / _TAKE_OVER_TIME_S, self._share_brake(sigma))
                if free_svd is not None and sigma >= 2.0 * eps:
                    bend = self._curvature_cap(q_end, free, command, *free_svd)
                    cap = min(cap, max(bend, self._task_share))
                self._free_sigma = sigma
                problem = task_scaling.ShareProblem(J_end, command, correction)
                if not problem.usable:
                    return None
            prefer = [
                a if w < a else b if w > b else w for w, a, b in zip(want, c_lo, c_hi, strict=True)
            ]
            for shares, largest in (
                ((0.0, cap), True),
                # the joints' motion carries them past the cap: as little past as they can
                ((cap, _SHARE_OVERSHOOT), False),
                ((1.0 - _SHARE_OVERSHOOT, 0.0), True),
            ):
                found = problem.solve(c_lo, c_hi, prefer, shares, largest)
                if found is not None:
                    return found[0].tolist(), found[1], periods != 1.0
        return None

    def _curvature_cap(
        self,
        q: list[float],
        free: list[bool],
        command: FloatArray,
        U: FloatArray,
        sv: FloatArray,
        Vt: FloatArray,
    ) -> float:
        """The largest share s at which the joints left free (`free`) can follow the bend of
        their own path: at a constant share they move at q̇ = s g(q), g = J_free⁺ c the velocity
        per unit share (c the `command`; U, sv, Vt: the SVD of J_free at q), and so accelerate
        at q̈ = s² h, h = dg/dσ the change of g along the path they trace (σ the command done).
        Each joint's s² |h| is kept within `_CURVATURE_SHARE` of its take-over acceleration,
        the rest left for changing s. h by a finite difference: g again a step
        `_CURVATURE_STEP` along g (one more Jacobian and SVD). Without it the share reached 1
        where the Panda's joints 1-6 bend fastest (σ_min 0.11-0.12), asked for more than the
        take-over acceleration, lagged, and the tool point left by 0.42-0.55 mm (500 Hz).
        The caller never lets it push the share below the present one (the bend grows toward
        the joints' singularity, where their own cap and `_share_brake` slow the share: forced
        down faster than the joints could follow, the Panda lagged by 0.54-0.67 mm), and only
        where their σ_min is at least twice the threshold."""
        g = Vt.T.dot(U.T.dot(command) / sv)
        scale = float(np.abs(g).max())
        if scale == 0.0:
            return math.inf
        eps = _CURVATURE_STEP / scale
        gk = iter(g.tolist())
        ahead = [x + eps * next(gk) if f else x for x, f in zip(q, free, strict=True)]
        J2 = self._task_jacobian(ahead)
        U2, sv2, Vt2 = dls.svd(J2[:, free])
        g2 = Vt2.T.dot(U2.T.dot(command) / sv2)
        h = ((g2 - g) / eps).tolist()
        tops = [t for t, f in zip(self._take_over_acceleration, free, strict=True) if f]
        best = math.inf
        for hk, top in zip(h, tops, strict=True):
            if hk != 0.0:
                best = min(best, math.sqrt(_CURVATURE_SHARE * top / abs(hk)))
        return best

    def _share_brake(self, sigma: float) -> float:
        """The largest share of the command from which the joints taking over can still slow, in
        proportion, before their smallest singular value `sigma` falls to the threshold or a
        joint reaches a position bound: a braking speed (`limits.braking_speed`) in the share
        itself, at what every joint can follow at `_SHARE_BRAKE` of its limits.

        Per unit of share a joint moves at g = q̇ / s (this period's velocities and share), so
        the share's acceleration and jerk are bounded by the joints' over |g|; σ moves at κ s,
        κ from the last period. Without this the share followed the singularity's cap (σ − ε)/ε
        down only as the cap fell, faster than the joints could slow (the Panda's joints 1-6 at
        1 rad/s, 1 kHz: 0.7 mm off the tool point)."""
        share = self._task_share
        last = self._free_sigma
        if share < 0.05:
            return math.inf
        dt = self.config.period_s
        A = J = math.inf
        g_list = [v / share for v in self._integrator.v_list]
        for g, a, j in zip(g_list, self._brake_acc, self._brake_jerk, strict=True):
            if g != 0.0:
                g = abs(g)
                A = min(A, a / g)
                J = min(J, j / g)
        if A == math.inf:
            return math.inf
        best = math.inf
        if last is not None:
            kappa = (last - sigma) / (dt * share)  # σ falling per unit share and second
            if kappa > 0.0:
                eps = self.config.singular_value_threshold
                a, j = kappa * A, kappa * J
                best = braking_speed_one(sigma - eps, a, j, a * a / j) / kappa
        q = self._integrator.q_list
        for g, x, low, high in zip(g_list, q, self._lower, self._upper, strict=True):
            if g > 0.0:
                d = high - x
            elif g < 0.0:
                d = x - low
            else:
                continue
            if d == math.inf:
                continue
            g = abs(g)
            a, j = g * A, g * J
            best = min(best, braking_speed_one(d, a, j, a * a / j) / g)
        return best

    # ------------------------------------------------------------------ status
    def _status(
        self, trouble: tuple[StatusCode, str] | None, details: dict[str, Any]
    ) -> ServoStatus:
        cfg = self.config
        names = self.chain.joint_names
        at_limit_mask = details.get("at_limit")
        at_limit: tuple[str, ...] = ()
        if at_limit_mask is not None and at_limit_mask is not self._no_joint:
            at_limit = tuple(names[k] for k in np.flatnonzero(at_limit_mask))
        condition = details.get("condition")
        kappa = condition[0] if condition else 1.0
        sigma_min = condition[1] if condition else math.inf
        pos_err, ang_err = details.get("errors", (0.0, 0.0))
        dropped = self.dropped_axes
        if self._mode is None or self._winding_down:
            code, message = self._stop if trouble is None else trouble
            if self._integrator.at_rest and code == StatusCode.TIMEOUT_STOP:
                message = "stopped: no fresh command"
        elif at_limit:
            code = StatusCode.AT_JOINT_LIMIT
            share = details.get("task_share", 1.0)
            message = f"at the position limit of {', '.join(at_limit)}; " + (
                "the other joints go on"
                if share >= 1.0
                else f"slowed along the path to {100.0 * share:.0f} % of the command"
            )
        elif sigma_min < cfg.singular_value_threshold:
            code = StatusCode.NEAR_SINGULARITY
            message = (
                f"near a singularity (condition number {kappa:.3g}, smallest singular value "
                f"{sigma_min:.3g}): slowed in the ill-conditioned directions only"
            )
            if details.get("out_of_reach"):
                message += "; the command leads out of reach there (the edge of the workspace)"
        else:
            code = StatusCode.OK
            message = f"following the {self._mode} command"
        if dropped and self._mode in ("twist", "pose"):
            message += self._dropped_note
        # (positional: the fields in `ServoStatus`'s order, a little faster on every cycle)
        return ServoStatus(
            code,
            message,
            kappa,
            at_limit,
            dropped,
            pos_err,
            ang_err,
            bool(details.get("reached", False)),
            bool(details.get("scaled", False)),
        )
