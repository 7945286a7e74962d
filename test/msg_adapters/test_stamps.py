"""msg_adapters.stamps against real ROS 2 message classes (rosbags): time round trips, refusals."""

from __future__ import annotations

import math

import pytest

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError


# --------------------------------------------------------------------------- Time
@pytest.mark.parametrize("seconds", [0.0, 1.5, 1_700_000_000.123456789, -2.25, 0.9999999999])
def test_time_round_trip(ros, seconds):
    t = ma.time_from_seconds(ros.types, seconds)
    assert 0 <= t.nanosec < 1_000_000_000
    assert ros.rclpy_type_problems(t) == []
    assert ma.seconds_from_time(ros.roundtrip(t)) == pytest.approx(seconds, abs=1e-9)


def test_time_refuses_nan(ros):
    with pytest.raises(InvalidInputError, match="finite"):
        ma.time_from_seconds(ros.types, math.nan)


def test_copy_time_keeps_every_nanosecond(ros):
    stamp = ros.new("builtin_interfaces/msg/Time", sec=1_700_000_000, nanosec=123_456_789)
    copy = ma.copy_time(ros.types, stamp)
    assert (copy.sec, copy.nanosec) == (1_700_000_000, 123_456_789)
    assert copy is not stamp
