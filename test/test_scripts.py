"""The node executables without ROS: one line saying what is needed, never a traceback."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


@pytest.mark.parametrize(
    ("script", "uses_our_interfaces"), [("kinematics_node", True), ("sim_arm", False)]
)
def test_without_rclpy_the_executable_says_what_is_needed(script, uses_our_interfaces):
    # rclpy may or may not be installed here: hide it, as on a machine without ROS.
    code = (
        "import runpy, sys; sys.modules['rclpy'] = None; "
        f"runpy.run_path({str(SCRIPTS / script)!r}, run_name='__main__')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 1
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    # the first ROS package the import misses: the node's first is our built interfaces, which
    # are missing too when the workspace is not sourced (`. build/ros/env.sh`)
    built = importlib.util.find_spec("kinematics_service") is not None
    missing = "kinematics_service" if uses_our_interfaces and not built else "rclpy"
    assert out.stderr.startswith(f"{script}: needs ROS 2 (module {missing!r} not found)")
