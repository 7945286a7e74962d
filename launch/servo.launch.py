"""A simulated bundled arm driven by the servo node, with the kinematics node watching it.

    ros2 launch kinematics_service servo.launch.py                 # the UR5e, servo at 1 kHz
    ros2 launch kinematics_service servo.launch.py robot:=panda command_out_type:=trajectory

Then jog it (README, "Servo"): twists on /servo/delta_twist_cmds, e.g. from the keyboard with
teleop_twist_keyboard, joint velocities on /servo/delta_joint_state_cmds, pose targets on
/servo/pose_target_cmds; watch /servo/status and /ee_pose.

Starts robot_state_publisher (TF and the robot_description topic), sim_arm in command mode at
`ready` joint positions (no demo motion: it holds still until the servo commands it), the
kinematics node (ee_pose, ee_twist) and the servo (config/servo.yaml), all on the same chain.

Arguments:
    robot: bundled robot (ur5e, panda, iiwa14, scara, planar3r); default ur5e.
    base_link, tip_link: the chain; empty = the robot's default chain.
    command_out_type: how the servo commands the arm: position (default) or velocity
        (std_msgs/Float64MultiArray, as forward_command_controller takes them), or trajectory
        (trajectory_msgs/JointTrajectory, as joint_trajectory_controller); sim_arm takes the
        same, on the same topic.
    period: the servo's period [s] (default 0.001: 1 kHz).
    rate: sim_arm's integration and joint_states rate [Hz] (default 100.0).
    rviz: "true" starts RViz with config/sim_arm.rviz.
"""

import os  # noqa: I001  (ruff would sort `launch` as first-party: the repo has a launch/ folder)

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from kinematics_node.sim.robots import default_chain_links
from kinematics_node.ros.env import fastdds_profile_env

PACKAGE = "kinematics_service"

#: Joint positions the simulated arm starts at, per bundled robot (its default chain's joints):
#: well inside the limits and away from singularities, so that jogging starts in every direction.
READY = {
    "ur5e": [0.0, -1.57, 1.57, -1.57, -1.57, 0.0],
    "panda": [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
    "iiwa14": [0.0, 0.6, 0.0, -1.2, 0.0, 0.9, 0.0],
    "scara": [0.0, 1.0, -0.1, 0.0],
    "planar3r": [0.0, 1.0, -0.8],
}


def _nodes(context, *args, **kwargs):
    share = get_package_share_directory(PACKAGE)
    robot = LaunchConfiguration("robot").perform(context)
    robots_dir = os.path.join(share, "config", "robots")
    description_file = os.path.join(robots_dir, robot + ".urdf")
    if not os.path.isfile(description_file):
        names = sorted(f[: -len(".urdf")] for f in os.listdir(robots_dir) if f.endswith(".urdf"))
        raise RuntimeError(f"unknown robot {robot!r}; bundled robots are: {', '.join(names)}")
    with open(description_file, encoding="utf-8") as fh:
        robot_description = ParameterValue(fh.read(), value_type=str)
    default_base, default_tip = default_chain_links(robot)
    base_link = LaunchConfiguration("base_link").perform(context) or default_base
    tip_link = LaunchConfiguration("tip_link").perform(context) or default_tip
    out_type = LaunchConfiguration("command_out_type").perform(context)
    period = float(LaunchConfiguration("period").perform(context))
    rate = float(LaunchConfiguration("rate").perform(context))
    chain = {
        "robot_description_file": description_file,
        "base_link": base_link,
        "tip_link": tip_link,
    }
    # the sim simulates the chain's joints, in its order: the servo's Float64MultiArray fits
    sim = {
        "robot": robot,
        "rate": rate,
        "command_mode": out_type,
        "base_link": base_link,
        "tip_link": tip_link,
    }
    if (base_link, tip_link) == (default_base, default_tip):
        sim["initial_positions"] = READY[robot]
    env = fastdds_profile_env(os.path.join(share, "config", "fastdds_profile.xml"))
    return [
        Node(
            package="robot_state_publisher",
            executable="robot_state_publisher",
            name="robot_state_publisher",
            parameters=[{"robot_description": robot_description}],
            output="screen",
            additional_env=env,
        ),
        Node(
            package=PACKAGE,
            executable="sim_arm",
            name="sim_arm",
            parameters=[sim],
            output="screen",
            additional_env=env,
        ),
        Node(
            package=PACKAGE,
            executable="kinematics_node",
            name="kinematics_node",
            parameters=[os.path.join(share, "config", "kinematics.yaml"), chain],
            output="screen",
            additional_env=env,
        ),
        Node(
            package=PACKAGE,
            executable="servo",
            name="servo",
            parameters=[
                os.path.join(share, "config", "servo.yaml"),
                {**chain, "command_out_type": out_type, "period_s": period},
            ],
            output="screen",
            additional_env=env,
        ),
        Node(
            package="rviz2",
            executable="rviz2",
            name="rviz2",
            arguments=["-d", os.path.join(share, "config", "sim_arm.rviz"), "-f", base_link],
            condition=IfCondition(LaunchConfiguration("rviz")),
            output="screen",
            additional_env=env,
        ),
    ]


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "robot",
                default_value="ur5e",
                description="bundled robot: ur5e, panda, iiwa14, scara or planar3r",
            ),
            DeclareLaunchArgument(
                "base_link", default_value="", description="chain root (empty: robot default)"
            ),
            DeclareLaunchArgument(
                "tip_link", default_value="", description="end effector (empty: robot default)"
            ),
            DeclareLaunchArgument(
                "command_out_type",
                default_value="position",
                description="joint commands: position, velocity or trajectory",
            ),
            DeclareLaunchArgument("period", default_value="0.001", description="servo period [s]"),
            DeclareLaunchArgument("rate", default_value="100.0", description="sim rate [Hz]"),
            DeclareLaunchArgument("rviz", default_value="false", description="start RViz"),
            OpaqueFunction(function=_nodes),
        ]
    )
