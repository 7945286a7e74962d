"""builtin_interfaces/Time ↔ float seconds.

Float seconds are for arithmetic (rates, velocity estimates); to stamp an output with an input's
time, copy the message with `copy_time` so no nanoseconds are lost to rounding (a float64 holds
~0.2 µs at today's epoch times).
"""

from __future__ import annotations

import math
from typing import Any

from kinematics_node.core.exceptions import InvalidInputError

from .types import MessageTypes

_NS_PER_S = 1_000_000_000


def seconds_from_time(stamp: Any) -> float:
    """t = sec + nanosec · 1e-9 [s] of a builtin_interfaces/Time (or anything with those fields)."""
    return int(stamp.sec) + int(stamp.nanosec) * 1e-9


def time_from_seconds(types: MessageTypes, seconds: float) -> Any:
    """builtin_interfaces/Time for `seconds` [s], rounded to the nearest nanosecond.

    Raises:
        InvalidInputError: `seconds` is NaN or infinite.
    """
    if not math.isfinite(seconds):
        raise InvalidInputError(f"time must be finite, got {seconds}")
    total_ns = round(seconds * _NS_PER_S)
    sec, nanosec = divmod(total_ns, _NS_PER_S)  # nanosec in [0, 1e9) also for negative times
    return types.Time(sec=int(sec), nanosec=int(nanosec))


def copy_time(types: MessageTypes, stamp: Any) -> Any:
    """A new Time message with the same sec and nanosec as `stamp`."""
    return types.Time(sec=int(stamp.sec), nanosec=int(stamp.nanosec))


def header(types: MessageTypes, stamp: Any, frame_id: str) -> Any:
    """std_msgs/Header with a copy of `stamp` (a Time message) and `frame_id`."""
    return types.Header(stamp=copy_time(types, stamp), frame_id=str(frame_id))
