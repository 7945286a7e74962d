"""A simulated arm (bundled, or your own description) + robot_state_publisher + the kinematics
node (+ RViz on request); or the kinematics node publishing /tf in robot_state_publisher's place.

    ros2 launch kinematics_service sim_arm.launch.py                 # the UR5e
    ros2 launch kinematics_service sim_arm.launch.py robot:=panda rviz:=true
    ros2 launch kinematics_service sim_arm.launch.py description_file:=my_arm.urdf.xacro
    ros2 launch kinematics_service sim_arm.launch.py state_publisher:=kinematics_node

Arguments:
    robot: bundled robot, a file config/robots/<robot>.urdf of this package
        (ur5e, panda, iiwa14, scara, planar3r); default ur5e.
    description_file, xacro_args: your own robot instead, a URDF or xacro file (relative to
        where you launch); xacro_args "name:=value other:=value".
    base_link, tip_link: chain of the kinematics node; empty = the robot's default chain
        (kinematics_node.sim.robots.default_chain_links), e.g. panda_link0 -> panda_hand_tcp.
    rate: sim_arm integration and joint_states rate [Hz] (default 100.0).
    rviz: "true" starts RViz with config/sim_arm.rviz (fixed frame = base_link).
    state_publisher: who publishes /tf and /tf_static: robot_state_publisher (default), or
        kinematics_node (its publish_tf parameter; robot_state_publisher is then not started, and
        nothing publishes the robot_description topic that RViz's robot model reads).

The arm moves in sim_arm's demo motion. The nodes and arguments are bundled_robot.py's, which
servo.launch.py shares.
"""

import importlib.util  # noqa: I001  (ruff would sort `launch` as first-party: the repo has a launch/ folder)
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import OpaqueFunction

# bundled_robot.py sits beside this file (in share/kinematics_service/launch once installed),
# which is not on sys.path: loaded by its path
_spec = importlib.util.spec_from_file_location(
    "kinematics_service_bundled_robot",
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "bundled_robot.py"),
)
bundled_robot = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bundled_robot)


def _nodes(context, *args, **kwargs):
    share = get_package_share_directory(bundled_robot.PACKAGE)
    robot = bundled_robot.chosen_robot(context, share)
    # every moving joint without <mimic> (what robot_state_publisher needs), in the demo motion
    publisher = bundled_robot.state_publisher(context)
    return bundled_robot.robot_nodes(share, robot, {}, bundled_robot.dds_env(share), publisher)


def generate_launch_description():
    return LaunchDescription([*bundled_robot.arguments(), OpaqueFunction(function=_nodes)])
