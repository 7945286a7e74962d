"""`spin.spin_until_shutdown`, the entry of both executables, in this process with real rclpy:
the exit status a supervisor sees (the demo and launch files check it).

rclpy's signal handler shuts the default context down from another thread as soon as SIGINT
arrives. Here each test does that shutdown itself at a chosen moment, so the race the CI once lost
(SIGINT while the node was still being built: `RCLError`, status 1) is replayed every run.
"""

from __future__ import annotations

import signal
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
