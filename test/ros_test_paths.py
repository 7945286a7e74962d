"""Which test modules touch ROS 2 (conftest.py marks them `ros`; KINEMATICS_TESTS=ros keeps only
them). A module of its own, since `conftest` names several modules of the suite."""

from __future__ import annotations

from pathlib import Path

#: The tests that start or import ROS 2 (rclpy, the built node, launch), relative to test/: a
#: folder (ending in /) or a module. They carry the marker `ros`, and they are all that a run with
#: KINEMATICS_TESTS=ros keeps: CI runs the whole suite on its first ROS distribution and only these
#: on the others, since the rest never touches ROS and gives the same answers on every one.
#: test_suite_split.py checks that every module that imports rclpy or starts the node is here.
ROS_TESTS = ("live/", "launch/", "ros/", "cli/test_ros_commands.py")
_HERE = Path(__file__).resolve().parent


def touches_ros(path: Path) -> bool:
    """Whether the test module at `path` is one of `ROS_TESTS`."""
    rel = path.resolve().relative_to(_HERE).as_posix()
    return any(
        rel.startswith(entry) if entry.endswith("/") else rel == entry for entry in ROS_TESTS
    )
