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
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from .executor import make_executor

BAD_PARAMETER = 2


def spin_until_shutdown(
    make_node: Callable[[], Node],
    name: str,
    refused: tuple[type[Exception], ...],
    args: list[str] | None = None,
) -> int:
    """Run `make_node()` until shutdown; `refused` are the exceptions by which the node's
    constructor rejects its parameters. Returns the exit status (module docstring)."""
    with _noting_stop_signals() as stop_signals:
        return _spin(make_node, name, refused, args, stop_signals)


def _spin(
    make_node: Callable[[], Node],
    name: str,
    refused: tuple[type[Exception], ...],
    args: list[str] | None,
    stop_signals: list[int],
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
        if context.ok() and not stop_signals:
            raise
        # stopped by a signal while an rclpy call was in flight (module docstring)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


@contextmanager
def _noting_stop_signals() -> Iterator[list[int]]:
    """Python handlers for SIGINT and SIGTERM that record the signal (SIGINT still raises
    `KeyboardInterrupt`, as Python's default does); the previous handlers come back on exit."""
    noted: list[int] = []

    def note(signum: int, frame: FrameType | None) -> None:
        noted.append(signum)
        if signum == signal.SIGINT:
            raise KeyboardInterrupt

    previous = {s: signal.signal(s, note) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield noted
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
