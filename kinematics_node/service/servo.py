"""Message-level logic of the servo node, with no rclpy import: `ServoService`.

Messages in, messages out; the node (`ros/servo.py`) only connects them to rclpy, so that what the
node does is tested on machines without ROS, on real message definitions (rosbags).

* Robot description: the kinematics node's own logic (`KinematicsService`, holding the robot only:
  the parameters robot_description, robot_description_file, xacro_args, base_link, tip_link, and
  the robot_description topic), so the two nodes read a description the same way, with the same
  messages.
* The `core.servo.Servo` is built once the description gives a chain and joint_states have named
  every joint of it (the servo starts at rest where the arm is). Until then every command is
  refused with the status NOT_READY, saying what is missing.
* Commands (`on_twist`, `on_pose`, `on_joint_jog`) go to `Servo.submit` unchecked
  (`msg_adapters.servo_messages`): the core refuses bad ones, with a status that says why, and
  stops the arm smoothly. A frame that is a link fixed to the base without being in the chain
  (UR's `base`, a `world` link above the base) is turned into the base's frame here.
* `step(now, scheduled)`, once per period, gives the joint command (Float64MultiArray of
  positions or velocities, or a JointTrajectory) and, when it is due, the status (diagnostic_msgs/
  DiagnosticStatus). Nothing non-finite is ever handed out: the core promises it, and a check
  here withholds a command that would break the promise.
* The period grid: the node's timer is due at t₀ + k·period; a callback that starts a period or
  more after its tick makes the timer skip the ticks it missed (rcl keeps the grid). `step`
  makes up the skipped periods from the grid (`scheduled`, the tick this call serves), not from
  the callback's start: a callback that is merely late within its period makes up nothing.
  Only the last step of a catch-up is published (`step`).
* A command that finds the servo idle (at rest, following nothing) may be stepped at once
  (`take_start_now`): the node steps it in the command's callback and restarts its timer's grid
  there, so the first joint command of a motion does not wait up to a period for the next tick.
  While the arm moves, commands wait for the tick: the output stays strictly periodic.
* A new robot description that arrives while the arm moves (the robot_description topic; the
  parameters change only at rest) does not drop the servo at once: the old servo stops the arm
  on the old chain within its acceleration and jerk limits, every period published as before,
  ending at zero velocity (a velocity controller would otherwise keep the last velocity), and
  only then is the servo of the new chain built. Meanwhile commands are refused (NOT_READY).

Smoothing: Ruckig's, jerk-limited, where Ruckig is installed; else the core's acceleration-limited
one (`core.servo.smoothers`). Without Ruckig the service says once, in its log (a warning at
start-up) and on its next status (key `smoother_note`), that jerk limits need Ruckig and how to
install it; every status names the smoother (key `smoother`).

Status policy: published when its code changes (near a singularity: when the code changes, not at
every new condition number), when its message changes otherwise, when a command is refused, and
at least every `status_period` seconds.

Time: every call takes `now` [s] on the clock of the commands' stamps (the node's ROS clock).
Not thread-safe: the node calls everything from its one executor thread.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msg_adapters import MessageTypes
from msg_adapters.servo_messages import (
    ServoMessageTypes,
    diagnostic_status,
    float64_multi_array,
    jog_command_from_joint_jog,
    jog_command_from_joint_state,
    joint_trajectory,
    pose_command_from_msg,
    twist_command_from_msg,
)

from ..core import SerialChain
from ..core.exceptions import InvalidInputError, KinematicsError
from ..core.model import middle_of_limits
from ..core.servo import (
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoConfig,
    ServoOutput,
    ServoStatus,
    Smoothing,
    StatusCode,
    TwistCommand,
    choose_smoothing,
)
from .kinematics import KinematicsService
from .robot_model import RobotModel
from .servo_parameters import (
    CONFIG_NAMES,
    CONTROLLER_TOPICS,
    DESCRIPTION_PARAMETERS,
    SERVO_STARTUP_ONLY,
    servo_config,
    servo_defaults,
    validate_servo_parameters,
)

FloatArray = NDArray[np.float64]

#: Status code of the node (not of the core, whose codes are 0..9) while it has no servo yet: no
#: robot description, no chain chosen, no joint_states naming every joint of the chain.
NOT_READY = -1
#: DiagnosticStatus level (0 OK, 1 WARN, 2 ERROR) of each status code.
LEVELS: dict[int, int] = {
    StatusCode.OK: 0,
    StatusCode.IDLE: 0,
    StatusCode.TIMEOUT_STOP: 0,
    StatusCode.PAUSED: 0,
    StatusCode.NEAR_SINGULARITY: 1,
    StatusCode.AT_JOINT_LIMIT: 1,
    StatusCode.COMMAND_STALE: 1,
    StatusCode.COMMAND_REFUSED: 1,
    NOT_READY: 1,
    StatusCode.NOT_FOLLOWING: 2,
    StatusCode.STATE_REFUSED: 2,
}
#: Periods a late step makes up at most (`ServoService.step`): at 1 kHz, a delay of up to 5 ms
#: costs no motion; a longer one (the machine stalled) is not made up beyond it, so the arm is
#: not thrown forward after a stall, and the extra work does not feed an overload.
MAX_CATCH_UP = 4
#: Codes under which the servo follows a command (otherwise it has none, or stops).
_FOLLOWING = frozenset({StatusCode.OK, StatusCode.NEAR_SINGULARITY, StatusCode.AT_JOINT_LIMIT})
#: The NOT_READY message while a servo of the previous chain stops the arm (module docstring).
RETIRING_MESSAGE = (
    "a new robot description arrived while the arm moved: stopping it on the previous chain "
    "({old}) within its limits before switching to {new}; commands are refused until then"
)


def code_name(code: int) -> str:
    """The name of a status code: a `StatusCode` member's, or NOT_READY."""
    return "NOT_READY" if code == NOT_READY else StatusCode(code).name


@dataclass
class _Retiring:
    """The servo of a previous chain, stopping the arm before the new chain's takes over."""

    servo: Servo
    chain: SerialChain
    index: dict[str, int]
    q: list[float]  # its joints' measured positions, its chain's order


@dataclass(frozen=True)
class ServoCycle:
    """What one period publishes: the joint command and the status (None: nothing this period)."""

    command: Any | None
    status: Any | None


class ServoService:
    """The servo node's behaviour on messages (module docstring).

    Args:
        types: message classes of the kinematics messages (for the robot description logic).
        servo_types: message classes of the servo's outputs.
        params: parameter values by name (`servo_parameters.SERVO_PARAMETERS`); missing =
            defaults. A description that cannot be used is reported (`take_log`, the status),
            not raised.
        node_name: the node's full name, for the commands messages suggest.

    Raises:
        InvalidInputError: a parameter value is invalid (the message names it).
    """

    def __init__(
        self,
        types: MessageTypes,
        servo_types: ServoMessageTypes,
        params: Mapping[str, Any] | None = None,
        node_name: str = "/servo",
    ) -> None:
        given = dict(params or {})
        problem = validate_servo_parameters(given)
        if problem is not None:
            raise InvalidInputError(problem)
        self._types = servo_types
        self._node_name = node_name
        self._params: dict[str, Any] = {**servo_defaults(), **given}
        self._config: ServoConfig = servo_config(self._params)
        self._robot = KinematicsService(
            types,
            {name: self._params[name] for name in DESCRIPTION_PARAMETERS},
            node_name=node_name,
        )
        self._log: list[tuple[str, str]] = []
        self._model: RobotModel | None = None
        self._chain: SerialChain | None = None
        self._servo: Servo | None = None
        self._index: dict[str, int] = {}
        self._q: list[float] = []  # measured positions, chain order (NaN: not received yet)
        self._measured: FloatArray | None = None  # the same, once complete
        self._build_problem: str | None = None  # why the servo could not be built
        self._fixed_frames: dict[str, FloatArray | None] = {}  # link -> T_base_link, or None
        self._paused = False
        self._last_code: int = StatusCode.IDLE  # of the last step
        self._idle_cycles = 0
        self._last_slot: float | None = None  # the grid time of the last step's period
        self._start_now = False  # the last accepted command found the servo idle
        self._retiring: _Retiring | None = None
        self._cycles = 0
        self._late_cycles = 0
        self._lost_periods = 0
        self._last_key: tuple[Any, ...] | None = None
        self._last_status_time = -math.inf
        self._smoothing: Smoothing = choose_smoothing(self._config.smoothing)
        self._smoothing_note: str | None = None  # for the next status (said once)
        self._smoothing_said = False
        self._say_smoothing()
        self._sync_model()

    # ------------------------------------------------------------------ state
    @property
    def params(self) -> dict[str, Any]:
        return dict(self._params)

    @property
    def config(self) -> ServoConfig:
        return self._config

    @property
    def period_s(self) -> float:
        """The control period [s]."""
        return self._config.period_s

    @property
    def servo(self) -> Servo | None:
        """The core servo, once built (a description and complete joint_states)."""
        return self._servo

    @property
    def chain(self) -> SerialChain | None:
        return self._chain

    @property
    def paused(self) -> bool:
        return self._paused

    @property
    def command_out_type(self) -> str:
        return str(self._params["command_out_type"])

    @property
    def command_out_topic(self) -> str:
        """The topic of the joint commands (the parameter, else the controller's default)."""
        return str(self._params["command_out_topic"]) or CONTROLLER_TOPICS[self.command_out_type]

    @property
    def takes_description_topic(self) -> bool:
        return self._robot.takes_topic

    def take_log(self) -> list[tuple[str, str]]:
        """(level, text) lines for the node's log since the last call ("info", "warn", "error")."""
        lines = self._robot.take_log() + self._log
        self._log = []
        return lines

    def _say_smoothing(self) -> None:
        """Say once, in the log and on the next status, what the smoothing lacks (Ruckig)."""
        note = self._smoothing.note
        if note is not None and not self._smoothing_said:
            self._smoothing_said = True
            self._smoothing_note = note
            self._say("warn", note)

    @property
    def smoothing(self) -> Smoothing:
        """The smoothing the servo uses (`core.servo.smoothers`)."""
        return self._smoothing

    def _say(self, level: str, text: str) -> None:
        self._log.append((level, text))
        if len(self._log) > 100:
            del self._log[:50]

    # ------------------------------------------------------------------ description
    def on_description_message(self, text: str) -> None:
        """A message of the robot_description topic (used while both description parameters are
        empty, as by the kinematics node). Never raises."""
        self._robot.on_description_message(text)
        self._sync_model()

    def _sync_model(self) -> None:
        """Follow the description logic's model: a new chain drops the servo, which is built
        again from the next complete joint_states."""
        model = self._robot.model
        if model is self._model:
            return
        self._model = model
        # (the same description again, e.g. from a restarted robot_state_publisher, keeps its
        # model: KinematicsService.load_description)
        chain = model.chain if model is not None else None
        if self._servo is not None and self._chain is not None and self._moving():
            # stop on the old chain first (module docstring)
            old, servo = self._chain, self._servo
            servo.pause()
            self._retiring = _Retiring(servo, old, dict(self._index), list(self._q))
            self._say(
                "warn",
                RETIRING_MESSAGE.format(old=_chain_name(old), new=_chain_name(chain)),
            )
        self._chain = chain
        self._servo = None
        self._build_problem = None
        self._measured = None
        self._fixed_frames = {}
        if chain is None:
            self._index, self._q = {}, []
            return
        self._index = {name: i for i, name in enumerate(chain.joint_names)}
        self._q = [math.nan] * chain.dof

    # ------------------------------------------------------------------ configuration
    def configure(self, changes: Mapping[str, Any]) -> None:
        """Validate and apply parameter changes at run time; on any error nothing changes.

        The servo's settings and the description change only while the arm is at rest without
        a command (pause the servo first): a new setting would otherwise start a new servo
        under a moving arm. Changed settings are checked against the chain (a limit override
        naming a joint it lacks is refused).

        Raises:
            InvalidInputError: a value is invalid, read at start-up only, or the arm is moving.
            KinematicsError: the description (or base/tip link) cannot be used.
        """
        fixed = sorted(set(changes) & SERVO_STARTUP_ONLY)
        if fixed:
            raise InvalidInputError(f"{', '.join(fixed)}: read at start-up only")
        problem = validate_servo_parameters(changes, self._params)
        if problem is not None:
            raise InvalidInputError(problem)
        merged = {**self._params, **changes}
        changed = {k for k in changes if merged[k] != self._params[k]}
        reread = {"robot_description_file", "xacro_args"} & set(changes)  # reads the file again
        config_changed = bool(changed & CONFIG_NAMES)
        description_changed = bool((changed | reread) & set(DESCRIPTION_PARAMETERS))
        if (config_changed or description_changed) and self._moving():
            raise InvalidInputError(
                f"{', '.join(sorted(changed | reread))}: the servo is moving; change it at rest "
                f"(pause first: ros2 service call {self._node_name}/pause_servo "
                "std_srvs/srv/SetBool '{data: true}')"
            )
        config = servo_config(merged) if config_changed else self._config
        new_servo = None
        if config_changed and self._chain is not None and not description_changed:
            # checked against the chain now; a running servo is replaced where it stands
            start = self._servo.positions if self._servo is not None else self._chain_middle()
            new_servo = self._make_servo(self._chain, start, config)
        if description_changed:
            self._robot.configure({k: merged[k] for k in DESCRIPTION_PARAMETERS if k in changes})
        if config.period_s != self._config.period_s:
            self._last_slot = None  # the node starts a new timer: a new grid
        self._params = merged
        self._config = config
        if config_changed:
            self._smoothing = choose_smoothing(config.smoothing)  # (validated above)
            self._say_smoothing()
        if new_servo is not None and self._servo is not None:
            self._servo = new_servo
            if self._paused:
                new_servo.pause()
        self._sync_model()

    def _chain_middle(self) -> FloatArray:
        chain = self._chain
        assert chain is not None
        return middle_of_limits(chain.lower, chain.upper)

    def _make_servo(self, chain: SerialChain, positions: Any, config: ServoConfig) -> Servo:
        """A servo of `chain` at rest at `positions`.

        Raises:
            InvalidInputError: what the chain and the settings cannot meet (a limit override
                naming an unknown joint, more task axes than joints, a joint range narrower
                than its margins), worded with the parameter names.
        """
        try:
            return Servo(chain, positions, config)
        except KinematicsError as exc:
            text = str(exc).replace("ServoConfig.", "parameter ")
            raise InvalidInputError(
                f"the servo settings do not fit chain {chain.base_link} -> {chain.tip_link}: {text}"
            ) from None

    def _moving(self) -> bool:
        """True while the servo follows a command or has not come to rest (or the servo of a
        previous chain is still stopping the arm)."""
        if self._retiring is not None:
            return True
        servo = self._servo
        if servo is None:
            return False
        return bool(servo.velocities.any() or servo.accelerations.any()) or (
            self._last_code in _FOLLOWING
        )

    # ------------------------------------------------------------------ joint states
    def on_joint_state(self, msg: Any) -> str | None:
        """Take the chain's joint positions from a sensor_msgs/JointState (names in any order,
        other joints ignored). Returns a problem to log, or None. Builds the servo once every
        chain joint is known."""
        index = self._index
        if not index:
            return None
        names, positions = msg.name, msg.position
        if len(positions) != len(names):
            return (
                f"joint_states has {len(names)} names but {len(positions)} positions; "
                "sample ignored"
            )
        retiring = self._retiring
        if retiring is not None:
            problem, _ = _read_positions(names, positions, retiring.index, retiring.q)
            if problem is not None:
                return problem
        q = self._q
        problem, found = _read_positions(names, positions, index, q)
        if problem is not None or not found:
            return problem
        if self._measured is None and not all(math.isfinite(v) for v in q):
            return None  # (until every chain joint has been named once)
        self._measured = np.array(q)
        if self._servo is None and self._build_problem is None and self._retiring is None:
            self._build()
        return None

    def _build(self) -> None:
        chain, measured = self._chain, self._measured
        assert chain is not None and measured is not None
        try:
            servo = self._make_servo(chain, measured, self._config)
        except InvalidInputError as exc:
            self._build_problem = str(exc)
            self._say("error", self._build_problem)
            return
        if self._paused:
            servo.pause()
        self._servo = servo
        self._say(
            "info",
            f"servo ready: {chain.base_link} -> {chain.tip_link}, joints "
            f"{list(chain.joint_names)}, every {self._config.period_s * 1e3:g} ms; commands out "
            f"as {self.command_out_type} on {self.command_out_topic}",
        )

    # ------------------------------------------------------------------ commands
    def on_twist(self, msg: Any, now: float) -> Any | None:
        """A geometry_msgs/TwistStamped; returns a status to publish now (a refusal), or None."""
        chain = self._chain
        if self._servo is None or chain is None:
            return self._not_ready_answer("TwistCommand", now)
        cmd = twist_command_from_msg(msg, now, chain.base_link)
        R = self._fixed_rotation(cmd.frame)
        if R is not None:  # a link fixed to the base: its axes are constant in the base's
            w, v = R @ np.array(cmd.angular), R @ np.array(cmd.linear)
            cmd = TwistCommand(tuple(w.tolist()), tuple(v.tolist()), chain.base_link, cmd.stamp_s)
        return self._submit(cmd, now)

    def on_pose(self, msg: Any, now: float) -> Any | None:
        """A geometry_msgs/PoseStamped target of the tip; a refusal's status, or None."""
        chain = self._chain
        if self._servo is None or chain is None:
            return self._not_ready_answer("PoseCommand", now)
        cmd = pose_command_from_msg(msg, now, chain.base_link)
        T = self._fixed_pose(cmd.frame)
        if T is not None:
            cmd = PoseCommand(T @ cmd.T_frame_tip, chain.base_link, cmd.stamp_s)
        return self._submit(cmd, now)

    def on_joint_jog(self, msg: Any, now: float) -> Any | None:
        """A control_msgs/JointJog (joint_names, velocities); a refusal's status, or None."""
        if self._servo is None:
            return self._not_ready_answer("JointJogCommand", now)
        return self._submit(jog_command_from_joint_jog(msg, now), now)

    def on_joint_state_jog(self, msg: Any, now: float) -> Any | None:
        """A sensor_msgs/JointState used as a jog (name, velocity); a refusal's status, or None."""
        if self._servo is None:
            return self._not_ready_answer("JointJogCommand", now)
        return self._submit(jog_command_from_joint_state(msg, now), now)

    def _submit(self, cmd: TwistCommand | PoseCommand | JointJogCommand, now: float) -> Any:
        servo = self._servo
        assert servo is not None
        idle = not self._moving()
        status = servo.submit(cmd, now)
        if not status.refused:
            self._start_now = idle
            return None
        self._start_now = False
        return self._status_due(status.code, status.message, status, now)

    def take_start_now(self) -> bool:
        """True (once) when the last accepted command found the servo idle: at rest, following
        nothing. The node may then step at once (`step(now, scheduled=now)`) and restart its
        timer's grid from there (module docstring); otherwise the command waits for the tick."""
        start, self._start_now = self._start_now, False
        return start

    def _not_ready_answer(self, kind: str, now: float) -> Any | None:
        message = f"{kind} refused: {self._not_ready_reason()}"
        return self._status_due(NOT_READY, message, None, now)

    def _not_ready_reason(self) -> str:
        retiring = self._retiring
        if retiring is not None:
            return RETIRING_MESSAGE.format(
                old=_chain_name(retiring.chain), new=_chain_name(self._chain)
            )
        if self._chain is None:
            return self._robot.status.message
        if self._build_problem is not None:
            return self._build_problem
        missing = [n for n, v in zip(self._chain.joint_names, self._q, strict=True) if v != v]
        return f"waiting for joint_states naming joint(s) {missing}"

    def _fixed_rotation(self, frame: str) -> FloatArray | None:
        T = self._fixed_pose(frame)
        return None if T is None else T[:3, :3]

    def _fixed_pose(self, frame: str) -> FloatArray | None:
        """T_base_frame of a link fixed to the base that is not a link of the chain (below the
        base, or above it: a `world` link); None for a link of the chain, or a name the core
        should refuse (it lists the chain's links)."""
        chain, model = self._chain, self._model
        if chain is None or model is None or frame in chain.link_names:
            return None
        cache = self._fixed_frames
        if frame not in cache:
            if len(cache) > 64:  # names from a bad sender: do not grow without bound
                cache.clear()
            cache[frame] = _fixed_to_base(model, frame)
        return cache[frame]

    # ------------------------------------------------------------------ pause
    def set_paused(self, paused: bool) -> str:
        """Pause (stop smoothly, refuse commands) or resume; returns what was done."""
        was = self._paused
        self._paused = paused
        servo = self._servo
        if servo is not None:
            if paused:
                servo.pause()
            else:
                servo.resume()
        if paused:
            return "paused: stopping smoothly; commands are refused until resumed" + (
                " (it was paused already)" if was else ""
            )
        return "resumed: waiting for a command" if was else "was not paused; nothing to resume"

    # ------------------------------------------------------------------ the period
    def step(self, now: float, scheduled: float | None = None) -> ServoCycle:
        """One period at time `now` [s]: the joint command to publish (None while there is no
        servo, or at rest after `halt_messages` holding commands) and the status when due.

        `scheduled` [s] is the time the node's timer was due for this call (its tick on the
        grid t₀ + k·period); None: the grid is estimated from the calls (anchored at the first,
        moved earlier by a call that comes early). The call serves the period of the latest grid
        time at or before `now`.

        When that is more than one period after the last step's (the callback began a period or
        more after its tick: the process was held up, and the timer skips the ticks it missed),
        the periods in between are made up first, up to `MAX_CATCH_UP` of them, each at its own
        grid time, so that the arm keeps to the commanded speed in real time; the status counts
        such cycles (late_cycles) and the periods not made up (lost_periods). A callback that is
        late within its own period makes up nothing. Those periods do not judge the command
        timeout (`Servo.step`'s held_up): the commands sent while the process was held up are
        still queued, and are taken after this call.

        Only the last step's command is published: the made-up ones are already due by the time
        they could go out; a forward position or velocity controller applies only the newest
        command it has at its update, and joint_trajectory_controller drops points whose time
        has passed (and would replay points stamped from their receipt late), so sending them
        would only make this late cycle later still."""
        self._cycles += 1
        missed = self._advance_grid(now, scheduled)
        if self._retiring is not None:
            return self._retire_step(now)
        servo = self._servo
        if servo is None:
            self._last_slot = None
            reason = self._not_ready_reason()
            return ServoCycle(None, self._status_due(NOT_READY, reason, None, now))
        if missed:
            self._late_cycles += 1
            extra = min(missed, MAX_CATCH_UP) if self._idle_cycles == 0 else 0
            self._lost_periods += missed - extra
            period = self._config.period_s
            slot = self._last_slot
            assert slot is not None
            for k in range(extra, 0, -1):
                servo.step(slot - k * period, self._measured, held_up=True)
        # (held up: the twists sent meanwhile are taken after this callback; Servo.step)
        out = servo.step(now, self._measured, held_up=bool(missed))
        status = out.status
        code = int(status.code)
        self._last_code = code
        finite = bool(np.isfinite(out.positions).all() and np.isfinite(out.velocities).all())
        if not finite:  # the core promises never to; if it ever did, nothing leaves the node
            message = "internal error: the servo computed a non-finite command; withheld"
            self._say("error", message)
            return ServoCycle(None, self._status_due(StatusCode.STATE_REFUSED, message, None, now))
        at_rest = code not in _FOLLOWING and not (out.velocities.any() or out.accelerations.any())
        self._idle_cycles = self._idle_cycles + 1 if at_rest else 0
        halt = int(self._params["halt_messages"])
        command = None
        if halt == 0 or self._idle_cycles <= halt:
            command = self._command_message(out, servo.chain)
        return ServoCycle(command, self._status_due(code, status.message, status, now))

    def _advance_grid(self, now: float, scheduled: float | None) -> int:
        """Move to the period this call serves: the latest grid time at or before `now` (`step`);
        returns the periods skipped since the last step's."""
        period = self._config.period_s
        last = self._last_slot
        if scheduled is not None:  # the grid's phase: the tick this callback was taken for
            late = max(0, math.floor((now - scheduled) / period + 1e-6))
            slot = float(scheduled) + late * period
        elif last is None:
            slot = now
        else:
            k = math.floor((now - last) / period + 1e-6)
            slot = last + k * period if k >= 1 else now  # early: the estimate was late
        self._last_slot = slot
        if last is None:
            return 0
        return max(0, round((slot - last) / period) - 1)

    def _retire_step(self, now: float) -> ServoCycle:
        """A period of the previous chain's servo stopping the arm (module docstring); once at
        rest (the command of zero velocity published), the new chain's servo is built from the
        next joint_states that name all of its joints."""
        retiring = self._retiring
        assert retiring is not None
        measured = np.array(retiring.q) if all(v == v for v in retiring.q) else None
        out = retiring.servo.step(now, measured)
        reason = self._not_ready_reason()
        finite = bool(np.isfinite(out.positions).all() and np.isfinite(out.velocities).all())
        command = self._command_message(out, retiring.chain) if finite else None
        if not finite or not (out.velocities.any() or out.accelerations.any()):
            self._retiring = None
            self._say(
                "info",
                f"the arm is at rest on {_chain_name(retiring.chain)}; switching to "
                f"{_chain_name(self._chain)}",
            )
            self._idle_cycles = 0
            self._last_code = StatusCode.IDLE
            # the new chain's servo is built from the next joint_states (`on_joint_state`): they
            # show where this last command left the arm
        return ServoCycle(command, self._status_due(NOT_READY, reason, None, now))

    def _command_message(self, out: ServoOutput, chain: SerialChain) -> Any:
        kind = self._params["command_out_type"]
        if kind == "position":
            return float64_multi_array(self._types, out.positions)
        if kind == "velocity":
            return float64_multi_array(self._types, out.velocities)
        return joint_trajectory(
            self._types,
            chain.joint_names,
            out.positions,
            out.velocities,
            out.accelerations,
            self._config.period_s,
        )

    # ------------------------------------------------------------------ status
    def _status_due(
        self,
        code: int,
        message: str,
        status: ServoStatus | None,
        now: float,
    ) -> Any | None:
        """The status message when it is due (module docstring), else None."""
        joints = status.joints_at_limit if status is not None else ()
        key = (code, "" if code == StatusCode.NEAR_SINGULARITY else message, joints)
        period = float(self._params["status_period"])
        if key == self._last_key and now - self._last_status_time < period:
            return None
        self._last_key = key
        self._last_status_time = now
        return self.status_message(code, message, status)

    def status_message(self, code: int, message: str, status: ServoStatus | None) -> Any:
        """diagnostic_msgs/DiagnosticStatus: level from the code, the message, and the details
        as key/values (code, code_name, condition_number, joints_at_limit, dropped_axes,
        position_error_m, orientation_error_rad, target_reached, velocity_scaled, paused,
        smoother; smoother_note once, where Ruckig is missing)."""
        values = [("code", str(code)), ("code_name", code_name(code))]
        if status is not None:
            kappa = status.condition_number
            values += [
                ("condition_number", f"{kappa:.6g}" if math.isfinite(kappa) else "inf"),
                ("joints_at_limit", " ".join(status.joints_at_limit)),
                ("dropped_axes", " ".join(status.dropped_axes)),
                ("position_error_m", f"{status.position_error_m:.6g}"),
                ("orientation_error_rad", f"{status.orientation_error_rad:.6g}"),
                ("target_reached", str(status.target_reached).lower()),
                ("velocity_scaled", str(status.velocity_scaled).lower()),
            ]
        values += [
            ("paused", str(self._paused).lower()),
            ("cycles", str(self._cycles)),
            ("late_cycles", str(self._late_cycles)),
            ("lost_periods", str(self._lost_periods)),
            ("smoother", self._smoothing.label),
        ]
        if self._smoothing_note is not None:
            values.append(("smoother_note", self._smoothing_note))
            self._smoothing_note = None
        robot = self._model.robot_name if self._model is not None else ""
        return diagnostic_status(
            self._types, LEVELS.get(code, 2), f"{self._node_name}: servo", message, robot, values
        )


def _chain_name(chain: SerialChain | None) -> str:
    return "no chain" if chain is None else f"chain {chain.base_link} -> {chain.tip_link}"


def _read_positions(
    names: Any, positions: Any, index: Mapping[str, int], q: list[float]
) -> tuple[str | None, int]:
    """Set q[index[name]] from a JointState's names and positions (other joints ignored).
    Returns a problem to log (and nothing set) when one of them is not finite, and how many
    positions were set."""
    found = []
    for name, value in zip(names, positions, strict=True):
        i = index.get(name)
        if i is not None:
            v = float(value)
            if not math.isfinite(v):
                return f"joint_states gives joint {name!r} the position {v}; sample ignored", 0
            found.append((i, v))
    for i, v in found:
        q[i] = v
    return None, len(found)


def _fixed_to_base(model: RobotModel, link: str) -> FloatArray | None:
    """T_base_link (4×4) of a robot link joined to the base by fixed joints only, below or above
    it; None when it moves with some joint, or is not a link of the robot."""
    try:
        source = model.link_pose_source(link)  # below the base
    except KinematicsError:
        source = None
    if isinstance(source, np.ndarray):
        return source
    if link not in model.link_names:
        return None
    path = model.tree.path(link, model.base_link)  # the base below `link`: a `world` link
    if not path or any(joint.kind != "fixed" for joint in path):
        return None
    T_link_base = np.eye(4)
    for joint in path:
        T_link_base = T_link_base @ joint.origin
    R, p = T_link_base[:3, :3], T_link_base[:3, 3]
    T = np.eye(4)
    T[:3, :3] = R.T
    T[:3, 3] = -R.T @ p
    return T
