"""The process entry shared by our rclpy executables (`kinematics_node`, `sim_arm`): build the
node, spin it in one thread (`executor.make_executor`: our LeanExecutor, or rclpy's
SingleThreadedExecutor with the node's `executor` parameter "rclpy" or where this rclpy lacks what
the lean one uses), and stop with a status a supervisor can trust.

Exit status: 0 after SIGINT, SIGTERM or an external shutdown; 2 when the node refuses a start-up
parameter (one line on stderr naming it, no traceback).

Why a stop is recognised by the context and not only by `KeyboardInterrupt`: rclpy's signal
handler shuts the context down from its own thread the moment the signal arrives, before Python
raises `KeyboardInterrupt` in the main thread. Whatever rclpy call the main thread is making at
that moment (creating a guard condition while the node is still being built, publishing from a
timer) then fails with an `RCLError` about an invalid context. That is the signal taking effect,
not a fault, so it ends with status 0. The context is not always down yet when that error
surfaces (the shutdown runs on rclpy's thread), and pybind11 can turn the `KeyboardInterrupt`
itself into a `RuntimeError` when it lands inside an argument conversion. So the stop signals are
also noted by a Python handler of ours, which rclpy's handler calls after its own; any error after
a noted signal is part of stopping. An error with no signal and the context valid is re-raised.

A stop that hangs (`stop_deadline_s`, the executables' `STOP_DEADLINE_S`): the first noted stop
signal arms a watchdog that does not need the main thread nor Python's lock (noting it does: the
main thread returns to Python at every timer tick, out of rclpy's wait). At the deadline,
faulthandler writes the Python stack of every thread to stderr (the node's log), under a line
"Timeout (0:00:05)!"; half a second later SIGALRM, left at its default action, ends the process:
its status is -14 (killed by SIGALRM; 142 in a shell), never 0, so that a supervisor can keep
trusting 0 as a clean stop, and it comes before the supervisor's own SIGKILL (launch's SIGTERM
follows its SIGINT after 5 s, `processes.stop_nodes` kills after 10 s), which leaves nothing to
read. The alarm stays armed until the process is gone, so a hang after Python has finished (a
library's destructor at exit) is ended too, without stacks (faulthandler stops with Python).
Why: once in CI, the servo did not exit within 10 s of SIGINT and was killed, its log ending at
"servo ready"; that could not say where it hung.
"""

from __future__ import annotations

import faulthandler
import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import FrameType

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from .executor import make_executor

BAD_PARAMETER = 2
#: [s] from the first SIGINT or SIGTERM to the dump of every thread's stack, for the executables
#: (module docstring); a clean stop takes 0.2-1.7 s on a loaded 2-core machine
STOP_DEADLINE_S = 5.0
#: [s] from the dump to SIGALRM
_DUMP_TO_ALARM_S = 0.5


def spin_until_shutdown(
    make_node: Callable[[], Node],
    name: str,
    refused: tuple[type[Exception], ...],
    args: list[str] | None = None,
    stop_deadline_s: float | None = None,
) -> int:
    """Run `make_node()` until shutdown; `refused` are the exceptions by which the node's
    constructor rejects its parameters. Returns the exit status (module docstring).

    `stop_deadline_s`: a process's stop that takes longer after its first SIGINT or SIGTERM
    dumps its threads' stacks and ends with SIGALRM (module docstring); the watchdog stays armed
    after this returns (the process is ending). None: no watchdog (a caller that goes on)."""
    on_stop = None if stop_deadline_s is None else (lambda: arm_stop_watchdog(stop_deadline_s))
    with _noting_stop_signals(on_stop) as stop:
        return _spin(make_node, name, refused, args, stop)


def _spin(
    make_node: Callable[[], Node],
    name: str,
    refused: tuple[type[Exception], ...],
    args: list[str] | None,
    stop: _StopSignals,
) -> int:
    context = rclpy.get_default_context()
    node = None
    try:
        # rclpy's signal handlers call ours (installed first) after theirs
        rclpy.init(args=args, context=context)
        node = make_node()
        kind = node.get_parameter("executor").value if node.has_parameter("executor") else "lean"
        executor = make_executor(kind, log=node.get_logger().warning)
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except refused as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return BAD_PARAMETER
    except Exception:
        if context.ok() and not stop.signals:
            raise
        # stopped by a signal while an rclpy call was in flight (module docstring)
    finally:
        stop.cleaning_up = True  # a signal from now on does not interrupt the cleanup
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def arm_stop_watchdog(deadline_s: float) -> None:
    """In `deadline_s` [s], every thread's Python stack to stderr; SIGALRM (its default action:
    the process ends) half a second later (module docstring). Neither needs the main thread or
    Python's lock: faulthandler's own thread dumps, the kernel delivers the alarm."""
    faulthandler.dump_traceback_later(deadline_s, exit=False, file=sys.stderr)
    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    signal.setitimer(signal.ITIMER_REAL, deadline_s + _DUMP_TO_ALARM_S)


@dataclass
class _StopSignals:
    signals: list[int] = field(default_factory=list)  # the stop signals received, in order
    cleaning_up: bool = False  # the node is being destroyed: a signal only counts


@contextmanager
def _noting_stop_signals(on_stop: Callable[[], object] | None = None) -> Iterator[_StopSignals]:
    """Python handlers for SIGINT and SIGTERM that record the signal and call `on_stop` at the
    first one. SIGINT still raises `KeyboardInterrupt`, as Python's default does, except during
    the cleanup: a second SIGINT (Ctrl-C pressed twice) does not cut the node's destruction
    short, which would end the process with a traceback. The previous handlers come back on
    exit; with `on_stop` (a process that ends: the watchdog bounds it) after a stop signal, both
    are ignored instead, since Python's own SIGINT handler gives way to the default action while
    the interpreter finishes, and a second Ctrl-C then killed the process (-2) after a clean stop."""
    stop = _StopSignals()

    def note(signum: int, frame: FrameType | None) -> None:
        stop.signals.append(signum)
        if on_stop is not None and len(stop.signals) == 1:
            on_stop()
        if signum == signal.SIGINT and not stop.cleaning_up:
            raise KeyboardInterrupt

    previous = {s: signal.signal(s, note) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        ending = on_stop is not None and bool(stop.signals)
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_IGN if ending else handler)
