"""kinematics_node.ros.node_setup: the descriptors the kinematics node and the servo declare their
parameters with, from the same tables their validation uses (`service.parameters.validate`)."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("rcl_interfaces.msg", reason="rcl_interfaces is not installed: needs ROS 2")

from kinematics_node.core.exceptions import InvalidInputError  # noqa: E402
from kinematics_node.ros.node_setup import answer_parameter_change, descriptor  # noqa: E402
from kinematics_node.service.parameters import PARAMETERS, SPECS, validate  # noqa: E402
from kinematics_node.service.servo_parameters import (  # noqa: E402
    SERVO_PARAMETERS,
    SERVO_SPECS,
)

TABLES = [(spec, SPECS) for spec in PARAMETERS] + [(spec, SERVO_SPECS) for spec in SERVO_PARAMETERS]


@pytest.mark.parametrize(("spec", "table"), TABLES, ids=[s.name for s, _ in TABLES])
def test_a_descriptor_says_what_validation_takes(spec, table):
    d = descriptor(spec)
    assert d.description.startswith(spec.description)
    for choice in spec.choices:
        assert choice in d.description
    bounded = spec.minimum is not None and spec.maximum is not None
    number = isinstance(spec.default, (int, float)) and not isinstance(spec.default, bool)
    ranges = list(d.floating_point_range) + list(d.integer_range)
    if not (bounded and number):
        assert ranges == []
        return
    (r,) = ranges
    assert (r.from_value, r.to_value) == (spec.minimum, spec.maximum)
    assert bool(d.integer_range) == isinstance(spec.default, int)  # (bool: no range, above)
    # the range's ends are where validation's are: inside accepted, outside refused
    kind = type(spec.default)
    step = 1 if kind is int else 0.0
    above = kind(spec.maximum) + step if kind is int else math.nextafter(spec.maximum, math.inf)
    below = kind(spec.minimum) - step if kind is int else math.nextafter(spec.minimum, -math.inf)
    assert validate({spec.name: kind(spec.maximum)}, table) is None
    assert spec.name in validate({spec.name: above}, table)
    assert spec.name in validate({spec.name: below}, table)
    if not (spec.positive and spec.minimum <= 0):
        assert validate({spec.name: kind(spec.minimum)}, table) is None


def test_servo_descriptors_carry_ranges_too():
    """The servo's numbers with both bounds (e.g. status_period, thread_priority) are described
    with their range, as the kinematics node's are (one descriptor for both nodes)."""
    bounded = [s for s in SERVO_PARAMETERS if s.minimum is not None and s.maximum is not None]
    assert bounded
    for spec in bounded:
        d = descriptor(spec)
        assert len(d.floating_point_range) + len(d.integer_range) == 1


def test_a_parameter_change_is_answered_by_what_configure_says():
    logged: list[str] = []

    def log() -> None:
        logged.append("log")

    def refuse() -> None:
        raise InvalidInputError("parameter 'tip_link': no link 'x'")

    def crash() -> None:
        raise ZeroDivisionError("boom")

    ok = answer_parameter_change(lambda: None, log)
    refused = answer_parameter_change(refuse, log)
    crashed = answer_parameter_change(crash, log)
    assert ok.successful and not refused.successful and not crashed.successful
    assert refused.reason == "parameter 'tip_link': no link 'x'"
    assert crashed.reason == "internal error: ZeroDivisionError('boom')"
    assert logged == ["log"] * 3  # the service's lines, whatever the answer
