"""LeanExecutor (kinematics_node/ros/executor.py) against real rclpy, in this process: every kind of
entity it runs, the parts of rclpy's semantics it keeps (callback groups, coroutine callbacks,
exceptions, entities created or destroyed while spinning, shutdown), and the one wait per
callback that is its reason to exist."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import live_node  # noqa: F401 - skips this module where rclpy is missing; keeps DDS on loopback
import pytest
import rclpy
from kinematics_service.srv import ComputeFK  # any service type with success and message
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from std_msgs.msg import Int32, String

import kinematics_node.ros.executor as executor_module
from kinematics_node.ros.executor import LeanExecutor, lean_executor_supported, make_executor


class WaitCounter:
    """Stands in for rclpy's `_rclpy` module in an executor module: its wait sets count their
    waits (everything else goes to the real ones)."""

    def __init__(self, real: Any) -> None:
        self._real, self.waits = real, 0
        counter = self

        class WaitSet:
            def __init__(self, *args: Any) -> None:
                self._ws = real.WaitSet(*args)

            def wait(self, timeout: int) -> Any:
                counter.waits += 1
                return self._ws.wait(timeout)

            def __getattr__(self, name: str) -> Any:
                return getattr(self._ws, name)

        self.WaitSet = WaitSet

    def __getattr__(self, name: str) -> Any:
        return getattr(self._real, name)


@pytest.fixture
def context() -> Iterator[Any]:
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.try_shutdown(context=ctx)


@pytest.fixture
def node(context: Any) -> Iterator[Node]:
    n = Node("lean_executor_test", context=context)
    yield n
    n.destroy_node()


@pytest.fixture
def executor(context: Any, node: Node) -> Iterator[LeanExecutor]:
    ex = LeanExecutor(context=context)
    ex.add_node(node)
    yield ex
    ex.shutdown()


def spin_until(ex: LeanExecutor, done: Callable[[], bool], seconds: float = 10.0) -> None:
    end = time.monotonic() + seconds
    while not done():
        assert time.monotonic() < end, "timed out"
        ex.spin_once(timeout_sec=0.05)


def test_this_rclpy_has_what_the_lean_executor_uses(context: Any) -> None:
    assert lean_executor_supported() is None
    assert isinstance(make_executor(context=context), LeanExecutor)


def test_without_those_internals_the_process_falls_back_to_rclpy_and_says_so(
    monkeypatch: pytest.MonkeyPatch, context: Any
) -> None:
    monkeypatch.setattr(executor_module, "lean_executor_supported", lambda: "_rclpy.WaitSet")
    said: list[str] = []
    ex = make_executor(log=said.append, context=context)
    assert type(ex) is SingleThreadedExecutor
    assert len(said) == 1 and "_rclpy.WaitSet" in said[0]
    assert type(make_executor("rclpy", said.append, context)) is SingleThreadedExecutor
    assert len(said) == 1  # asked for: nothing to say


def test_every_message_arrives_in_order_with_one_wait_each(
    node: Node, executor: LeanExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    counter = WaitCounter(executor_module._rclpy)
    monkeypatch.setattr(executor_module, "_rclpy", counter)  # before the first wait set
    got: list[int] = []
    node.create_subscription(Int32, "numbers", lambda m: got.append(m.data), 100)
    pub = node.create_publisher(Int32, "numbers", 100)
    spin_until(executor, lambda: pub.get_subscription_count() > 0)
    executor.spin_once(timeout_sec=0.01)
    assert counter.waits > 0  # (the counting wait set is in use)
    counter.waits = 0

    def publish() -> None:  # one message every 5 ms, each arriving while the spinner waits
        for i in range(50):
            time.sleep(0.005)
            pub.publish(Int32(data=i))

    publisher = threading.Thread(target=publish)
    publisher.start()
    end = time.monotonic() + 10.0
    while len(got) < 50 and time.monotonic() < end:
        executor.spin_once(timeout_sec=1.0)
    publisher.join()
    assert got == list(range(50))
    # rclpy's SingleThreadedExecutor waits twice per message (after every callback it triggers
    # its own guard condition, so the next wait returns at once); this one waits once
    assert counter.waits <= 50 + 2


def test_a_backlog_is_taken_several_messages_per_wait_in_order(
    node: Node, executor: LeanExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A subscription that fell behind: each wait runs up to 1 + MORE_TAKES of its messages, in
    order, interleaved round by round with the other subscriptions that had one."""
    counter = WaitCounter(executor_module._rclpy)
    monkeypatch.setattr(executor_module, "_rclpy", counter)
    got: list[tuple[str, int]] = []
    node.create_subscription(Int32, "backlog_a", lambda m: got.append(("a", m.data)), 100)
    node.create_subscription(Int32, "backlog_b", lambda m: got.append(("b", m.data)), 100)
    pub_a = node.create_publisher(Int32, "backlog_a", 100)
    pub_b = node.create_publisher(Int32, "backlog_b", 100)
    spin_until(
        executor, lambda: pub_a.get_subscription_count() > 0 and pub_b.get_subscription_count() > 0
    )
    executor.spin_once(timeout_sec=0.01)
    n = 2 * (1 + executor_module.MORE_TAKES) + 3
    for i in range(n):
        pub_a.publish(Int32(data=i))
    for i in range(2):
        pub_b.publish(Int32(data=i))
    time.sleep(0.3)  # all delivered to the subscriptions' queues
    counter.waits = 0
    executor.spin_once(timeout_sec=1.0)
    per_turn = 1 + executor_module.MORE_TAKES
    assert counter.waits == 1
    assert got[:4] == [("a", 0), ("b", 0), ("a", 1), ("b", 1)]
    assert [i for k, i in got if k == "a"] == list(range(per_turn))
    while len(got) < n + 2 and counter.waits < 10:
        executor.spin_once(timeout_sec=1.0)
    assert [i for k, i in got if k == "a"] == list(range(n))
    assert counter.waits == 3  # 16 + 16 + 3 messages of a


def test_a_service_and_a_client_in_the_same_executor(node: Node, executor: LeanExecutor) -> None:
    def answer(request: Any, response: Any) -> Any:
        response.success, response.message = True, "served"
        return response

    node.create_service(ComputeFK, "lean_trigger", answer)
    client = node.create_client(ComputeFK, "lean_trigger")
    spin_until(executor, client.service_is_ready)
    future = client.call_async(ComputeFK.Request())
    executor.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.done() and future.result().message == "served"
    # and through rclpy's module-level helper, which runs spin_once_until_future_complete
    future = client.call_async(ComputeFK.Request())
    rclpy.spin_until_future_complete(node, future, executor=executor, timeout_sec=10.0)
    assert future.result().success


def test_a_held_response_learns_how_long_its_request_waited(
    node: Node, executor: LeanExecutor
) -> None:
    """`DeferredResponses.hold(on_header=...)` over real rmw: the header's source timestamp
    (what the node counts against an IK timeout) measures the time since the client's send."""
    from kinematics_node.ros.deferred import DeferredResponses, waited_since_sent

    waited: list[float] = []

    def answer(request: Any, response: Any) -> Any:
        def start(header: Any) -> None:
            waited.append(waited_since_sent(header))
            response.success = True
            deferred.release(response)

        deferred.hold(response, on_header=start)
        return response

    service = node.create_service(ComputeFK, "lean_held", answer)
    deferred = DeferredResponses(service)
    client = node.create_client(ComputeFK, "lean_held")
    spin_until(executor, client.service_is_ready)
    future = client.call_async(ComputeFK.Request())
    time.sleep(0.2)  # the request waits, as behind a backlog of other callbacks
    executor.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.done() and future.result().success
    assert len(waited) == 1 and 0.2 <= waited[0] < 2.0, waited


def test_timers_fire_and_a_cancelled_timer_does_not(node: Node, executor: LeanExecutor) -> None:
    fired: list[str] = []
    node.create_timer(0.01, lambda: fired.append("running"))
    cancelled = node.create_timer(0.01, lambda: fired.append("cancelled"))
    cancelled.cancel()
    spin_until(executor, lambda: fired.count("running") >= 5)
    assert "cancelled" not in fired


def test_a_guard_condition_triggered_from_another_thread_wakes_the_spin(
    node: Node, executor: LeanExecutor
) -> None:
    woken: list[str] = []
    guard = node.create_guard_condition(lambda: woken.append(threading.current_thread().name))
    executor.spin_once(timeout_sec=0.05)  # the wake-ups from add_node and create_guard_condition
    executor.spin_once(timeout_sec=0.05)
    threading.Timer(0.2, guard.trigger).start()
    start = time.monotonic()
    while not woken and time.monotonic() - start < 5.0:
        executor.spin_once(timeout_sec=5.0)
    assert woken == [threading.current_thread().name]
    assert time.monotonic() - start < 2.0  # woken by the trigger, not by the timeout


def test_a_coroutine_callback_that_waits_finishes_later_and_holds_its_exclusive_group(
    node: Node, executor: LeanExecutor
) -> None:
    group = MutuallyExclusiveCallbackGroup()
    gate: Future = Future()
    events: list[str] = []

    async def slow(request: Any, response: Any) -> Any:
        events.append("slow started")
        await gate
        events.append("slow finished")
        response.success = True
        return response

    def sibling(msg: Int32) -> None:
        events.append(f"sibling {msg.data}")

    node.create_service(ComputeFK, "lean_slow", slow, callback_group=group)
    node.create_subscription(Int32, "lean_sibling", sibling, 10, callback_group=group)
    pub = node.create_publisher(Int32, "lean_sibling", 10)
    client = node.create_client(ComputeFK, "lean_slow")
    spin_until(executor, lambda: client.service_is_ready() and pub.get_subscription_count() > 0)
    future = client.call_async(ComputeFK.Request())
    spin_until(executor, lambda: "slow started" in events)
    pub.publish(Int32(data=1))
    start = time.monotonic()
    for _ in range(20):  # the group is busy: the sibling waits, however often we spin
        executor.spin_once(timeout_sec=0.01)
    assert events == ["slow started"]
    # ... and is left out of the wait meanwhile: each spin waits its timeout out instead of
    # returning at once for a message that cannot be taken yet (20 x 10 ms)
    assert time.monotonic() - start >= 0.15
    gate.set_result(None)
    executor.wake()
    spin_until(executor, lambda: future.done() and "sibling 1" in events)
    assert events == ["slow started", "slow finished", "sibling 1"]
    assert future.result().success


def test_an_exception_in_a_callback_reaches_the_spinner_and_later_work_still_runs(
    node: Node, executor: LeanExecutor
) -> None:
    ran: list[str] = []

    def broken() -> None:
        raise ValueError("broken callback")

    first = node.create_guard_condition(broken)
    second = node.create_guard_condition(lambda: ran.append("second"))
    first.trigger()
    second.trigger()
    with pytest.raises(ValueError, match="broken callback"):
        spin_until(executor, lambda: bool(ran))
    spin_until(executor, lambda: bool(ran))  # the second trigger was not lost
    assert ran == ["second"]


def test_entities_created_and_destroyed_while_spinning(node: Node, executor: LeanExecutor) -> None:
    got: list[str] = []
    pub = node.create_publisher(String, "lean_late", 10)
    executor.spin_once(timeout_sec=0.01)  # a wait set without the subscription
    sub = node.create_subscription(String, "lean_late", lambda m: got.append(m.data), 10)
    spin_until(executor, lambda: pub.get_subscription_count() > 0)
    pub.publish(String(data="first"))
    spin_until(executor, lambda: got == ["first"])
    node.destroy_subscription(sub)
    executor.spin_once(timeout_sec=0.01)  # lets go of the destroyed subscription's handle
    with pytest.raises(Exception):  # noqa: B017 - rclpy's InvalidHandle: really destroyed
        with sub.handle:
            pass
    pub.publish(String(data="second"))
    for _ in range(10):
        executor.spin_once(timeout_sec=0.01)
    assert got == ["first"]


def test_qos_events_reach_their_handlers(node: Node, executor: LeanExecutor) -> None:
    """QoS event handlers are waitables: a reliable subscription to a best-effort publisher
    hears that they are incompatible."""
    heard: list[Any] = []
    node.create_subscription(
        Int32,
        "lean_qos",
        lambda m: None,
        QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE),
        event_callbacks=SubscriptionEventCallbacks(incompatible_qos=heard.append),
    )
    node.create_publisher(
        Int32, "lean_qos", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
    )
    spin_until(executor, lambda: bool(heard))
    assert heard[0].total_count >= 1


def test_shutdown_from_another_thread_ends_spin_and_releases_every_handle(
    context: Any, node: Node
) -> None:
    ex = LeanExecutor(context=context)
    ex.add_node(node)
    node.create_subscription(Int32, "lean_stop", lambda m: None, 10)
    node.create_timer(10.0, lambda: None)
    spinner = threading.Thread(target=ex.spin)
    spinner.start()
    time.sleep(0.2)
    assert ex.shutdown(timeout_sec=5.0)
    spinner.join(5.0)
    assert not spinner.is_alive()
    node.destroy_node()  # would wait on handles still in use
    with pytest.raises(Exception):  # noqa: B017 - rclpy's InvalidHandle
        with node.handle:
            pass


def test_a_context_shut_down_while_spinning_ends_spin(context: Any, node: Node) -> None:
    from rclpy.executors import ExternalShutdownException

    ex = LeanExecutor(context=context)
    ex.add_node(node)
    outcome: list[str] = []

    def spin() -> None:
        try:
            ex.spin()
            outcome.append("returned")
        except ExternalShutdownException:
            outcome.append("external shutdown")

    spinner = threading.Thread(target=spin)
    spinner.start()
    time.sleep(0.2)
    rclpy.shutdown(context=context)
    spinner.join(5.0)
    assert not spinner.is_alive() and outcome


class HumbleShapedExecutor(LeanExecutor):
    """rclpy's executor API as Humble has it: `_take_subscription` returns the message and a
    separate `_execute_subscription` coroutine runs the callback (so do the other kinds)."""

    def _take_subscription(self, sub: Any) -> Any:
        with sub.handle:
            msg_info = sub.handle.take_message(sub.msg_type, sub.raw)
            if msg_info is not None:
                return msg_info[0]
        return None

    async def _execute_subscription(self, sub: Any, msg: Any) -> None:
        if msg:
            sub.callback(msg)

    def _take_guard_condition(self, gc: Any) -> None:
        gc._executor_triggered = False

    async def _execute_guard_condition(self, gc: Any, _: Any) -> None:
        gc.callback()


def test_humbles_two_step_take_and_execute_is_followed(context: Any, node: Node) -> None:
    ex = HumbleShapedExecutor(context=context)
    ex.add_node(node)
    got: list[int] = []
    woken: list[bool] = []
    node.create_subscription(Int32, "lean_humble", lambda m: got.append(m.data), 10)
    guard = node.create_guard_condition(lambda: woken.append(True))
    pub = node.create_publisher(Int32, "lean_humble", 10)
    spin_until(ex, lambda: pub.get_subscription_count() > 0)
    for i in range(3):
        pub.publish(Int32(data=i))
    guard.trigger()
    spin_until(ex, lambda: len(got) == 3 and woken == [True])
    assert got == [0, 1, 2]
    ex.shutdown()
