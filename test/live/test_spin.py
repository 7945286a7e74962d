"""`spin.spin_until_shutdown`, the entry of both executables, in this process with real rclpy:
the exit status a supervisor sees (the demo and launch files check it).

rclpy's signal handler shuts the default context down from another thread as soon as SIGINT
arrives. Here each test does that shutdown itself at a chosen moment, so the race the CI once lost
(SIGINT while the node was still being built: `RCLError`, status 1) is replayed every run.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time

import live_node  # noqa: F401  (skips this module where the built node cannot run)
import pytest
import rclpy
from rclpy.node import Node
from std_msgs.msg import String

from kinematics_node.ros.spin import BAD_PARAMETER, spin_until_shutdown


def test_a_signal_while_the_node_is_being_built_is_a_normal_stop():
    def make() -> Node:
        node = Node("ros_main_start")
        rclpy.shutdown()  # what the signal handler does while the constructor runs
        node.create_guard_condition(lambda: None)  # raises: the context is no longer valid
        return node

    assert spin_until_shutdown(make, "test_node", ()) == 0


def test_a_signal_while_a_timer_publishes_is_a_normal_stop():
    def make() -> Node:
        node = Node("ros_main_timer")
        pub = node.create_publisher(String, "ros_main_chatter", 1)

        def tick() -> None:
            rclpy.shutdown()
            pub.publish(String(data="after the signal"))  # raises: context invalid

        node.create_timer(0.01, tick)
        return node

    assert spin_until_shutdown(make, "test_node", ()) == 0


def test_a_signal_that_pybind11_turned_into_another_error_is_a_normal_stop():
    def make() -> Node:
        node = Node("ros_main_swallowed")

        def tick() -> None:
            try:  # as pybind11 does when the interrupt lands inside an argument conversion
                signal.raise_signal(signal.SIGINT)
            except KeyboardInterrupt:
                raise RuntimeError("Unable to convert call argument '0' to Python object") from None

        node.create_timer(0.01, tick)
        return node

    assert spin_until_shutdown(make, "test_node", ()) == 0


def test_the_previous_signal_handlers_come_back():
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)

    def make() -> Node:
        rclpy.shutdown()
        raise RuntimeError("stopped")

    assert spin_until_shutdown(make, "test_node", ()) == 0
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before


def test_an_error_with_the_context_still_valid_is_not_hidden():
    def make() -> Node:
        raise RuntimeError("a real fault")

    with pytest.raises(RuntimeError, match="a real fault"):
        spin_until_shutdown(make, "test_node", ())
    assert not rclpy.ok()  # and rclpy is shut down on the way out


def test_a_refused_start_up_parameter_is_one_line_and_status_2(capsys):
    def make() -> Node:
        raise ValueError("parameter rate must be > 0 Hz, got -1")

    assert spin_until_shutdown(make, "sim_arm", (ValueError,)) == BAD_PARAMETER
    err = capsys.readouterr().err
    assert err == "sim_arm: parameter rate must be > 0 Hz, got -1\n"


def test_sigint_to_this_process_ends_the_spin_with_status_0():
    def make() -> Node:
        node = Node("ros_main_sigint")
        start = time.monotonic()

        def tick() -> None:
            if time.monotonic() - start > 0.2:
                signal.raise_signal(signal.SIGINT)

        node.create_timer(0.05, tick)
        return node

    assert spin_until_shutdown(make, "test_node", ()) == 0


def test_a_second_sigint_does_not_cut_the_cleanup_short():
    destroyed = []

    class Twice(Node):
        def __init__(self) -> None:
            super().__init__("ros_main_twice")
            self.create_timer(0.05, lambda: signal.raise_signal(signal.SIGINT))

        def destroy_node(self) -> None:
            signal.raise_signal(signal.SIGINT)  # Ctrl-C pressed again while the node goes
            super().destroy_node()
            destroyed.append(True)

    assert spin_until_shutdown(Twice, "test_node", ()) == 0  # before: KeyboardInterrupt
    assert destroyed


#: A node process whose destruction hangs holding Python's lock (a C call through ctypes.PyDLL
#: keeps it), as a deadlock inside an rclpy or DDS call would: run by the next test.
HANGING_STOP = """
import ctypes, sys
from rclpy.node import Node
from kinematics_node.ros.spin import spin_until_shutdown

class Hangs(Node):
    def __init__(self):
        super().__init__("hangs_on_stop")
        self.create_timer(0.05, lambda: print("spinning", flush=True))

    def destroy_node(self):
        ctypes.PyDLL(None).sleep(60)

sys.exit(spin_until_shutdown(Hangs, "hangs_on_stop", (), None, float(sys.argv[1])))
"""


def test_a_stop_that_hangs_dumps_every_stack_and_ends_with_sigalrm(tmp_path):
    from live_node import DOMAIN_ID

    from kinematics_node.ros.env import local_ros_env

    deadline = 1.0
    log = tmp_path / "hangs.log"
    with log.open("wb") as out:
        proc = subprocess.Popen(
            [sys.executable, "-c", HANGING_STOP, str(deadline)],
            stdout=subprocess.PIPE,
            stderr=out,
            env=local_ros_env(DOMAIN_ID),
        )
    try:
        assert proc.stdout is not None and proc.stdout.readline() == b"spinning\n", log.read_text()
        proc.send_signal(signal.SIGINT)
        sent = time.monotonic()
        code = proc.wait(deadline + 9.0)  # before the change: still asleep in destroy_node
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    text = log.read_text(errors="replace")
    # not 0, which says a clean stop; within the deadline and the half second to the alarm
    assert code == -signal.SIGALRM, (code, text)
    assert deadline <= took < deadline + 3.0, (took, text)
    # where it hung, from faulthandler's thread (the main thread held Python's lock)
    assert "Timeout (0:00:01)!" in text, text
    assert re.search(r"line \d+ in destroy_node\n.*line \d+ in _spin", text, re.S), text
