"""LeanExecutor (kinematics_node/ros/executor.py) against real rclpy, in this process: every kind of
entity it runs, the parts of rclpy's semantics it keeps (callback groups, coroutine callbacks,
exceptions, entities created or destroyed while spinning, shutdown), and the one wait per
callback that is its reason to exist."""

from __future__ import annotations

import sys
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
from rclpy.executors import Executor, SingleThreadedExecutor
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
    ex = make_executor(context=context)
    assert isinstance(ex, LeanExecutor)
    assert lean_executor_supported(ex) is None


def test_asked_for_rclpys_executor_the_process_gets_it_and_nothing_is_said(context: Any) -> None:
    said: list[str] = []
    assert type(make_executor("rclpy", said.append, context)) is SingleThreadedExecutor
    assert said == []


class Hiding:
    """Stands in for `real` without the attributes `hidden`, and with `replaced` in place of
    others (everything else goes to `real`)."""

    def __init__(self, real: Any, *hidden: str, **replaced: Any) -> None:
        self._real, self._hidden, self._replaced = real, hidden, replaced

    def __getattr__(self, name: str) -> Any:
        if name in self._hidden:
            raise AttributeError(name)
        if name in self._replaced:
            return self._replaced[name]
        return getattr(self._real, name)


def _rclpy_hooks() -> list[str]:
    """The methods this rclpy's Executor leaves to its subclasses (they raise NotImplementedError
    there): spin_once, spin_once_until_future_complete, and on rclpy 9 (Kilted)
    _spin_once_until_future_complete, which Executor.spin_until_future_complete calls."""
    return [
        name
        for name in dir(Executor)
        if "NotImplementedError" in getattr(getattr(Executor, name), "__code__", NO_CODE).co_names
    ]


NO_CODE = (lambda: None).__code__


def _internals() -> list[str]:
    """Every rclpy internal that `lean_executor_supported` checks, as it names them."""
    m = executor_module
    return [
        "rclpy.impl.implementation_singleton.rclpy_implementation",
        "rclpy.utilities.timeout_sec_to_nsec",
        *(f"Executor.{name}" for name in m._TAKERS),
        *(f"LeanExecutor.{name}" for name in _rclpy_hooks()),
        "_rclpy.WaitSet",
        *(f"WaitSet.{name}" for name in m._WAIT_SET_CALLS),
        *(f"_rclpy.{cls}.{member}" for cls, member in m._HANDLE_MEMBERS),
        *(f"NumberOfEntities.{name}" for name in m._ENTITY_COUNTS),
        *(f"Executor.{name}" for name in m._EXECUTOR_STATE),
        *(f"GuardCondition.{name}" for name in m._GUARD_STATE),
    ]


def _take_away(internal: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Make this rclpy look like one without `internal` (as `_internals` names it)."""
    m = executor_module
    owner, _, name = internal.rpartition(".")
    if internal.startswith("rclpy."):
        monkeypatch.setattr(m, "_rclpy" if "implementation" in internal else name, None)
    elif owner == "Executor" and name in m._TAKERS:
        monkeypatch.delattr(Executor, name)
    elif owner == "LeanExecutor":
        monkeypatch.delattr(LeanExecutor, name)
    elif internal == "_rclpy.WaitSet":
        monkeypatch.setattr(m, "_rclpy", Hiding(m._rclpy, "WaitSet"))
    elif owner == "WaitSet":
        monkeypatch.setattr(m, "_rclpy", Hiding(m._rclpy, WaitSet=Hiding(m._rclpy.WaitSet, name)))
    elif owner.startswith("_rclpy."):
        cls = owner.split(".")[1]
        monkeypatch.setattr(
            m, "_rclpy", Hiding(m._rclpy, **{cls: Hiding(getattr(m._rclpy, cls), name)})
        )
    elif owner == "NumberOfEntities":
        real = m.NumberOfEntities
        monkeypatch.setattr(m, "NumberOfEntities", lambda: Hiding(real(), name))
    else:  # state that rclpy's Executor.__init__ sets up, in the executor or its guard condition
        init = Executor.__init__

        def without(self: Any, *args: Any, **kwargs: Any) -> None:
            init(self, *args, **kwargs)
            if isinstance(self, LeanExecutor):  # (rclpy's executor, the fallback, keeps it)
                monkeypatch.delattr(self._guard if owner == "GuardCondition" else self, name)

        monkeypatch.setattr(Executor, "__init__", without)


@pytest.mark.parametrize("internal", _internals())
def test_where_rclpy_lacks_an_internal_the_process_falls_back_to_rclpy_and_says_which(
    internal: str, context: Any
) -> None:
    said: list[str] = []
    # (its own monkeypatch: what is taken away is back before the context shuts down, which
    # wakes every executor made in it, through the guard condition rclpy's Executor made)
    with pytest.MonkeyPatch.context() as monkeypatch:
        _take_away(internal, monkeypatch)
        ex = make_executor(log=said.append, context=context)
    assert type(ex) is SingleThreadedExecutor
    assert len(said) == 1 and internal in said[0].split("(", 1)[1], said


def test_a_method_a_future_rclpy_leaves_to_executors_is_noticed(
    monkeypatch: pytest.MonkeyPatch, context: Any
) -> None:
    """A new method that rclpy's Executor leaves to subclasses (as rclpy 9 added
    _spin_once_until_future_complete): LeanExecutor lacks it, so the node falls back."""

    def _spin_some_new_way(self: Any) -> None:
        raise NotImplementedError()

    monkeypatch.setattr(Executor, "_spin_some_new_way", _spin_some_new_way, raising=False)
    assert lean_executor_supported() == "LeanExecutor._spin_some_new_way"
    said: list[str] = []
    assert type(make_executor(log=said.append, context=context)) is SingleThreadedExecutor
    assert len(said) == 1 and "LeanExecutor._spin_some_new_way" in said[0]


class Recording(WaitCounter):
    """Stands in for `_rclpy` in the executor module: records which of its members and of its
    wait sets' the module uses."""

    def __init__(self, real: Any) -> None:
        super().__init__(real)
        self.used: set[str] = set()
        counting = self.WaitSet
        recording = self

        class WaitSet(counting):  # type: ignore[valid-type, misc]
            def __getattr__(self, name: str) -> Any:
                if sys._getframe(1).f_code.co_filename == executor_module.__file__:
                    recording.used.add(f"WaitSet.{name}")  # (rclpy's waitables add their own)
                return super().__getattr__(name)

        self.WaitSet = WaitSet

    def __getattr__(self, name: str) -> Any:
        self.used.add(f"_rclpy.{name}")
        return super().__getattr__(name)


def test_every_rclpy_internal_the_lean_executor_touches_is_checked(
    context: Any, node: Node, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every kind of entity through a LeanExecutor (timer, subscription, guard condition,
    service and client, a QoS event waitable, a coroutine callback left pending as a task), while
    recording what of rclpy beyond its public API the module's code touches: the executor's
    private attributes that rclpy's Executor defines, `_rclpy`'s members and its wait set's
    calls. Each must be one that `lean_executor_supported` checks (or uses only where present)."""
    m = executor_module
    recording = Recording(m._rclpy)
    monkeypatch.setattr(m, "_rclpy", recording)
    touched: set[str] = set()

    class Touching(LeanExecutor):
        def __getattribute__(self, name: str) -> Any:
            if name.startswith("_") and not name.startswith("__"):
                if sys._getframe(1).f_code.co_filename == m.__file__:
                    touched.add(name)
            return object.__getattribute__(self, name)

    ex = Touching(context=context)
    ex.add_node(node)
    fired: list[str] = []
    gate: Future = Future()

    async def slow(request: Any, response: Any) -> Any:
        await gate
        response.success = True
        return response

    node.create_timer(0.01, lambda: fired.append("timer"))
    node.create_subscription(Int32, "lean_touch", lambda m: fired.append("message"), 10)
    guard = node.create_guard_condition(lambda: fired.append("guard"))
    node.create_service(ComputeFK, "lean_touch", slow)
    client = node.create_client(ComputeFK, "lean_touch")
    node.create_subscription(
        Int32,
        "lean_touch_qos",
        lambda m: None,
        QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE),
        event_callbacks=SubscriptionEventCallbacks(incompatible_qos=lambda e: fired.append("qos")),
    )
    node.create_publisher(
        Int32, "lean_touch_qos", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
    )
    pub = node.create_publisher(Int32, "lean_touch", 10)
    spin_until(ex, lambda: pub.get_subscription_count() > 0 and client.service_is_ready())
    pub.publish(Int32(data=1))
    guard.trigger()
    future = client.call_async(ComputeFK.Request())
    spin_until(ex, lambda: {"timer", "message", "guard", "qos"} <= set(fired))
    gate.set_result(None)
    ex.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.result().success
    ex.shutdown()
    ex.spin_once(timeout_sec=0.0)

    own = (
        set(vars(LeanExecutor))
        | (set(vars(LeanExecutor(context=context))) - set(vars(ex)))
        | (
            set(vars(LeanExecutor(context=context)))
            - set(vars(SingleThreadedExecutor(context=context)))
        )
    )
    checked = {*m._TAKERS, *m._EXECUTOR_STATE, *m._OPTIONAL, *_rclpy_hooks()}
    assert touched - own, "(the recording works)"
    assert touched - own <= checked, touched - own - checked
    calls = {f"_rclpy.{cls}" for cls, _ in m._HANDLE_MEMBERS} | {"_rclpy.WaitSet"}
    calls |= {f"WaitSet.{name}" for name in m._WAIT_SET_CALLS}
    assert recording.used and recording.used <= calls, recording.used - calls


def _nodes(ex: LeanExecutor, node: Node, context: Any) -> None:
    other = Node("lean_other", context=context)
    ticks: list[int] = []
    other.create_timer(0.01, lambda: ticks.append(1))
    assert ex.add_node(other) and not ex.add_node(other)
    assert set(ex.get_nodes()) == {node, other}
    spin_until(ex, lambda: len(ticks) >= 2)
    ex.remove_node(other)
    assert ex.get_nodes() == [node]
    ex.spin_once(timeout_sec=0.05)  # (lets go of the other node's timer)
    ticks.clear()
    for _ in range(5):
        ex.spin_once(timeout_sec=0.02)
    assert ticks == []
    other.destroy_node()


def _a_future_done_by_a_timer(node: Node, future: Future | None = None) -> Future:
    future = Future() if future is None else future
    node.create_timer(0.05, lambda: future.done() or future.set_result("done"))
    return future


def _spin_until_future_complete(ex: LeanExecutor, node: Node, context: Any) -> None:
    """The method rclpy 9 builds on `_spin_once_until_future_complete` (NotImplementedError
    on LeanExecutor before it had one): with a timeout, without, and one that runs out."""
    future = _a_future_done_by_a_timer(node)
    ex.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.result() == "done"
    future = _a_future_done_by_a_timer(node)
    ex.spin_until_future_complete(future)
    assert future.result() == "done"
    never: Future = Future()
    ex.spin_until_future_complete(never, timeout_sec=0.1)
    assert not never.done()


def _spin_once_until_future_complete(ex: LeanExecutor, node: Node, context: Any) -> None:
    future = _a_future_done_by_a_timer(node)
    end = time.monotonic() + 10.0
    while not future.done() and time.monotonic() < end:
        ex.spin_once_until_future_complete(future, timeout_sec=1.0)
    assert future.result() == "done"


def _create_task(ex: LeanExecutor, node: Node, context: Any) -> None:
    async def seven() -> int:
        return 7

    plain, coroutine = ex.create_task(lambda x: x + 1, 41), ex.create_task(seven)
    spin_until(ex, lambda: plain.done() and coroutine.done())
    assert (plain.result(), coroutine.result()) == (42, 7)


def _create_future(ex: LeanExecutor, node: Node, context: Any) -> None:
    future = _a_future_done_by_a_timer(node, ex.create_future())
    ex.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.result() == "done"


def _spin_once(ex: LeanExecutor, node: Node, context: Any) -> None:
    ticks: list[int] = []
    node.create_timer(0.01, lambda: ticks.append(1))
    spin_until(ex, lambda: len(ticks) >= 3)


def _spin_and_shutdown(ex: LeanExecutor, node: Node, context: Any) -> None:
    ticks: list[int] = []
    node.create_timer(0.01, lambda: ticks.append(1))
    spinner = threading.Thread(target=ex.spin)
    spinner.start()
    end = time.monotonic() + 10.0
    while len(ticks) < 3 and time.monotonic() < end:
        time.sleep(0.01)
    assert ex.shutdown(timeout_sec=10.0)
    spinner.join(10.0)
    assert len(ticks) >= 3 and not spinner.is_alive()


def _wake(ex: LeanExecutor, node: Node, context: Any) -> None:
    for _ in range(3):  # the wake-ups of add_node
        ex.spin_once(timeout_sec=0.05)
    spinner = threading.Thread(target=ex.spin_once, kwargs={"timeout_sec": 60.0})
    spinner.start()
    time.sleep(0.2)
    ex.wake()
    spinner.join(10.0)
    assert not spinner.is_alive()  # woken, not timed out


def _can_execute(ex: LeanExecutor, node: Node, context: Any) -> None:
    group = MutuallyExclusiveCallbackGroup()
    sub = node.create_subscription(Int32, "lean_can", lambda m: None, 10, callback_group=group)
    assert ex.can_execute(sub)
    assert group.beginning_execution(sub)
    assert not ex.can_execute(sub)  # its exclusive group is busy
    group.ending_execution(sub)


def _wait_for_ready_callbacks(ex: LeanExecutor, node: Node, context: Any) -> None:
    woken: list[bool] = []
    guard = node.create_guard_condition(lambda: woken.append(True))
    guard.trigger()
    end = time.monotonic() + 10.0
    while not woken and time.monotonic() < end:
        handler, _, _ = ex.wait_for_ready_callbacks(timeout_sec=1.0)
        handler()
    assert woken


def _context(ex: LeanExecutor, node: Node, context: Any) -> None:
    assert ex.context is context


#: rclpy's public Executor methods, each run on a LeanExecutor (rclpy 7.1 lacks create_future)
PUBLIC_METHODS: dict[str, Callable[[LeanExecutor, Node, Any], None]] = {
    "add_node": _nodes,
    "remove_node": _nodes,
    "get_nodes": _nodes,
    "can_execute": _can_execute,
    "context": _context,
    "create_future": _create_future,
    "create_task": _create_task,
    "shutdown": _spin_and_shutdown,
    "spin": _spin_and_shutdown,
    "spin_once": _spin_once,
    "spin_once_until_future_complete": _spin_once_until_future_complete,
    "spin_until_future_complete": _spin_until_future_complete,
    "wait_for_ready_callbacks": _wait_for_ready_callbacks,
    "wake": _wake,
}


@pytest.mark.parametrize("name", sorted(n for n in dir(Executor) if not n.startswith("_")))
def test_every_public_method_of_rclpys_executor_works_on_the_lean_executor(
    name: str, node: Node, executor: LeanExecutor, context: Any
) -> None:
    assert name in PUBLIC_METHODS, f"rclpy's Executor has {name}, which no test here runs"
    PUBLIC_METHODS[name](executor, node, context)


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
