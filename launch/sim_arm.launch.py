"""A simulated bundled arm + robot_state_publisher + the kinematics node (+ RViz on request).

    ros2 launch kinematics_service sim_arm.launch.py                 # the UR5e
    ros2 launch kinematics_service sim_arm.launch.py robot:=panda rviz:=true

Arguments:
    robot: bundled robot, a file config/robots/<robot>.urdf of this package
        (ur5e, panda, iiwa14, scara, planar3r); default ur5e.
    base_link, tip_link: chain of the kinematics node; empty = the robot's default chain
        (kinematics_node.sim.robots.default_chain_links), e.g. panda_link0 -> panda_hand_tcp.
    rate: sim_arm integration and joint_states rate [Hz] (default 100.0).
    rviz: "true" starts RViz with config/sim_arm.rviz (fixed frame = base_link).
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
    rate = float(LaunchConfiguration("rate").perform(context))
    # Fast DDS's short shared-memory health check, unless the environment names a profile
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
            parameters=[{"robot": robot, "rate": rate}],
            output="screen",
            additional_env=env,
        ),
        Node(
            package=PACKAGE,
            executable="kinematics_node",
            name="kinematics_node",
            parameters=[
                os.path.join(share, "config", "kinematics.yaml"),
                {
                    "robot_description_file": description_file,
                    "base_link": base_link,
                    "tip_link": tip_link,
                },
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
            DeclareLaunchArgument("rate", default_value="100.0", description="sim rate [Hz]"),
            DeclareLaunchArgument("rviz", default_value="false", description="start RViz"),
            OpaqueFunction(function=_nodes),
        ]
    )
