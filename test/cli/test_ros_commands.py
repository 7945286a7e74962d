"""`kinematics ros` without a node (and without ROS): its arguments and what it says when ROS 2
is missing. Against the running node: test/live/test_node_from_shell.py and test_quickstart.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

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
    "args",
    [
        ["ros", "pose"],
        ["ros", "ik", "--target", "0.4,0.1,0.4,1,0,0,0"],
        ["ros", "twist"],
        ["ros", "diagnostics"],
        ["ros", "fk", "--q", "0,1"],
        ["ros", "jacobian"],
        ["ros", "jog", "--keys-from-stdin"],
        ["ros", "param", "list", "kinematics_node"],
    ],
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
    for verb in ("pose", "twist", "fk", "jacobian", "ik", "diagnostics", "jog", "param"):
        assert f"\n    {verb} " in out or f"\n    {verb}\n" in out, verb
    assert "ROS_DOMAIN_ID" in out


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["list"], "the following arguments are required: NODE"),
        (["get", "kinematics_node"], "the following arguments are required: NAME"),
        (["set", "kinematics_node", "tip_link"], "the following arguments are required: VALUE"),
        (["unset", "kinematics_node"], "invalid choice: 'unset'"),
    ],
)
def test_param_usage_errors_name_what_is_missing(capsys, args, says):
    assert main(["ros", "param", *args]) == 2
    assert says in capsys.readouterr().err


@pytest.mark.parametrize(
    ("current", "text", "expected"),
    [
        ("double", "1", ("double_value", 1.0)),
        ("double", "0.25", ("double_value", 0.25)),
        ("double_array", "[1, 2]", ("double_array_value", [1.0, 2.0])),
        ("double", "inf", ("double_value", float("inf"))),
        ("double", "fast", ("string_value", "fast")),  # left to the node to refuse
        ("string", "42", ("string_value", "42")),
        ("string", "true", ("string_value", "true")),
        ("string", "tool0", ("string_value", "tool0")),
        ("integer", "3", ("integer_value", 3)),
        ("integer", "0.5", ("double_value", 0.5)),  # left to the node to refuse
        ("not_set", "1", ("integer_value", 1)),
    ],
)
def test_param_set_reads_yaml_in_the_parameters_own_type(current, text, expected):
    """`kinematics ros param set` reads VALUE as YAML (as ros2 param set), then fits it to the
    parameter's current type where it fits: a whole number to a double, any text to a string."""
    pytest.importorskip("rcl_interfaces", reason="rcl_interfaces comes with ROS 2 (make ros)")
    from rcl_interfaces.msg import ParameterType, ParameterValue
    from rclpy.parameter import get_parameter_value

    from kinematics_node.cli.ros_commands import _typed_as

    now = ParameterValue(type=getattr(ParameterType, f"PARAMETER_{current.upper()}"))
    value = _typed_as(get_parameter_value(text), now, text)
    field, wanted = expected
    kind = field.removesuffix("_value").upper()
    assert value.type == getattr(ParameterType, f"PARAMETER_{kind}")
    got = getattr(value, field)
    assert (list(got) if "array" in field else got) == wanted


@pytest.mark.parametrize("option", ["--speed", "--turn", "--rate"])
@pytest.mark.parametrize("value", ["0", "-0.1", "nan", "fast"])
def test_jog_speeds_and_rate_are_positive_numbers(capsys, option, value):
    assert main(["ros", "jog", option, value]) == 2
    assert f"argument {option}: expected a finite number > 0" in capsys.readouterr().err


@pytest.mark.parametrize("stdin", ["devnull", "pipe"])
def test_jog_without_a_terminal_says_it_needs_one_before_starting_ros(stdin):
    """`kinematics ros jog < /dev/null` (or from a pipe) used to print its banner and exit 0, as
    if the user had quit. It says that it needs a terminal, exits 1, prints no banner, and does
    not start ROS (rclpy is made unimportable: reaching it would say "needs ROS 2" instead)."""
    code = (
        "import sys; sys.modules['rclpy'] = None; from kinematics_node.cli.main import main; "
        "sys.exit(main(['ros', 'jog', '--wait', '1']))"
    )
    where: dict[str, Any] = {"stdin": subprocess.DEVNULL} if stdin == "devnull" else {"input": "w"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT, **where
    )
    assert out.returncode == 1
    assert out.stdout == ""  # no banner
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert out.stderr.startswith("kinematics: error: kinematics ros jog reads keys from a terminal")
    assert "standard input is not one" in out.stderr and "--keys-from-stdin" in out.stderr
    assert "needs ROS 2" not in out.stderr


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("0,-1.2,1.4", ((None, 0.0), (None, -1.2), (None, 1.4))),
        ("elbow_joint=0.5, wrist_1_joint = -1", (("elbow_joint", 0.5), ("wrist_1_joint", -1.0))),
    ],
)
def test_joint_values_are_named_or_in_chain_order(text, expected):
    from kinematics_node.cli.ros_services import joint_values

    assert joint_values(text) == expected


@pytest.mark.parametrize("verb", ["fk", "jacobian"])
@pytest.mark.parametrize(
    ("q", "says"),
    [
        ("0,elbow_joint=1", "give every value a joint name (NAME=VALUE,...) or none"),
        ("0,1,x", "expected numbers (VALUE,... in chain order, or NAME=VALUE,...), got 'x'"),
        ("=1", "a joint name is missing before '='"),
        ("elbow_joint=nan", "every value must be finite"),
        ("0,,1", "got ''"),
    ],
)
def test_bad_joint_values_are_a_usage_error_naming_the_option(capsys, verb, q, says):
    assert main(["ros", verb, "--q", q]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "argument --q" in err and says in err


def test_the_jacobian_frame_is_one_of_three(capsys):
    assert main(["ros", "jacobian", "--frame", "tool"]) == 2
    assert "invalid choice: 'tool'" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("status", "node", "matches"),
    [
        ("kinematics_node: end effector", "kinematics_node", True),  # before the full name
        ("/kinematics_node: end effector", "kinematics_node", True),
        ("/arm/kinematics_node: end effector", "kinematics_node", True),
        ("/arm/kinematics_node: end effector", "/arm/kinematics_node", True),
        ("/arm/kinematics_node: end effector", "/other/kinematics_node", False),
        ("/arm/my_kinematics_node: end effector", "kinematics_node", False),
        ("servo: status", "kinematics_node", False),
        ("/kinematics_node: end effector", "", False),
    ],
)
def test_a_status_is_matched_to_its_node_by_name_or_full_name(status, node, matches):
    from kinematics_node.cli.ros_topics import status_of_node

    assert status_of_node(status, node) is matches
