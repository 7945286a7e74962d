"""`kinematics ros` without a node (and without ROS): its arguments and what it says when ROS 2
is missing. Against the running node: test/live/test_node_from_shell.py and test_quickstart.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from kinematics_node.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


def _kinematics_without_rclpy(*args: str) -> subprocess.CompletedProcess[str]:
    code = (
        "import sys; sys.modules['rclpy'] = None; from kinematics_node.cli.main import main; "
        f"sys.exit(main({list(args)!r}))"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT
    )


@pytest.mark.parametrize(
    "args", [["ros", "pose"], ["ros", "ik", "--target", "0.4,0.1,0.4,1,0,0,0"], ["ros", "jog"]]
)
def test_without_rclpy_it_says_how_to_get_ros_in_one_line(args):
    out = _kinematics_without_rclpy(*args)
    assert out.returncode == 1
    assert out.stdout == ""
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert out.stderr.startswith(f"kinematics: error: kinematics ros {args[1]} needs ROS 2 (rclpy")
    assert "make ros && . build/ros/env.sh" in out.stderr
    assert "source install/setup.bash" in out.stderr


@pytest.mark.parametrize(
    ("target", "says"),
    [
        ("0.4,0.1,0.4", "expected 7 values x,y,z,qx,qy,qz,qw, got 3"),
        ("0.4,0.1,0.4,1,0,0,zero", "expected 7 numbers"),
        ("0.4,0.1,nan,1,0,0,0", "every value must be finite"),
        ("0.4,0.1,0.4,0,0,0,0", "the quaternion qx,qy,qz,qw is zero"),
    ],
)
def test_a_bad_target_is_a_usage_error_naming_the_option(capsys, target, says):
    assert main(["ros", "ik", "--target", target]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "argument --target" in err and says in err


@pytest.mark.parametrize("option", ["--wait", "--timeout"])
@pytest.mark.parametrize("value", ["0", "-1", "inf", "soon"])
def test_waits_and_timeouts_are_positive_seconds(capsys, option, value):
    assert main(["ros", "ik", "--target", "0.4,0.1,0.4,1,0,0,0", option, value]) == 2
    assert f"argument {option}: expected a finite number of seconds > 0" in capsys.readouterr().err


def test_the_command_is_listed_in_the_help(capsys):
    assert main(["--help"]) == 0
    assert "    ros " in capsys.readouterr().out
    assert main(["ros", "--help"]) == 0
    out = capsys.readouterr().out
    assert "pose" in out and "ik" in out and "ROS_DOMAIN_ID" in out


@pytest.mark.parametrize("option", ["--speed", "--turn", "--rate"])
@pytest.mark.parametrize("value", ["0", "-0.1", "nan", "fast"])
def test_jog_speeds_and_rate_are_positive_numbers(capsys, option, value):
    assert main(["ros", "jog", option, value]) == 2
    assert f"argument {option}: expected a finite number > 0" in capsys.readouterr().err
