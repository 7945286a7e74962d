"""rclpy wiring of the servo node (executable `servo`); its behaviour is `ServoService`
(`service/servo.py`), tested without ROS.

Topics (relative names: namespaces and remaps apply; ``~/`` = under the node's name, as
moveit_servo's, so joystick and teleop configurations written for it carry over):
  sub  ~/delta_twist_cmds        geometry_msgs/TwistStamped  twist of the tip (ω, v) in the axes of
                                 header.frame_id (a robot link; empty = base_link), about the tip
  sub  ~/delta_joint_cmds        control_msgs/JointJog       joint velocities (where control_msgs
                                 is installed: a ROS 2 installation; it is not on PyPI)
  sub  ~/delta_joint_state_cmds  sensor_msgs/JointState      joint velocities by name (`velocity`),
                                 the same jog without control_msgs
  sub  ~/pose_target_cmds        geometry_msgs/PoseStamped   a pose of the tip to reach
  sub  joint_states              sensor_msgs/JointState      the measured joint positions
  sub  robot_description         std_msgs/String             (transient local), while the
                                 description parameters are empty
  pub  command_out_topic         std_msgs/Float64MultiArray (positions or velocities) or
                                 trajectory_msgs/JointTrajectory, by `command_out_type`
  pub  ~/status                  diagnostic_msgs/DiagnosticStatus: level, message and the details
                                 (code, code_name, condition_number, joints_at_limit, ...,
                                 smoother: Ruckig's or the acceleration-limited one; the loop's
                                 own figures: cycles, late_cycles, lost_periods, step_us_max)
Services: ~/pause_servo (std_srvs/SetBool: true pauses, false resumes, as moveit_servo's since
Iron), ~/unpause_servo (std_srvs/Trigger, as moveit_servo's on Humble).

Commands are taken best effort (a best-effort subscription matches reliable and best-effort
publishers alike), depth 10; only the newest matters.

One thread runs everything (`spin`: our LeanExecutor): a timer at the servo's period (up to
1 kHz, 2 kHz at the most) steps the servo and publishes; the joint_states callback only stores
what it receives. Each tick tells the servo the grid time it serves (the timer's next call
minus one period: rcl keeps the timer on its grid and skips the ticks a late callback missed),
so that a late cycle makes up exactly the periods skipped (`ServoService.step`). A command that
finds the servo idle is stepped at once in its own callback, and the timer restarted from there
(`ServoService.take_start_now`): the first joint command of a motion does not wait up to a
period for the next tick.

`thread_priority` (start-up): SCHED_FIFO for the node's thread, as moveit_servo's parameter of
that name (`realtime.apply_thread_priority`; a system that does not permit it is logged, and
the node runs on).

Why a process of its own and not inside the kinematics node: one Python thread runs one callback
at a time; the kinematics node's pose path carries joint_states at up to 1 kHz (and its IK
requests), and in its thread the servo's 1 ms ticks would queue behind them, while the pose
path's latency grew by the servo's steps (measured with benchmarks/servo_process_benchmark.py:
docs/performance.md, "Why the servo is a process of its own").
"""

from __future__ import annotations

import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TwistStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory

from msg_adapters import MessageTypes
from msg_adapters.servo_messages import ServoMessageTypes

from ..core.exceptions import InvalidInputError
from ..service.servo import ServoService
from ..service.servo_parameters import SERVO_PARAMETERS, SERVO_SPECS
from .node_log import ThrottledWarnings, log_lines
from .node_setup import (
    answer_parameter_change,
    check_parameter_names,
    declare_parameters,
    freeze_heap,
)
from .qos import DESCRIPTION_QOS, JOINT_STATES_QOS, NO_PUBLISHER_EVENTS, NO_SUBSCRIPTION_EVENTS
from .realtime import apply_thread_priority
from .spin import STOP_DEADLINE_S, spin_until_shutdown

try:  # not on PyPI: present on a full ROS 2 installation
    from control_msgs.msg import JointJog
except ImportError:  # pragma: no cover - depends on the installation
    JointJog = None

#: Commands: best effort (matches reliable and best-effort publishers), the newest 10.
COMMAND_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
#: Joint commands: reliable (as ros2_control's controllers subscribe), the newest 10.
COMMAND_OUT_DEPTH = 10


class ServoNode(Node):
    """Parameters, topics, services and the control timer around one `ServoService`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("servo", **kwargs)
        values = declare_parameters(self, SERVO_PARAMETERS)
        check_parameter_names(self)  # a typo (-p period_ss:=...) is named, not silently ignored
        self._logic = ServoService(
            MessageTypes.from_rclpy(),
            ServoMessageTypes.from_rclpy(),
            values,
            node_name=self.get_fully_qualified_name(),
        )
        self._log_events()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._warn_throttled = ThrottledWarnings(self.get_logger())
        self._step_max = 0.0  # [s], since the last status

        group = ReentrantCallbackGroup()
        out_type = (
            JointTrajectory if self._logic.command_out_type == "trajectory" else (Float64MultiArray)
        )
        self._command_pub = self.create_publisher(
            out_type,
            self._logic.command_out_topic,
            COMMAND_OUT_DEPTH,
            event_callbacks=NO_PUBLISHER_EVENTS,
        )
        self._status_pub = self.create_publisher(
            DiagnosticStatus, "~/status", 10, event_callbacks=NO_PUBLISHER_EVENTS
        )
        self._subscribe(JointState, "joint_states", self._on_joint_state, JOINT_STATES_QOS, group)
        self._subscribe(TwistStamped, "~/delta_twist_cmds", self._on_twist, COMMAND_QOS, group)
        self._subscribe(PoseStamped, "~/pose_target_cmds", self._on_pose, COMMAND_QOS, group)
        self._subscribe(
            JointState, "~/delta_joint_state_cmds", self._on_joint_state_jog, COMMAND_QOS, group
        )
        if JointJog is not None:
            self._subscribe(JointJog, "~/delta_joint_cmds", self._on_joint_jog, COMMAND_QOS, group)
        else:
            self.get_logger().info(
                "control_msgs is not installed: ~/delta_joint_cmds (control_msgs/JointJog) is not "
                "offered; jog with ~/delta_joint_state_cmds (sensor_msgs/JointState: name, "
                "velocity) instead"
            )
        self.create_subscription(
            String, "robot_description", self._on_description, DESCRIPTION_QOS, callback_group=group
        )
        self.create_service(SetBool, "~/pause_servo", self._pause, callback_group=group)
        self.create_service(Trigger, "~/unpause_servo", self._unpause, callback_group=group)
        self._group = group
        self._timer = self.create_timer(self._logic.period_s, self._on_timer, callback_group=group)
        self.get_logger().info(
            f"servo every {self._logic.period_s * 1e3:g} ms; joint commands "
            f"({self._logic.command_out_type}) on {self._logic.command_out_topic}"
        )
        self._apply_thread_priority(int(self._logic.params["thread_priority"]))
        freeze_heap()

    def _apply_thread_priority(self, priority: int) -> None:
        said = apply_thread_priority(priority)  # (the range: checked by ServoService)
        log_lines(self.get_logger(), [said] if said is not None else [])

    def _subscribe(self, msg_type: Any, topic: str, callback: Any, qos: Any, group: Any) -> None:
        self.create_subscription(
            msg_type,
            topic,
            callback,
            qos,
            callback_group=group,
            event_callbacks=NO_SUBSCRIPTION_EVENTS,
        )

    def _now(self) -> float:
        return float(self.get_clock().now().nanoseconds) * 1e-9

    # -------------------------------------------------------------- callbacks
    def _on_timer(self) -> None:
        now = self._now()
        # the grid time of this tick: rcl has moved the timer to its next call already
        until_next = self._timer.time_until_next_call()
        scheduled = None if until_next is None else now + until_next * 1e-9 - self._logic.period_s
        self._step(now, scheduled)

    def _step(self, now: float, scheduled: float | None) -> None:
        start = time.perf_counter()
        cycle = self._logic.step(now, scheduled)
        if cycle.command is not None:
            self._command_pub.publish(cycle.command)
        if cycle.status is not None:
            self._publish_status(cycle.status)
        self._log_events()
        self._step_max = max(self._step_max, time.perf_counter() - start)

    def _publish_status(self, status: Any) -> None:
        # the longest timer callback since the last status (step, messages, publishing) [µs]
        status.values += [KeyValue(key="step_us_max", value=f"{self._step_max * 1e6:.0f}")]
        self._step_max = 0.0
        self._status_pub.publish(status)

    def _answer(self, status: Any | None) -> None:
        if status is not None:
            self._publish_status(status)
        if self._logic.take_start_now():
            # the servo was idle: step this command at once, and restart the grid from it
            self._timer.reset()
            now = self._now()
            self._step(now, now)

    def _on_twist(self, msg: TwistStamped) -> None:
        self._answer(self._logic.on_twist(msg, self._now()))

    def _on_pose(self, msg: PoseStamped) -> None:
        self._answer(self._logic.on_pose(msg, self._now()))

    def _on_joint_jog(self, msg: Any) -> None:
        self._answer(self._logic.on_joint_jog(msg, self._now()))

    def _on_joint_state_jog(self, msg: JointState) -> None:
        self._answer(self._logic.on_joint_state_jog(msg, self._now()))

    def _on_joint_state(self, msg: JointState) -> None:
        problem = self._logic.on_joint_state(msg)
        if problem is not None:
            self._warn_throttled(problem)

    def _on_description(self, msg: String) -> None:
        try:
            self._logic.on_description_message(msg.data)
        except Exception as exc:  # noqa: BLE001 - a description must never take the node down
            self.get_logger().error(f"robot_description topic: internal error: {exc!r}")
        self._log_events()

    def _pause(self, request: Any, response: Any) -> Any:
        response.message = self._logic.set_paused(bool(request.data))
        response.success = True
        self.get_logger().info(response.message)
        return response

    def _unpause(self, request: Any, response: Any) -> Any:
        response.message = self._logic.set_paused(False)
        response.success = True
        self.get_logger().info(response.message)
        return response

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in SERVO_SPECS}
        period = self._logic.period_s
        answer = answer_parameter_change(lambda: self._logic.configure(changes), self._log_events)
        if self._logic.period_s != period:
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(
                self._logic.period_s, self._on_timer, callback_group=self._group
            )
        return answer

    # -------------------------------------------------------------- logs
    def _log_events(self) -> None:
        log_lines(self.get_logger(), self._logic.take_log())


def main(args: list[str] | None = None) -> int:
    """Entry point of the `servo` executable: 0 after SIGINT/SIGTERM, 2 when a start-up
    parameter is invalid (one line on stderr saying which); see `spin`."""
    return spin_until_shutdown(
        ServoNode, "servo", (InvalidInputError, ParameterException), args, STOP_DEADLINE_S
    )


if __name__ == "__main__":
    main()
