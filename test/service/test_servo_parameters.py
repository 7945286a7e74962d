"""The servo node's parameter table: it follows the core's ServoConfig (names, defaults), the
kinematics node's description parameters, config/servo.yaml; bad values are refused saying why."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import pytest

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.core.servo import ServoConfig
from kinematics_node.service.parameters import SPECS as KINEMATICS_SPECS
from kinematics_node.service.servo_parameters import (
    CONFIG_NAMES,
    CONTROLLER_TOPICS,
    DESCRIPTION_PARAMETERS,
    SERVO_PARAMETERS,
    SERVO_SPECS,
    parse_joint_values,
    servo_config,
    servo_defaults,
    validate_servo_parameters,
)

ROOT = Path(__file__).resolve().parents[2]


def test_every_servo_config_field_is_a_parameter_with_the_cores_default():
    default = ServoConfig()
    for f in fields(ServoConfig):
        assert f.name in SERVO_SPECS, f.name
    assert CONFIG_NAMES == {f.name for f in fields(ServoConfig)}
    # the defaults give the core's defaults back
    assert servo_config(servo_defaults()) == default


def test_the_description_parameters_are_the_kinematics_nodes():
    for name in DESCRIPTION_PARAMETERS:
        assert SERVO_SPECS[name] == KINEMATICS_SPECS[name]


def test_names_are_unique_and_every_default_is_valid():
    names = [spec.name for spec in SERVO_PARAMETERS]
    assert len(names) == len(set(names))
    assert validate_servo_parameters(servo_defaults()) is None


def test_controller_topics_are_ros2_controls():
    assert CONTROLLER_TOPICS == {
        "position": "/forward_position_controller/commands",
        "velocity": "/forward_velocity_controller/commands",
        "trajectory": "/joint_trajectory_controller/joint_trajectory",
    }
    assert SERVO_SPECS["command_out_type"].choices == tuple(CONTROLLER_TOPICS)


def test_the_parameter_file_lists_every_parameter_at_its_default():
    yaml = pytest.importorskip("yaml")
    doc = yaml.safe_load((ROOT / "config" / "servo.yaml").read_text(encoding="utf-8"))
    (key,) = doc
    assert key.split("/")[-1] == "servo"
    given = doc[key]["ros__parameters"]
    assert set(given) == set(SERVO_SPECS)
    assert validate_servo_parameters(given) is None
    for name, value in given.items():  # ROS refuses an int for a double parameter
        assert type(value) is type(SERVO_SPECS[name].default), name
        assert value == SERVO_SPECS[name].default, name


def test_strings_become_the_configs_maps_and_axes():
    config = servo_config(
        {
            "velocity_limits": "a:=1.5 b:=2",
            "jerk_limits": "a:=100.0,b:=50",
            "task_axes": "wz vx, vy",
            "command_timeout_s": 1,  # an int for a float
        }
    )
    assert dict(config.velocity_limits) == {"a": 1.5, "b": 2.0}
    assert dict(config.jerk_limits) == {"a": 100.0, "b": 50.0}
    assert config.task_axes == ("wz", "vx", "vy") and config.command_timeout_s == 1.0
    assert servo_config({"task_axes": ""}).task_axes is None


@pytest.mark.parametrize(
    "text", ["a", "a:=", "a:=x", "a:=0", "a:=-1", "a:=inf", "a:=nan", ":=1", "a:=1 a:=2"]
)
def test_bad_joint_values_are_refused_naming_the_parameter(text):
    with pytest.raises(InvalidInputError, match="'jerk_limits'"):
        parse_joint_values(text, "jerk_limits")


@pytest.mark.parametrize(
    ("values", "words"),
    [
        ({"period_s": 0.0001}, ["parameter 'period_s'", "0.0005", "0.0001"]),
        ({"period_s": "fast"}, ["'period_s'", "float", "fast"]),
        ({"command_timeout_s": 0.0}, ["'command_timeout_s'"]),
        ({"velocity_scale": 1.5}, ["'velocity_scale'"]),
        ({"halt_messages": 1.5}, ["'halt_messages'", "int"]),
        ({"halt_messages": -1}, ["'halt_messages'", ">= 0"]),
        ({"status_period": 0.0}, ["'status_period'", "> 0"]),
        ({"command_out_type": "effort"}, ["'command_out_type'", "position"]),
        ({"task_axes": "wx wx"}, ["'task_axes'", "distinct"]),
        ({"task_axes_frame": "world"}, ["'task_axes_frame'"]),
        ({"max_following_error": True}, ["'max_following_error'"]),  # bool is not a number
        ({"velocity_limits": "a:=1 b"}, ["'velocity_limits'", "'b'"]),
    ],
)
def test_validation_names_the_parameter_and_the_range(values, words):
    problem = validate_servo_parameters(values)
    assert problem is not None
    for word in words:
        assert word in problem, problem
