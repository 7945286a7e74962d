"""CI runs the tests that touch ROS on every ROS 2 distribution and the rest once
(conftest.ROS_TESTS, KINEMATICS_TESTS=ros): every test module that imports rclpy, starts the built
node or sources the build's environment must be among the former, or a second distribution would
never run it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import ROS_TESTS, touches_ros

HERE = Path(__file__).resolve().parent

#: What in a module's source says that it runs ROS: an rclpy or launch import, the live helpers
#: (which start the built node), the built executables, the build's env.sh.
_RUNS_ROS = re.compile(
    r"^\s*(from|import) (rclpy|launch|launch_testing|live_node|servo_node_testing\.live)\b"
    r"|KINEMATICS_ROS_ENV|KINEMATICS_NODE_EXECUTABLE|ros\.env import .*\bexecutable\b",
    re.MULTILINE,
)


def _test_modules() -> list[Path]:
    own = Path(__file__).resolve()  # names the patterns, runs nothing
    return sorted(p for p in HERE.rglob("test_*.py") if p.resolve() != own)


def test_every_module_that_runs_ros_is_among_the_ros_tests() -> None:
    unmarked = [
        p.relative_to(HERE).as_posix()
        for p in _test_modules()
        if _RUNS_ROS.search(p.read_text(encoding="utf-8")) and not touches_ros(p)
    ]
    assert unmarked == [], f"add these to conftest.ROS_TESTS: {unmarked}"


def test_each_entry_names_something_that_exists() -> None:
    for entry in ROS_TESTS:
        assert (HERE / entry).exists(), entry


@pytest.mark.parametrize(
    ("rel", "expected"),
    [("live/test_spin.py", True), ("cli/test_ros_commands.py", True), ("cli/test_cli.py", False)],
)
def test_touches_ros_reads_folders_and_modules(rel: str, expected: bool) -> None:
    assert touches_ros(HERE / rel) is expected
