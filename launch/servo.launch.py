"""A simulated arm (bundled, or your own description) driven by the servo node, with the
kinematics node watching it.

    ros2 launch kinematics_service servo.launch.py                 # the UR5e, servo at 1 kHz
    ros2 launch kinematics_service servo.launch.py robot:=panda command_out_type:=trajectory
    ros2 launch kinematics_service servo.launch.py thread_priority:=40   # SCHED_FIFO (1 kHz)

Then jog it (README, "Servo"): twists on /servo/delta_twist_cmds, e.g. from the keyboard with
teleop_twist_keyboard, joint velocities on /servo/delta_joint_state_cmds, pose targets on
/servo/pose_target_cmds; watch /servo/status and /ee_pose.

Starts what sim_arm.launch.py starts (bundled_robot.py: robot_state_publisher, sim_arm, the
kinematics node on the chain, RViz on request), with sim_arm in command mode: every moving joint
without <mimic> simulated (robot_state_publisher needs them all: a Panda's finger too), the
chain's joints at `READY` positions and taking the servo's commands (`command_joints`), the rest
holding still; and the servo (config/servo.yaml) on the same chain.

    ros2 launch kinematics_service servo.launch.py description_file:=my_arm.urdf tip_link:=tool0

Arguments:
    robot: bundled robot (ur5e, panda, iiwa14, scara, planar3r); default ur5e.
    description_file, xacro_args: your own robot instead, a URDF or xacro file; it starts in the
        middle of its joint limits.
    base_link, tip_link: the chain; empty = the robot's default chain (your own robot's: its
        root and its one tip; with several tips, say which: the launch lists them).
    command_out_type: how the servo commands the arm: position (default) or velocity
        (std_msgs/Float64MultiArray, as forward_command_controller takes them), or trajectory
        (trajectory_msgs/JointTrajectory, as joint_trajectory_controller); sim_arm takes the
        same, on the same topic.
    period: the servo's period [s] (default 0.001: 1 kHz).
    thread_priority: SCHED_FIFO priority (1-99) of the servo's thread, and that plus 10 (at most
        99) of sim_arm's, which stands in for ros2_control's controller_manager, whose loop runs
        above the servo (their defaults: moveit_servo 40, controller_manager 50); 0 (default)
        leaves the scheduling alone. On a busy machine the default scheduling lets the 1 kHz
        loop's thread wait behind other processes for periods at a time; 40 (servo 40, sim_arm
        50) is what docs/performance.md measured. Where SCHED_FIFO is not permitted (no
        CAP_SYS_NICE, no rtprio limit) both nodes say so in their log and run as before.
    rate: sim_arm's integration and joint_states rate [Hz] (default 100.0).
    rviz: "true" starts RViz with config/sim_arm.rviz.
    state_publisher: robot_state_publisher (default) or kinematics_node (publish_tf: the
        kinematics node publishes /tf and /tf_static, and robot_state_publisher is not started).
"""

import importlib.util  # noqa: I001  (ruff would sort `launch` as first-party: the repo has a launch/ folder)
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from kinematics_node.core import SerialChain
from kinematics_node.core.model import middle_of_limits
from kinematics_node.sim.arm import urdf_actuated_joints

# bundled_robot.py sits beside this file (in share/kinematics_service/launch once installed),
# which is not on sys.path: loaded by its path
_spec = importlib.util.spec_from_file_location(
    "kinematics_service_bundled_robot",
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "bundled_robot.py"),
)
bundled_robot = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bundled_robot)

#: Joint positions the simulated arm starts at, per bundled robot (its default chain's joints):
#: well inside the limits and away from singularities, so that jogging starts in every direction.
#: The joints off the chain (a Panda's finger) start in the middle of their limits.
READY = {
    "ur5e": [0.0, -1.57, 1.57, -1.57, -1.57, 0.0],
    "panda": [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
    "iiwa14": [0.0, 0.6, 0.0, -1.2, 0.0, 0.9, 0.0],
    "scara": [0.0, 1.0, -0.1, 0.0],
    "planar3r": [0.0, 1.0, -0.8],
}


#: sim_arm's thread_priority is the servo's plus this (at most 99): ros2_control's
#: controller_manager (default 50) runs above moveit_servo (default 40).
SIM_PRIORITY_ABOVE = 10


def thread_priorities(text):
    """(servo, sim_arm) thread_priority from the launch argument `text`; raises RuntimeError
    naming the argument unless it is an integer 0-99."""
    try:
        priority = int(text)
    except ValueError:
        priority = -1
    if not 0 <= priority <= 99:
        raise RuntimeError(
            f"thread_priority must be an integer 0-99 (0: the default scheduling), got {text!r}"
        )
    return priority, (min(priority + SIM_PRIORITY_ABOVE, 99) if priority else 0)


def _nodes(context, *args, **kwargs):
    share = get_package_share_directory(bundled_robot.PACKAGE)
    robot = bundled_robot.chosen_robot(context, share)
    out_type = LaunchConfiguration("command_out_type").perform(context)
    period = float(LaunchConfiguration("period").perform(context))
    servo_priority, sim_priority = thread_priorities(
        LaunchConfiguration("thread_priority").perform(context)
    )
    try:
        chain = SerialChain.from_urdf(robot["xml"], robot["base_link"], robot["tip_link"])
    except Exception as exc:  # a chain the description does not have (names the candidates)
        raise RuntimeError(f"base_link/tip_link: {exc}") from None
    # sim_arm simulates every moving joint without <mimic>; the servo's Float64MultiArray holds
    # the chain's, in chain order: command_joints says which
    sim = {
        "command_mode": out_type,
        "command_joints": " ".join(chain.joint_names),
        "thread_priority": sim_priority,
    }
    if robot["default_chain"]:
        names, lower, upper, _ = urdf_actuated_joints(robot["description_file"])
        ready = dict(zip(chain.joint_names, READY[robot["robot"]], strict=True))
        middle = middle_of_limits(lower, upper)
        sim["initial_positions"] = [
            float(ready.get(name, middle[k])) for k, name in enumerate(names)
        ]
    env = bundled_robot.dds_env(share)
    servo = Node(
        package=bundled_robot.PACKAGE,
        executable="servo",
        name="servo",
        parameters=[
            os.path.join(share, "config", "servo.yaml"),
            {
                **bundled_robot.chain_parameters(robot),
                "command_out_type": out_type,
                "period_s": period,
                "thread_priority": servo_priority,
            },
        ],
        output="screen",
        additional_env=env,
    )
    publisher = bundled_robot.state_publisher(context)
    return [*bundled_robot.robot_nodes(share, robot, sim, env, publisher), servo]


def generate_launch_description():
    return LaunchDescription(
        [
            *bundled_robot.arguments(),
            DeclareLaunchArgument(
                "command_out_type",
                default_value="position",
                description="joint commands: position, velocity or trajectory",
            ),
            DeclareLaunchArgument("period", default_value="0.001", description="servo period [s]"),
            DeclareLaunchArgument(
                "thread_priority",
                default_value="0",
                description="SCHED_FIFO priority of the servo (sim_arm: 10 above, at most 99); "
                "0: the default scheduling",
            ),
            OpaqueFunction(function=_nodes),
        ]
    )
