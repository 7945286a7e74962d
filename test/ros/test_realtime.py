"""`thread_priority` (ros/realtime.py): SCHED_FIFO for the node's thread (and one below it for the
process's other threads) at start-up, never a failure when the system refuses it. Applied in a
process of its own, so that the test process keeps its scheduling."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from kinematics_node.ros import realtime
from kinematics_node.ros.realtime import apply_thread_priority

ROOT = Path(__file__).resolve().parents[2]
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


#: In a process of its own (the call raises every thread of its process): a thread that exists
#: before the call (as the middleware's do), then the call, then each thread's policy/priority.
_CHILD = """
import json, os, threading
from kinematics_node.ros.realtime import apply_thread_priority
seen, go = {}, threading.Event()
def other():
    go.wait()
    seen["other"] = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
thread = threading.Thread(target=other)
thread.start()
said = apply_thread_priority(7)
go.set()
thread.join()
seen["own"] = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
print(json.dumps({"said": said, **seen}))
"""


@linux
def test_a_priority_makes_the_threads_sched_fifo_or_says_why_not():
    out = subprocess.run(
        [sys.executable, "-c", _CHILD], capture_output=True, text=True, check=True, cwd=ROOT
    )
    got = json.loads(out.stdout)
    level, text = got["said"]
    if level == "info":  # permitted here (root, CAP_SYS_NICE, or an rtprio limit)
        assert got["own"] == [os.SCHED_FIFO, 7]
        assert got["other"] == [os.SCHED_FIFO, 6]  # the middleware's: one below
        assert "1 of 1 other threads" in text
    else:
        assert got["own"][0] != os.SCHED_FIFO and "default scheduling" in text


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
