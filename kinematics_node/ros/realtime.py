"""Real-time scheduling of a node's thread at start-up: the `thread_priority` parameter of the servo
node and of the simulated arm (no rclpy import; Linux's scheduler through `os`).

Why: at 1 kHz a period is 1 ms, and on a shared machine a callback thread under the default
scheduler (SCHED_OTHER) waits behind whatever else is runnable on its core, for several
periods at times. The field's answer is SCHED_FIFO for the control loop's thread:
moveit_servo's `thread_priority` (default 40) and ros2_control's controller_manager
`thread_priority` (default 50, above the servo's) configure it with realtime_tools'
`configure_sched_fifo`, and when the system does not permit it they log a warning and run on.
Ours does the same, with 0 meaning "leave the scheduling alone" (our default: see
`service/servo_parameters.py`).

What is raised: the calling thread (the one that builds the node and then spins it: every
callback of the node) to `priority`, and the process's other threads, which the middleware
started (DDS's receive, event and discovery threads), to one below it. moveit_servo and
controller_manager raise their loop's thread only; here that left the middleware's threads to
wait behind everything else on the machine while the raised thread waited for them (a command
received, a publication's locks). Measured with benchmarks/servo_node_benchmark.py, the servo at
40 and the sim_arm at 50, 20 s streaming at 1 kHz, two runs of each alternately on the 2-core
machine at load average 3.5-3.9: the loop's thread alone, 99.27 % and 99.57 % of the cycles
on time (47 and 48 late by the node's own count); every thread, 99.74 % and 99.78 % (20, 21).
Threads started later inherit the policy of the thread that starts them.

Linux throttles real-time threads to 95 % of each second (kernel.sched_rt_runtime_us), so a
callback that ever spun would not lock the machine.
"""

from __future__ import annotations

import os
import threading
from typing import Any

#: SCHED_FIFO's priority range on Linux.
MIN_PRIORITY, MAX_PRIORITY = 1, 99


def apply_thread_priority(priority: int) -> tuple[str, str] | None:
    """Make the calling thread SCHED_FIFO at `priority` (1-99); 0 leaves it alone (returns None).

    Never raises for a refusal by the system: returns (level, message) for the node's log,
    "info" when it took effect, "warn" (saying why and how to permit it) when not.

    Raises:
        ValueError: `priority` is not an integer in 0..99 (a parameter error, refused at start-up).
    """
    if isinstance(priority, bool) or not isinstance(priority, int):
        raise ValueError(f"thread_priority must be an integer 0-99, got {priority!r}")
    if priority == 0:
        return None
    if not MIN_PRIORITY <= priority <= MAX_PRIORITY:
        raise ValueError(
            f"thread_priority must be 0 (leave the scheduling alone) or a SCHED_FIFO priority "
            f"{MIN_PRIORITY}-{MAX_PRIORITY}, got {priority}"
        )
    setter = getattr(os, "sched_setscheduler", None)
    if setter is None:  # not Linux
        return (
            "warn",
            f"thread_priority {priority}: this system has no sched_setscheduler; running with "
            "the default scheduling",
        )
    try:
        setter(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError as exc:
        return (
            "warn",
            f"thread_priority {priority}: SCHED_FIFO is not permitted here ({exc.strerror}); "
            "running with the default scheduling. To permit it: run with CAP_SYS_NICE, or give "
            "the user an rtprio limit of at least the priority (limits.conf '<user> - rtprio "
            f"{priority}', as ros2_control's real-time guide does)",
        )
    except OSError as exc:
        return (
            "warn",
            f"thread_priority {priority}: SCHED_FIFO could not be set ({exc.strerror or exc}); "
            "running with the default scheduling",
        )
    others = _raise_other_threads(setter, max(MIN_PRIORITY, priority - 1))
    return (
        "info",
        f"thread_priority {priority}: the node's thread runs SCHED_FIFO at priority {priority}, "
        f"{others}",
    )


def _raise_other_threads(setter: Any, priority: int) -> str:
    """SCHED_FIFO at `priority` for the process's other threads (the middleware's); says how
    many (a thread that ended meanwhile, or one the system refuses, is left as it is)."""
    own = threading.get_native_id()
    try:
        tids = [int(t) for t in os.listdir("/proc/self/task")]
    except OSError:
        return "the middleware's threads left as they were (no /proc/self/task)"
    raised = 0
    others = [t for t in tids if t != own]
    for tid in others:
        try:
            setter(tid, os.SCHED_FIFO, os.sched_param(priority))
            raised += 1
        except OSError:
            continue
    return f"the process's {raised} of {len(others)} other threads (the middleware's) at {priority}"
