"""The node executables without ROS: one line saying what is needed, never a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


@pytest.mark.parametrize("script", ["kinematics_node", "sim_arm"])
def test_without_rclpy_the_executable_says_what_is_needed(script):
    # rclpy may or may not be installed here: hide it, as on a machine without ROS.
    code = (
        "import runpy, sys; sys.modules['rclpy'] = None; "
        f"runpy.run_path({str(SCRIPTS / script)!r}, run_name='__main__')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 1
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert out.stderr.startswith(f"{script}: needs ROS 2 (module 'rclpy' not found)")
