"""ROS 2 node `sim_arm`: a simulated arm publishing ``joint_states`` (rclpy wiring only).

The simulation is `kinematics_node.sim.arm.ArmSimulator`; message conversion is
`msg_adapters.joint_commands`. This module only connects them to rclpy (Humble and Jazzy API).

Parameters (`executables.SIM_ARM_PARAMETERS`, which `sim_arm --help` lists):
    robot_description_file (str, ""): a URDF or xacro file, expanded with `xacro_args` (str,
        "name:=value ..."), as the kinematics node reads its parameter of that name.
    robot_description (str, ""): URDF/xacro XML; with neither, the bundled robot `robot` is used.
    robot (str, "ur5e"): bundled robot name (see `kinematics_node.sim.robots.available_robots`).
    base_link, tip_link (str, ""): when tip_link is set, simulate only the chain base → tip;
        otherwise every moving non-mimic joint (what robot_state_publisher needs).
    rate (double, 100.0): publishing and integration rate [Hz]; the step is 1/rate [s].
    command_timeout (double, 0.5): how long a velocity command is held [s].
    demo (bool, true): move in the built-in demo motion until the first command.
    demo_resume_after (double, 0.0): restart the demo after this many idle seconds; ≤ 0: never.
    command_mode (str, "demo"): "demo" as above; "position", "velocity", "trajectory": no demo,
        the arm holds still until commanded on `command_topic` the way ros2_control's
        forward_command_controller (positions or velocities) or joint_trajectory_controller
        takes commands (how the servo node drives it).
    command_topic (str, ""): empty = that controller's topic (`CONTROLLER_TOPICS`).
    command_joints (str, ""): the joints a Float64MultiArray command on `command_topic` is for,
        "joint joint ...", in its order (forward_command_controller's `joints`); the others hold
        still; empty = every simulated joint. So the servo drives an arm's chain while the
        simulation also publishes the gripper's joints that robot_state_publisher needs.
    initial_positions (double[], []): where the arm starts; empty = the middle of its limits.
    thread_priority (int, 0): SCHED_FIFO priority (1-99) of the node's thread, set at start-up
        (standing in for ros2_control's controller_manager, whose loop runs SCHED_FIFO at 50 by
        default; `realtime.apply_thread_priority`); 0 = leave the scheduling alone. A system
        that does not permit it is logged, and the node runs on.

Topics (relative names): publishes ``joint_states`` (sensor_msgs/JointState); subscribes
``joint_trajectory`` (trajectory_msgs/JointTrajectory) and ``joint_velocity_commands``
(std_msgs/Float64MultiArray, one value per published joint name, in that order), in every mode,
and `command_topic` in the command modes. Malformed commands are refused with a logged warning;
the node keeps running.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import ParameterException, ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from kinematics_node.core import SerialChain
from kinematics_node.core.exceptions import KinematicsError
from kinematics_node.ros.executables import SIM_ARM_PARAMETERS
from kinematics_node.ros.node_log import log_lines
from kinematics_node.ros.node_setup import check_parameter_names
from kinematics_node.ros.realtime import apply_thread_priority
from kinematics_node.ros.spin import STOP_DEADLINE_S, spin_until_shutdown
from kinematics_node.service.description_file import read_description_file
from kinematics_node.service.servo_parameters import CONTROLLER_TOPICS
from kinematics_node.sim.arm import ArmSimulator
from kinematics_node.sim.robots import default_chain_links, robot_path
from msg_adapters.joint_commands import (
    apply_position_msg,
    apply_trajectory_msg,
    apply_velocity_msg,
    fill_joint_state,
)

COMMAND_MODES = ("demo", *CONTROLLER_TOPICS)


class SimArmNode(Node):
    """Steps an `ArmSimulator` on a timer and publishes its joint states."""

    def __init__(self) -> None:
        super().__init__("sim_arm")
        p = self._declare_parameters()
        check_parameter_names(self)  # a typo (-p rat:=...) is named, not silently ignored
        description = p["robot_description"]
        if not description and p["robot_description_file"]:
            description = read_description_file(p["robot_description_file"], p["xacro_args"]).xml
        bundled = not description
        if bundled:
            description = robot_path(p["robot"]).read_text(encoding="utf-8")
        rate = p["rate"]
        if not rate > 0:
            raise KinematicsError(f"parameter rate must be > 0 Hz, got {rate}")
        priority = p["thread_priority"]
        if not 0 <= priority <= 99:
            raise KinematicsError(
                f"parameter thread_priority must be 0 (leave the scheduling alone) or a "
                f"SCHED_FIFO priority 1-99, got {priority}"
            )
        mode = p["command_mode"]
        if mode not in COMMAND_MODES:
            raise KinematicsError(
                f"parameter command_mode must be one of {list(COMMAND_MODES)}, got {mode!r}"
            )
        options = {
            "command_timeout": p["command_timeout"],
            "demo": p["demo"] and mode == "demo",
            "demo_resume_after": p["demo_resume_after"] if mode == "demo" else 0.0,
            "q0": list(p["initial_positions"]) or None,
        }
        if p["tip_link"]:
            base = p["base_link"] or None
            if bundled and base is None:
                base = default_chain_links(p["robot"])[0]
            chain = SerialChain.from_urdf(description, base_link=base, tip_link=p["tip_link"])
            self.sim = ArmSimulator.from_chain(chain, 1.0 / rate, **options)
        else:
            self.sim = ArmSimulator.from_urdf(description, 1.0 / rate, **options)

        self._pub = self.create_publisher(JointState, "joint_states", 10)
        self.create_subscription(JointTrajectory, "joint_trajectory", self._on_trajectory, 10)
        self.create_subscription(
            Float64MultiArray, "joint_velocity_commands", self._on_velocity, 10
        )
        self._command_topic = ""
        if mode != "demo":
            self._command_topic = p["command_topic"] or CONTROLLER_TOPICS[mode]
            kind = JointTrajectory if mode == "trajectory" else Float64MultiArray
            joints = _command_joints(p["command_joints"], self.sim.joint_names)
            self._apply = {
                "position": lambda sim, msg, topic: apply_position_msg(sim, msg, topic, joints),
                "velocity": lambda sim, msg, topic: apply_velocity_msg(sim, msg, topic, joints),
                "trajectory": lambda sim, msg, topic: apply_trajectory_msg(sim, msg),
            }[mode]
            self.create_subscription(kind, self._command_topic, self._on_command, 10)
        self.create_timer(1.0 / rate, self._on_timer)
        commanded = f"; {mode} commands on {self._command_topic}" if mode != "demo" else ""
        self.get_logger().info(
            f"simulating {self.sim.dof} joints {list(self.sim.joint_names)} at {rate:g} Hz"
            + commanded
        )
        said = apply_thread_priority(priority)
        log_lines(self.get_logger(), [said] if said is not None else [])

    def _declare_parameters(self) -> dict:
        values = {}
        for spec in SIM_ARM_PARAMETERS:
            descriptor = ParameterDescriptor(description=spec.description)
            if isinstance(spec.default, tuple):  # a double array, unset by default
                self.declare_parameter(spec.name, Parameter.Type.DOUBLE_ARRAY, descriptor)
                try:
                    values[spec.name] = tuple(self.get_parameter(spec.name).value)
                except ParameterUninitializedException:
                    values[spec.name] = spec.default
                continue
            self.declare_parameter(spec.name, spec.default, descriptor)
            values[spec.name] = self.get_parameter(spec.name).value
        return values

    def _on_timer(self) -> None:
        _, q, qdot = self.sim.step()
        msg = fill_joint_state(
            JointState(), self.sim.joint_names, q, qdot, self.get_clock().now().to_msg()
        )
        self._pub.publish(msg)

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        try:
            cmd = apply_trajectory_msg(self.sim, msg)
        except (KinematicsError, ValueError) as exc:
            self.get_logger().warning(f"refused joint_trajectory: {exc}")
            return
        self.get_logger().info(
            f"following a trajectory of {len(cmd.times)} points over {cmd.times[-1]:.3g} s"
        )

    def _on_velocity(self, msg: Float64MultiArray) -> None:
        try:
            apply_velocity_msg(self.sim, msg)
        except (KinematicsError, ValueError) as exc:
            self.get_logger().warning(f"refused joint_velocity_commands: {exc}")

    def _on_command(self, msg: Any) -> None:
        """A command on command_topic (streamed, e.g. at the servo's 1 kHz: nothing is logged
        per message, and refusals at most every 5 s)."""
        try:
            self._apply(self.sim, msg, self._command_topic)
        except (KinematicsError, ValueError) as exc:
            self.get_logger().warning(
                f"refused a command on {self._command_topic}: {exc}", throttle_duration_sec=5.0
            )


def _command_joints(text: str, simulated: tuple[str, ...]) -> tuple[str, ...] | None:
    """The joints of the command_joints parameter (None: all), checked against the simulated
    ones."""
    names = tuple(text.replace(",", " ").split())
    if not names:
        return None
    if len(set(names)) != len(names) or not set(names) <= set(simulated):
        raise KinematicsError(
            f"parameter command_joints must name distinct simulated joints (of {list(simulated)}), "
            f"got {text!r}"
        )
    return names


def main(args: list[str] | None = None) -> int:
    """Entry point of the `sim_arm` executable: 0 after SIGINT/SIGTERM, 2 when a start-up
    parameter is invalid (one line on stderr saying which); see `spin`."""
    return spin_until_shutdown(
        SimArmNode, "sim_arm", (KinematicsError, ParameterException), args, STOP_DEADLINE_S
    )


if __name__ == "__main__":
    main()
