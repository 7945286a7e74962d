"""`thread_priority` (ros/realtime.py): SCHED_FIFO for the calling thread at start-up, never a
failure when the system refuses it. Applied in threads of their own, so that the test process
keeps its scheduling."""

from __future__ import annotations

import os
import threading
from typing import Any

import pytest

from kinematics_node.ros import realtime
from kinematics_node.ros.realtime import apply_thread_priority

linux = pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="Linux scheduling")


def _in_a_thread(priority: int) -> tuple[Any, int, int]:
    """apply_thread_priority in a new thread: (its answer, that thread's policy and priority
    afterwards)."""
    out: list[Any] = []

    def run() -> None:
        said = apply_thread_priority(priority)
        out.append((said, os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    return out[0]


@linux
def test_zero_leaves_the_scheduling_alone():
    said, policy, _ = _in_a_thread(0)
    assert said is None and policy == os.sched_getscheduler(0)


@linux
def test_a_priority_makes_the_thread_sched_fifo_or_says_why_not():
    said, policy, priority = _in_a_thread(7)
    level, text = said
    if level == "info":  # permitted here (root, CAP_SYS_NICE, or an rtprio limit)
        assert policy == os.SCHED_FIFO and priority == 7
    else:
        assert policy != os.SCHED_FIFO and "default scheduling" in text
    assert os.sched_getscheduler(0) != os.SCHED_FIFO  # only the calling thread


@linux
def test_a_refusal_is_a_warning_that_says_how_to_permit_it(monkeypatch):
    def refuse(*args: Any) -> None:
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(realtime.os, "sched_setscheduler", refuse)
    level, text = apply_thread_priority(40)
    assert level == "warn" and "not permitted" in text and "rtprio" in text
    assert "CAP_SYS_NICE" in text


@pytest.mark.parametrize("bad", [-1, 100, 2.5, True, "40"])
def test_a_priority_out_of_range_is_a_parameter_error(bad):
    with pytest.raises(ValueError, match="thread_priority"):
        apply_thread_priority(bad)
