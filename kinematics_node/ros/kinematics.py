"""rclpy wiring of the kinematics node (executable `kinematics_node`); all behaviour is in
`KinematicsService` (`service/kinematics.py`), which is tested without ROS.

Topics (relative names, so namespaces and remaps apply):
  sub  joint_states       sensor_msgs/JointState   best effort (matches reliable and best-effort
                                                   publishers), depth 100 (100 ms at 1 kHz)
  sub  robot_description  std_msgs/String          transient local, reliable (used while the
                                                   robot_description and robot_description_file
                                                   parameters are empty)
  pub  ee_pose            geometry_msgs/PoseStamped  reliable, depth 100 (100 ms at 1 kHz), as
                                                   the two below
  pub  ee_twist           geometry_msgs/TwistStamped
  pub  /diagnostics       diagnostic_msgs/DiagnosticArray (absolute, as aggregators expect)
  pub  ~/markers          visualization_msgs/MarkerArray  the manipulability ellipsoid and its most
                                                   singular direction, at markers_rate, only while
                                                   subscribed (a timer; never in the pose path)
  pub  /tf, /tf_static    tf2_msgs/TFMessage       with publish_tf: the description's links as
                                                   robot_state_publisher gives them (/tf at most
                                                   tf_rate by the stamps; /tf_static transient
                                                   local, again for a new description)
Services: compute_fk, compute_jacobian, compute_ik (kinematics_service/srv/...).

Threads and processes. One thread runs every callback (`spin`: our `LeanExecutor`, one wait per
callback, by default): rclpy's MultiThreadedExecutor cannot carry 1 kHz joint_states, and a busy
Python thread in this process would hold the GIL away from the pose path. FK and Jacobian requests
take microseconds and are answered in place. IK runs in worker processes (`IKPool`, `ik.workers`,
at a lower CPU priority): `compute_ik` returns its response unfinished (`DeferredResponses`: no
coroutine, which rclpy's executors would resume on every turn), and the work starts when rclpy
hands over the request's header, whose source timestamp says how long the request waited before its
callback. Targets the closed form solves at its first try are answered at once; the rest go to the
pool. The answer comes back through a `Mailbox` into the executor thread, which fills the response
and sends it: on the next joint_states message's turn while they stream, else woken by a guard
condition. Meanwhile joint_states keep flowing. Every IK request is answered by its timeout (plus a
few ms) counted from when its client sent it; one sent more than 20 ms late is logged.

Robot description: the robot_description parameter (URDF/xacro XML), else robot_description_file
(a path; xacro_args for xacro), else the robot_description topic. A description whose tip is not
chosen (several leaves: a gripper's fingers, cameras) is held, and the node says which tips there
are until tip_link is set; a new description replaces the robot (`KinematicsService.configure`).

TF: target frames that are not robot links are looked up with tf2_ros when it is installed (it is
not on PyPI); without it such targets are refused with a message saying so. Uses only API
available in both Humble and Jazzy.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import asdict
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped
from kinematics_service.srv import ComputeFK, ComputeIK, ComputeJacobian
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.subscription import Subscription
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from msg_adapters import MessageTypes, matrix_from_transform
from msg_adapters.markers import MarkerTypes
from msg_adapters.transforms import TFTypes

from ..core.exceptions import InvalidInputError, KinematicsError
from ..service.ik_pool import IKOutcome, IKPool, solve_at_once
from ..service.kinematics import KinematicsService, PendingIK, Severity
from ..service.parameters import PARAMETERS, SPECS, STARTUP_ONLY
from .deferred import DeferredResponses, waited_since_sent
from .mailbox import Mailbox
from .node_log import ThrottledWarnings, log_lines
from .node_setup import (
    answer_parameter_change,
    check_parameter_names,
    declare_parameters,
    freeze_heap,
)
from .qos import (
    DESCRIPTION_QOS,
    JOINT_STATES_QOS,
    NO_PUBLISHER_EVENTS,
    NO_SUBSCRIPTION_EVENTS,
    TF_QOS,
    TF_STATIC_QOS,
)
from .spin import STOP_DEADLINE_S, spin_until_shutdown

try:  # not on PyPI: present on a full ROS 2 installation
    from tf2_ros import Buffer, TransformListener
except ImportError:  # pragma: no cover - depends on the installation
    Buffer = TransformListener = None

#: ee_pose, ee_twist and /diagnostics keep the last 100 messages (100 ms at 1 kHz), so a reliable
#: subscriber whose process falls a few ms behind gets them resent instead of losing them: with
#: rclpy's default of 10, a benchmark receiver on the same 2 busy CPUs lost up to 17 % of the
#: samples published during a long IK solve (benchmarks/node_benchmark.py, "2 s IK call").
PUBLISHED_DEPTH = 100
#: joint_states stream when the last one came less than this long ago [s]; then an IK answer
#: waits up to this long (never past its deadline) for the next message's turn of the executor,
#: which collects it (`Mailbox`), instead of waking the executor for it. (At 500 Hz one comes
#: every 2 ms.)
STREAMING_GAP = 0.0025
#: A job whose worker has not answered this long before its deadline is answered as timed out
#: then (never before the worker's own stop): the answer's way out of a busy node (pool thread,
#: mailbox, executor) took up to 13-15 ms on the benchmark's saturated 2 CPUs [s].
EARLY_ANSWER = 0.004
#: An IK answer sent this long after its deadline is logged (with where the time went) [s].
LATE_ANSWER_WARNING = 0.02
#: rclpy (Iron and later) hands a two-argument subscription callback the message's info, whose
#: source_timestamp [ns] says when its publisher sent it; Humble's hands over the message only.
MESSAGE_INFO = hasattr(Subscription, "CallbackType")
TF_MISSING = "TF frames need tf2_ros, which is not installed here (it comes with a full ROS 2)"


def _message_classes(table: Any) -> tuple[Any, str]:
    """(the rclpy classes of a `MessageClasses` table, "") or (None, why not)."""
    try:
        return table.from_rclpy(), ""
    except (ImportError, AttributeError) as exc:
        return None, f"{exc} (the message package is not installed)"


class KinematicsNode(Node):
    """Parameters, publishers, subscriptions and services around one `KinematicsService`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("kinematics_node", **kwargs)
        values = declare_parameters(self, PARAMETERS)
        check_parameter_names(self)  # a typo (-p tip_lnk:=...) is named, not silently ignored

        self._tf_buffer = None
        lookup = self._lookup_transform
        if Buffer is not None and TransformListener is not None:
            self._tf_buffer = Buffer()
            self._tf_listener = TransformListener(self._tf_buffer, self)
        else:
            self.get_logger().info(f"{TF_MISSING}; IK targets in robot links still work")
        tf_types = None
        if values["publish_tf"]:
            tf_types, why = _message_classes(TFTypes)
            if tf_types is None:
                self.get_logger().error(f"publish_tf: no /tf can be published: {why}")
        self._logic = KinematicsService(
            MessageTypes.from_rclpy(),
            values,  # a description that cannot be used is reported, not raised
            lookup_transform=lookup,
            clock=lambda: self.get_clock().now().nanoseconds * 1e-9,
            node_name=self.get_fully_qualified_name(),
            tf_types=tf_types,
        )
        self._log_description_events()
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self._pool = IKPool(int(values["ik.workers"]) or _default_workers(), grace=-EARLY_ANSWER)
        self._pool.warm_up()  # start the workers now: starting one later would block this thread
        # One thread runs everything, so callbacks never overlap. The group is reentrant so that
        # rclpy needs no bookkeeping of which callback of the group may run.
        group = ReentrantCallbackGroup()
        self._ik_wake = self.create_guard_condition(self._deliver_ik_answers, group)
        self._ik_answers: Mailbox[tuple[PendingIK, Any, IKOutcome, float]] = Mailbox(
            self._ik_wake.trigger, "ik-answers"
        )
        self._last_joint_state = -math.inf  # time.monotonic() of the last one's callback

        self._pose_pub = self._publisher(PoseStamped, "ee_pose")
        self._twist_pub = self._publisher(TwistStamped, "ee_twist")
        self._diag_pub = self._publisher(DiagnosticArray, "/diagnostics")
        self._tf_pub = self._tf_static_pub = None
        if tf_types is not None:
            self._tf_pub = self.create_publisher(
                tf_types.TFMessage, "/tf", TF_QOS, event_callbacks=NO_PUBLISHER_EVENTS
            )
            self._tf_static_pub = self.create_publisher(
                tf_types.TFMessage, "/tf_static", TF_STATIC_QOS
            )
            self._publish_static_tf()
        self._marker_types = self._markers_pub = None
        if float(values["markers_rate"]) > 0:
            self._marker_types, why = _message_classes(MarkerTypes)
            if self._marker_types is None:
                self.get_logger().warning(f"no manipulability markers on ~/markers: {why}")
            else:
                self._markers_pub = self.create_publisher(
                    self._marker_types.MarkerArray, "~/markers", 10
                )
                self.create_timer(
                    1.0 / float(values["markers_rate"]),
                    self._publish_markers,
                    callback_group=group,
                )
        on_joint_state: Any = self._on_joint_state
        if not MESSAGE_INFO:  # pragma: no cover - Humble
            on_joint_state = lambda msg: self._on_joint_state(msg, {})  # noqa: E731
        self.create_subscription(
            JointState,
            "joint_states",
            on_joint_state,
            JOINT_STATES_QOS,
            callback_group=group,
            event_callbacks=NO_SUBSCRIPTION_EVENTS,
        )
        self.create_subscription(
            String, "robot_description", self._on_description, DESCRIPTION_QOS, callback_group=group
        )
        self.create_service(ComputeFK, "compute_fk", self._logic.compute_fk, callback_group=group)
        self.create_service(
            ComputeJacobian,
            "compute_jacobian",
            self._logic.compute_jacobian,
            callback_group=group,
        )
        ik_service = self.create_service(
            ComputeIK, "compute_ik", self._compute_ik, callback_group=group
        )
        self._ik_responses = DeferredResponses(
            ik_service,
            lambda exc: self.get_logger().warning(f"an IK answer could not be sent: {exc!r}"),
        )
        self._diag_timer = self.create_timer(
            float(values["diagnostics_period"]), self._publish_diagnostics, callback_group=group
        )
        self._warn_throttled = ThrottledWarnings(self.get_logger())
        freeze_heap()

    def _publisher(self, msg_type: Any, topic: str) -> Any:
        return self.create_publisher(
            msg_type, topic, PUBLISHED_DEPTH, event_callbacks=NO_PUBLISHER_EVENTS
        )

    # -------------------------------------------------------------- callbacks
    def _log_description_events(self) -> None:
        """Log what happened to the robot description (loaded, waiting for a tip and which tips
        there are, refused and why), as the service reports it."""
        log_lines(self.get_logger(), self._logic.take_log())

    def _on_description(self, msg: String) -> None:
        # used while robot_description and robot_description_file are empty, else kept for later
        model = self._logic.model
        try:
            self._logic.on_description_message(msg.data)
        except Exception as exc:  # noqa: BLE001 - a description must never take the node down
            self.get_logger().error(f"robot_description topic: internal error: {exc!r}")
        self._log_description_events()
        if self._logic.model is not model and self._logic.model is not None:
            self._publish_static_tf()
            freeze_heap()

    def _on_joint_state(self, msg: JointState, info: dict[str, Any]) -> None:
        self._last_joint_state = time.monotonic()
        # A sample's arrival time (the time base of velocities its stamps cannot give) is when its
        # publisher sent it, the DDS source timestamp, which the transport's and this executor's
        # delays (up to ms on a busy machine) do not blur; without one, now on the same clock.
        sent = info.get("source_timestamp", 0)
        out = self._logic.on_joint_state(msg, sent * 1e-9 if sent else time.time())
        if out.pose is not None:
            self._pose_pub.publish(out.pose)
        if out.twist is not None:
            self._twist_pub.publish(out.twist)
        if out.tf is not None and self._tf_pub is not None:
            self._tf_pub.publish(out.tf)
        if out.problem is not None and out.severity >= Severity.WARN:
            self._warn_throttled(out.problem)
        if self._ik_answers:  # IK answers that waited for this turn
            self._deliver_ik_answers()

    def _compute_ik(self, request: Any, response: Any) -> Any:
        # The work starts when rclpy hands over the request's header, right after this returns:
        # its source timestamp says how long the request waited before this callback.
        self._ik_responses.hold(
            response, on_header=lambda header: self._start_ik(request, response, header)
        )
        return response

    def _start_ik(self, request: Any, response: Any, header: Any) -> None:
        """Solve in this thread when the closed form answers at once, else hand the job to the
        pool; either way `response` is released (sent) when its answer is known."""
        pending = self._logic.prepare_ik(request, response, waited=waited_since_sent(header))
        if pending is None:  # refused or answered at once
            self._ik_responses.release(response)
            return
        try:
            outcome = solve_at_once(pending.chain, pending.job)  # the closed form, ~0.2 ms
        except Exception:  # noqa: BLE001 - a worker solves it then, and reports what went wrong
            outcome = None
        if outcome is None:
            try:
                self._pool.submit(
                    pending.job, lambda outcome: self._hand_back(pending, response, outcome)
                )
                return  # released by _deliver_ik_answers
            except RuntimeError as exc:  # the pool is shut down: the node is stopping
                outcome = IKOutcome.failed(str(exc))
        self._ik_responses.release(self._logic.finish_ik(pending, outcome, response))

    def _hand_back(self, pending: PendingIK, response: Any, outcome: IKOutcome) -> None:
        """From the pool's thread: hand the outcome to the executor thread, which collects it on
        the next joint_states turn while they stream, or is woken for it."""
        now = time.monotonic()
        streaming = now - self._last_joint_state < STREAMING_GAP
        # an answer may wait for the next joint_states turn, but never past its deadline
        patience = min(STREAMING_GAP, pending.job.deadline - now) if streaming else 0.0
        self._ik_answers.put((pending, response, outcome, now), patience)

    def _deliver_ik_answers(self) -> None:
        for pending, response, outcome, handed in self._ik_answers.collect():
            now = time.monotonic()
            self._ik_responses.release(self._logic.finish_ik(pending, outcome, response, now))
            late = now - pending.job.deadline
            if late > LATE_ANSWER_WARNING:
                self._warn_throttled(
                    f"an IK answer left {late * 1e3:.0f} ms after its deadline (the worker pool "
                    f"handed it over {(handed - pending.job.deadline) * 1e3:+.0f} ms from it; "
                    "the rest is this process's delay)",
                    kind="late IK answer",
                )

    def _publish_markers(self) -> None:
        """At markers_rate: the markers of the last state, only while someone subscribes."""
        pub, types = self._markers_pub, self._marker_types
        if pub is None or types is None or pub.get_subscription_count() == 0:
            return
        msg = self._logic.markers(types)
        if msg is not None:
            pub.publish(msg)

    def _publish_static_tf(self) -> None:
        """/tf_static of the description in use (again when it changes), stamped now."""
        if self._tf_static_pub is None:
            return
        msg = self._logic.static_tf(self.get_clock().now().to_msg())
        if msg is not None:
            self._tf_static_pub.publish(msg)

    def _publish_diagnostics(self) -> None:
        if self.get_parameter("publish_diagnostics").value:
            self._diag_pub.publish(self._logic.diagnostics(asdict(self._pool.stats())))

    def _lookup_transform(self, target_frame: str, source_frame: str) -> np.ndarray:
        """T_target_source from TF (latest available); raises when unavailable."""
        if self._tf_buffer is None:
            raise KinematicsError(TF_MISSING)
        stamped = self._tf_buffer.lookup_transform(target_frame, source_frame, Time())
        return matrix_from_transform(stamped.transform, "TF transform")

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in SPECS}  # e.g. not use_sim_time
        fixed = sorted(set(changes) & STARTUP_ONLY)
        if fixed:
            return SetParametersResult(
                successful=False, reason=f"{', '.join(fixed)}: read at start-up only"
            )
        model = self._logic.model
        answer = answer_parameter_change(
            lambda: self._logic.configure(changes), self._log_description_events
        )
        if self._logic.model is not model and self._logic.model is not None:
            self._publish_static_tf()
            freeze_heap()
        return answer

    def destroy_node(self) -> None:
        # Also called by rclpy's context at shutdown (Kilted's rclpy destroys every node it
        # tracks) on a node whose __init__ raised, a refused parameter: tear down what was built.
        pool = getattr(self, "_pool", None)
        if pool is not None:
            pool.shutdown()  # answers every open job (into the mailbox)
        answers = getattr(self, "_ik_answers", None)
        if answers is not None:
            answers.close()
        super().destroy_node()


def _default_workers() -> int:
    """Solves that may run at once: 4, or one per core where there are more (at most 8). Fewer
    than the clients calling at once would queue reachable targets behind unreachable ones, which
    take their whole timeout. The workers run niced, so the pose path preempts them; each holds
    the core and the model (~50 MB, mostly shared with the fork server)."""
    return min(max(os.cpu_count() or 1, 4), 8)


def main(args: list[str] | None = None) -> int:
    """Entry point of the `kinematics_node` executable: 0 after SIGINT/SIGTERM, 2 when a
    start-up parameter is invalid (one line on stderr saying which); see `spin`."""
    return spin_until_shutdown(
        KinematicsNode,
        "kinematics_node",
        (InvalidInputError, ParameterException),
        args,
        STOP_DEADLINE_S,
    )


if __name__ == "__main__":
    main()
