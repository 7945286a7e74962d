"""rclpy wiring of the kinematics node (executable `kinematics_node`); all behaviour is in
`KinematicsService` (`service.py`), which is tested without ROS.

Topics (relative names, so namespaces and remaps apply):
  sub  joint_states       sensor_msgs/JointState   sensor-data QoS (best effort: matches reliable
                                                   and best-effort publishers)
  sub  robot_description  std_msgs/String          transient local, reliable (only when the
                                                   robot_description parameter is empty)
  pub  ee_pose            geometry_msgs/PoseStamped
  pub  ee_twist           geometry_msgs/TwistStamped
  pub  /diagnostics       diagnostic_msgs/DiagnosticArray (absolute, as aggregators expect)
Services: compute_fk, compute_jacobian, compute_ik (kinematics_service/srv/...), in a reentrant
callback group of their own, run by a MultiThreadedExecutor, so a long IK call never delays the
joint_states → ee_pose path. Uses only API available in both Humble and Jazzy.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped
from kinematics_service.srv import ComputeFK, ComputeIK, ComputeJacobian
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_ros import Buffer, TransformListener

from msg_adapters import MessageTypes, matrix_from_transform

from .core.exceptions import KinematicsError
from .parameters import PARAMETERS, SPECS, ParameterSpec
from .service import KinematicsService


def _descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    text = spec.description
    if spec.choices:
        text += f" One of: {', '.join(spec.choices)}."
    d = ParameterDescriptor(description=text)
    if isinstance(spec.default, bool):
        return d
    if isinstance(spec.default, float) and spec.minimum is not None and spec.maximum is not None:
        d.floating_point_range = [
            FloatingPointRange(
                from_value=float(spec.minimum), to_value=float(spec.maximum), step=0.0
            )
        ]
    elif isinstance(spec.default, int) and spec.minimum is not None and spec.maximum is not None:
        d.integer_range = [
            IntegerRange(from_value=int(spec.minimum), to_value=int(spec.maximum), step=1)
        ]
    return d


class KinematicsNode(Node):
    """Parameters, publishers, subscriptions and services around one `KinematicsService`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("kinematics_node", **kwargs)
        for spec in PARAMETERS:
            self.declare_parameter(spec.name, spec.default, _descriptor(spec))
        values = {spec.name: self.get_parameter(spec.name).value for spec in PARAMETERS}

        self._tf_buffer = Buffer()
        self._tf_listener = TransformListener(self._tf_buffer, self)
        self._logic = KinematicsService(
            MessageTypes.from_rclpy(),
            {k: v for k, v in values.items() if k != "robot_description"},
            lookup_transform=self._lookup_transform,
            clock=lambda: self.get_clock().now().nanoseconds * 1e-9,
        )
        if values["robot_description"]:
            self._load(values["robot_description"], "the robot_description parameter")
        self.add_on_set_parameters_callback(self._on_set_parameters)

        state_group = MutuallyExclusiveCallbackGroup()  # joint_states and description, in order
        service_group = ReentrantCallbackGroup()  # IK calls may overlap each other
        self._pose_pub = self.create_publisher(PoseStamped, "ee_pose", 10)
        self._twist_pub = self.create_publisher(TwistStamped, "ee_twist", 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_subscription(
            JointState,
            "joint_states",
            self._on_joint_state,
            qos_profile_sensor_data,
            callback_group=state_group,
        )
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        self.create_subscription(
            String, "robot_description", self._on_description, latched, callback_group=state_group
        )
        self.create_service(
            ComputeFK, "compute_fk", self._logic.compute_fk, callback_group=service_group
        )
        self.create_service(
            ComputeJacobian,
            "compute_jacobian",
            self._logic.compute_jacobian,
            callback_group=service_group,
        )
        self.create_service(
            ComputeIK, "compute_ik", self._logic.compute_ik, callback_group=service_group
        )
        self._diag_timer = self.create_timer(
            float(values["diagnostics_period"]),
            self._publish_diagnostics,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        self._warned: str | None = None

    # -------------------------------------------------------------- callbacks
    def _load(self, description: str, source: str) -> bool:
        try:
            model = self._logic.load_description(description)
        except KinematicsError as exc:
            self.get_logger().error(f"cannot use the robot description from {source}: {exc}")
            return False
        chain = model.chain
        self.get_logger().info(
            f"loaded {model.robot_name!r} from {source}: {chain.base_link} -> {chain.tip_link}, "
            f"joints {list(chain.joint_names)}"
        )
        return True

    def _on_description(self, msg: String) -> None:
        if self.get_parameter("robot_description").value:
            return  # the parameter wins over the topic
        self._load(msg.data, "the robot_description topic")

    def _on_joint_state(self, msg: JointState) -> None:
        out = self._logic.on_joint_state(msg)
        if out.pose is not None:
            self._pose_pub.publish(out.pose)
        if out.twist is not None:
            self._twist_pub.publish(out.twist)
        if out.problem and out.problem != "velocity unknown" and out.problem != self._warned:
            self.get_logger().warn(out.problem, throttle_duration_sec=5.0)
        self._warned = out.problem

    def _publish_diagnostics(self) -> None:
        if self.get_parameter("publish_diagnostics").value:
            self._diag_pub.publish(self._logic.diagnostics())

    def _lookup_transform(self, target_frame: str, source_frame: str) -> np.ndarray:
        """T_target_source from TF (latest available); raises tf2 exceptions when unavailable."""
        stamped = self._tf_buffer.lookup_transform(target_frame, source_frame, Time())
        return matrix_from_transform(stamped.transform, "TF transform")

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in SPECS}  # e.g. not use_sim_time
        if "diagnostics_period" in changes:
            return SetParametersResult(
                successful=False, reason="diagnostics_period is read at start-up only"
            )
        try:
            self._logic.configure(changes)
        except KinematicsError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)


def main(args: list[str] | None = None) -> None:
    """Entry point of the `kinematics_node` executable."""
    rclpy.init(args=args)
    node = None
    try:
        node = KinematicsNode()
        executor = MultiThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
