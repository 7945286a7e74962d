"""launch/sim_arm.launch.py (with its helper launch/bundled_robot.py): the files it refers to
exist, its RViz config shows what it should, and it builds a launch description where ROS 2
launch is installed."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

from kinematics_node.sim import robots

REPO = Path(__file__).resolve().parents[2]
LAUNCH = REPO / "launch" / "sim_arm.launch.py"
HELPER = REPO / "launch" / "bundled_robot.py"  # its nodes and arguments, shared with servo.launch


def _launch_constants() -> set[str]:
    strings = set()
    for path in (LAUNCH, HELPER):
        nodes = ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        strings |= {
            n.value for n in nodes if isinstance(n, ast.Constant) and isinstance(n.value, str)
        }
    return strings


def test_every_file_the_launch_file_refers_to_exists():
    strings = _launch_constants()
    # Files are joined from share-relative parts: os.path.join(share, "config", "<file>").
    assert "config" in strings and "robots" in strings
    referenced = {s for s in strings if Path(s).suffix in (".yaml", ".rviz") and Path(s).stem}
    assert referenced == {"kinematics.yaml", "sim_arm.rviz"}
    # the default robot, and every robot the launch file offers, is a bundled file
    assert "ur5e" in strings
    offered = next(s for s in strings if s.startswith("bundled robot:"))
    for name in robots.available_robots():
        assert name in offered
        assert (REPO / "config" / "robots" / f"{name}.urdf").is_file()
    missing = sorted(name for name in referenced if not (REPO / "config" / name).is_file())
    if missing == ["kinematics.yaml"]:
        pytest.skip("config/kinematics.yaml is written on the ROS-layer branch (after merge)")
    assert not missing, f"the launch file refers to missing files in config/: {missing}"


def test_rviz_config_shows_the_robot_tf_and_ee_pose():
    rviz = (REPO / "config" / "sim_arm.rviz").read_text(encoding="utf-8")
    for needed in (
        "rviz_default_plugins/RobotModel",
        "rviz_default_plugins/TF",
        "rviz_default_plugins/Pose",
        "Value: /ee_pose",
        "Value: /robot_description",
    ):
        assert needed in rviz


def test_launch_file_builds_a_launch_description():
    # (check launch_ros first: the repo's own launch/ folder is importable as a namespace package)
    pytest.importorskip(
        "launch_ros", reason="ROS 2 launch_ros is not installed here; the file is only parsed"
    )
    launch = pytest.importorskip("launch")
    spec = importlib.util.spec_from_file_location("sim_arm_launch", LAUNCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    assert isinstance(description, launch.LaunchDescription)
    names = {getattr(e, "name", None) for e in description.entities}
    assert {"robot", "rviz", "base_link", "tip_link", "rate", "state_publisher"} <= names
