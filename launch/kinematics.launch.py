"""Start the kinematics node alone.

    ros2 launch kinematics_service kinematics.launch.py description_file:=/path/robot.urdf \
        base_link:=base_link tip_link:=tool0
    ros2 launch kinematics_service kinematics.launch.py description_file:=/path/arm.urdf.xacro \
        xacro_args:="name:=arm prefix:=left_"

Arguments:
    description_file: URDF or xacro file, passed to the node as its robot_description_file
        parameter (the node runs xacro on .xacro files, and on any file when xacro_args is set).
        Empty: the parameter file decides (by default: the robot_description topic).
    xacro_args: xacro arguments for description_file, "name:=value other:=value" (the node's
        xacro_args parameter).
    base_link, tip_link: override the parameter file when non-empty.
    params_file: parameter file (default: this package's config/kinematics.yaml).
    namespace: namespace of the node (and so of its relative topics and services).
"""

import os  # noqa: I001  (ruff would sort `launch` as first-party: the repo has a launch/ folder)

from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from launch import LaunchDescription

from kinematics_node.ros.env import fastdds_profile_env


def _kinematics_node(context, *args, **kwargs):
    overrides = {}
    description_file = LaunchConfiguration("description_file").perform(context)
    if description_file:  # absolute: relative to where `ros2 launch` runs, not the node
        overrides["robot_description_file"] = os.path.abspath(os.path.expanduser(description_file))
    for name in ("xacro_args", "base_link", "tip_link"):
        value = LaunchConfiguration(name).perform(context)
        if value:
            overrides[name] = value
    return [
        Node(
            package="kinematics_service",
            executable="kinematics_node",
            name="kinematics_node",
            namespace=LaunchConfiguration("namespace"),
            parameters=[LaunchConfiguration("params_file"), overrides],
            output="screen",
            # Fast DDS's short shared-memory health check (config/fastdds_profile.xml says why),
            # unless the environment names a profile
            additional_env=fastdds_profile_env(
                PathJoinSubstitution(
                    [FindPackageShare("kinematics_service"), "config", "fastdds_profile.xml"]
                ).perform(context)
            ),
        )
    ]


def generate_launch_description():
    default_params = PathJoinSubstitution(
        [FindPackageShare("kinematics_service"), "config", "kinematics.yaml"]
    )
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "description_file",
                default_value="",
                description="URDF or xacro file (the node's robot_description_file); empty = "
                "the parameter file decides (by default: the robot_description topic)",
            ),
            DeclareLaunchArgument(
                "xacro_args",
                default_value="",
                description="xacro arguments for description_file: 'name:=value other:=value'",
            ),
            DeclareLaunchArgument(
                "base_link", default_value="", description="chain root (empty: parameter file)"
            ),
            DeclareLaunchArgument(
                "tip_link", default_value="", description="end effector (empty: parameter file)"
            ),
            DeclareLaunchArgument(
                "params_file", default_value=default_params, description="parameter file"
            ),
            DeclareLaunchArgument("namespace", default_value="", description="node namespace"),
            OpaqueFunction(function=_kinematics_node),
        ]
    )
