"""A single-threaded rclpy executor that costs one wait per callback, not two rebuilt wait sets.

Why: rclpy's `SingleThreadedExecutor` spends most of a light node's CPU on itself. Each
`spin_once` gathers every entity of every node, enters each handle, allocates a new wait set and
fills it, waits, then wraps the one callback it runs in a `Task`. After the callback it triggers
its own guard condition, so the next wait returns at once, only to build the whole wait set again.
At 1 kHz joint_states that is two full turns per message (an idle turn of our node costs about
0.15 ms of Python), and each compute_ik request costs two more.

`LeanExecutor` keeps rclpy's behaviour and drops that overhead:
* the wait set (`_Plan`) is allocated once and refilled from prepared handle lists each turn; it is
  rebuilt only when a node's entities change (created, destroyed, a node added or removed);
* every callback that a wait found ready runs in that turn, inline, in rclpy's order of kinds
  (waitables, timers, subscriptions, guard conditions, clients, services), one message or
  request each, as rclpy takes them; nothing is retriggered after a callback;
* then the subscriptions that had a message are taken from again, one message each per round,
  while they have more (at most `MORE_TAKES` rounds), before the next wait. rclpy waits again
  for every message; a node that fell behind (a backlog of joint_states while other processes
  held the CPU) then pays a whole turn per queued message and catches up slowly. (Only
  subscriptions: rclpy's takes of clients and services do not say whether they found anything.)
  Measured with benchmarks/node_benchmark.py, 4 IK clients at 500 Hz joint_states, 7 alternating
  pairs: pose p99 3.9-6.6 ms in all 7 runs with these takes, 4.9-32.7 ms without (3 of 7 over
  10 ms);
* it takes data and calls callbacks through rclpy's own per-kind methods (`_take_subscription`,
  `_take_service`, ...), so how a message, request or timer event is taken stays rclpy's, in
  whatever version is installed;
* a coroutine callback that suspends becomes a `Task` (as in rclpy), and while any task is
  pending, entities whose callback group is busy are left out of the wait (as rclpy does);
  without pending tasks no group can be busy (every callback has returned), so none is asked.

The handles of the nodes' entities are held in use while the plan lives (rclpy holds them only
during each wait). Destroying an entity from a callback or another thread therefore takes effect
at the start of the next turn, when the changed entity list releases the plan; `spin` releases it
when it returns, and so does the first turn after `shutdown`.

It uses the rclpy internals that rclpy's own executors use (`_rclpy.WaitSet`, handle pointers,
`Executor._take_*` and on Humble `Executor._execute_*`, the state `Executor.__init__` sets up, a
guard condition's `_executor_triggered`), and it defines every method that rclpy's `Executor`
leaves to its subclasses (those that raise NotImplementedError there: `spin_once`,
`spin_once_until_future_complete`, and from rclpy 9 (Kilted) on `_spin_once_until_future_complete`,
which `Executor.spin_until_future_complete` calls). `lean_executor_supported` checks all of it,
and `make_executor` falls back to `SingleThreadedExecutor`, saying why, where something differs
(a future rclpy). Tested on rclpy 7.1 (Jazzy) and 9.1 (Kilted); Humble's two-step take/execute
form is exercised by a test that imitates it.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from contextlib import ExitStack, suppress
from dataclasses import dataclass, field
from typing import Any, cast

from rclpy.exceptions import InvalidHandle
from rclpy.executors import (
    Executor,
    ExternalShutdownException,
    SingleThreadedExecutor,
)
from rclpy.task import Task
from rclpy.waitable import NumberOfEntities

# Internals, imported so that an rclpy without them still imports this module (and the node falls
# back to rclpy's executor, `make_executor`)
try:
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
except ImportError:  # pragma: no cover - an rclpy that moved its C extension
    _rclpy = None  # type: ignore[assignment]
try:
    from rclpy.utilities import timeout_sec_to_nsec
except ImportError:  # pragma: no cover
    timeout_sec_to_nsec = None  # type: ignore[assignment]

#: entity kind -> (the wait set's name of it, WaitSet.add_*, the Executor's taker)
_KINDS = (
    ("timers", "timer", "add_timer", "_take_timer"),
    ("subscriptions", "subscription", "add_subscription", "_take_subscription"),
    ("guards", "guard_condition", "add_guard_condition", "_take_guard_condition"),
    ("clients", "client", "add_client", "_take_client"),
    ("services", "service", "add_service", "_take_service"),
)

#: Rounds of further takes from the subscriptions that had a message, before the next wait
#: (module docstring): a backlog of 100 messages costs 7 waits instead of 100, and the other
#: entities wait at most 15 more callbacks of each of those for their turn.
MORE_TAKES = 15

#: The rclpy internals LeanExecutor relies on (module docstring): rclpy's Executor's takers; the
#: calls of `_rclpy.WaitSet`; the members of `_rclpy`'s entity handles it reads; what
#: `Executor.__init__` sets up in an executor; a guard condition's flag for a trigger that the wait
#: set consumed; and what a waitable's `get_num_entities()` counts.
_TAKERS = (*(taker for *_, taker in _KINDS), "_take_waitable")
_WAIT_SET_CALLS = (
    "clear_entities",
    *(add for _, _, add, _ in _KINDS),
    "wait",
    "get_ready_entities",
)
_HANDLE_MEMBERS = (
    *((cls, "pointer") for cls in ("Timer", "Subscription", "GuardCondition", "Client", "Service")),
    ("Timer", "is_timer_ready"),
)
_EXECUTOR_STATE = ("_context", "_guard", "_is_shutdown", "_tasks", "_tasks_lock", "_work_tracker")
#: ... and what it uses only where rclpy has it: the SIGINT guard condition (an executor's wake-up
#: on Ctrl-C), Humble's `_execute_<kind>` halves of its takers (`LeanExecutor._taker`)
_OPTIONAL = ("_sigint_gc", *(taker.replace("_take_", "_execute_", 1) for taker in _TAKERS))
_GUARD_STATE = ("_executor_triggered",)
_ENTITY_COUNTS = (
    "num_subscriptions",
    "num_guard_conditions",
    "num_timers",
    "num_clients",
    "num_services",
    "num_events",
)


def lean_executor_supported(executor: Executor | None = None) -> str | None:
    """None when this rclpy has what `LeanExecutor` uses, else what is missing (comma-separated).

    Without `executor`, what can be checked before one exists (classes and modules); with one (a
    LeanExecutor just made), also the state that rclpy's `Executor.__init__` set up in it."""
    missing = []
    if _rclpy is None:
        missing.append("rclpy.impl.implementation_singleton.rclpy_implementation")
    if timeout_sec_to_nsec is None:
        missing.append("rclpy.utilities.timeout_sec_to_nsec")
    missing += [
        f"Executor.{name}" for name in _TAKERS if not callable(getattr(Executor, name, None))
    ]
    missing += [f"LeanExecutor.{name}" for name in _hooks_left_undefined()]
    if _rclpy is not None:
        wait_set = getattr(_rclpy, "WaitSet", None)
        if wait_set is None:
            missing.append("_rclpy.WaitSet")
        else:
            missing += [f"WaitSet.{n}" for n in _WAIT_SET_CALLS if not hasattr(wait_set, n)]
        missing += [
            f"_rclpy.{cls}.{member}"
            for cls, member in _HANDLE_MEMBERS
            if not hasattr(getattr(_rclpy, cls, None), member)
        ]
    counts = NumberOfEntities()
    missing += [f"NumberOfEntities.{n}" for n in _ENTITY_COUNTS if not hasattr(counts, n)]
    if executor is not None:
        missing += [f"Executor.{n}" for n in _EXECUTOR_STATE if not hasattr(executor, n)]
        guard = getattr(executor, "_guard", None)
        if guard is not None:
            missing += [f"GuardCondition.{n}" for n in _GUARD_STATE if not hasattr(guard, n)]
    return ", ".join(missing) or None


def _hooks_left_undefined() -> list[str]:
    """The methods rclpy's `Executor` leaves to its subclasses (its own raise NotImplementedError,
    as `spin_once` does) that `LeanExecutor` does not define: a public method of `Executor` that
    calls one of them would raise NotImplementedError on a LeanExecutor."""
    undefined = []
    for name in dir(Executor):
        method = getattr(Executor, name, None)
        code = getattr(method, "__code__", None)
        if code is None or "NotImplementedError" not in code.co_names:
            continue
        if getattr(LeanExecutor, name, None) is method:
            undefined.append(name)
    return undefined


def make_executor(
    kind: str = "lean", log: Callable[[str], object] | None = None, context: Any = None
) -> Executor:
    """The executor of a node process: `LeanExecutor` ("lean") where this rclpy supports it, else
    (or for "rclpy") rclpy's `SingleThreadedExecutor`; `log` hears about a fallback."""
    if kind == "lean":
        missing = lean_executor_supported()
        if missing is None:
            executor = LeanExecutor(context=context)
            missing = lean_executor_supported(executor)
            if missing is None:
                return executor
            # let go of its guard conditions, as far as rclpy's shutdown still fits it
            with suppress(Exception):
                executor.shutdown()
        if log is not None:
            log(
                f"this rclpy lacks what the lean executor uses ({missing}); "
                "using rclpy's SingleThreadedExecutor"
            )
    return SingleThreadedExecutor(context=context)


@dataclass
class _Plan:
    """A wait set and what goes in it, for one set of entities (`key`)."""

    key: tuple
    wait_set: Any
    hold: ExitStack  # the entities' handles, held in use while the plan lives
    timers: list = field(default_factory=list)  # (node, entity, handle) in rclpy's order
    subscriptions: list = field(default_factory=list)
    guards: list = field(default_factory=list)
    clients: list = field(default_factory=list)
    services: list = field(default_factory=list)
    waitables: list = field(default_factory=list)  # (node, waitable)
    own_guards: list = field(default_factory=list)  # the executor's: wake-up and SIGINT


class LeanExecutor(Executor):
    """Runs every ready callback in the calling thread, one wait per turn (module docstring)."""

    def __init__(self, *, context: Any = None) -> None:
        super().__init__(context=context)
        self._plan: _Plan | None = None
        self._takers = {name: self._taker(name) for name in _TAKERS}

    # ------------------------------------------------------------------ rclpy's Executor API
    def spin(self) -> None:
        try:
            super().spin()
        finally:
            self._release()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        self._turn(timeout_sec)

    def spin_once_until_future_complete(self, future: Any, timeout_sec: Any = None) -> None:
        future.add_done_callback(lambda _: self.wake())
        self._spin_once_until_future_complete(future, timeout_sec)

    def _spin_once_until_future_complete(self, future: Any, timeout_sec: Any = None) -> None:
        """One turn that returns at once when `future` is done (rclpy 9's
        `Executor.spin_until_future_complete` calls this; it has made the future wake us)."""
        # Iron and later pass the time left as a TimeoutObject, Humble as a float
        self._turn(getattr(timeout_sec, "timeout", timeout_sec), future.done)

    # ------------------------------------------------------------------ one turn
    def _turn(self, timeout_sec: float | None, condition: Callable[[], bool] | None = None) -> None:
        if self._is_shutdown:
            self._release()
            return
        if condition is not None and condition():
            return
        tasks_pending = self._run_tasks()
        plan = self._current_plan()
        if plan is None:  # shut down meanwhile
            return
        ws = plan.wait_set
        ws.clear_entities()
        for kind, _, add, _ in _KINDS:
            add_entity = getattr(ws, add)
            for _, entity, handle in getattr(plan, kind):
                if not tasks_pending or self.can_execute(entity):
                    add_entity(handle)
        for handle in plan.own_guards:
            ws.add_guard_condition(handle)
        waited = []
        for node, waitable in plan.waitables:
            if not tasks_pending or self.can_execute(waitable):
                waitable.add_to_wait_set(ws)
                waited.append((node, waitable))
        ws.wait(timeout_sec_to_nsec(timeout_sec))
        if self._is_shutdown:
            self._release()
            return
        if not self._context.ok():
            self._release()
            raise ExternalShutdownException()

        ready: list[tuple[Any, Any, Callable[[Any], Any]]] = []
        queued: list[tuple[Any, Any, Callable[[Any], Any]]] = []  # may hold more messages
        for node, waitable in waited:
            if waitable.is_ready(ws):
                ready.append((node, waitable, self._takers["_take_waitable"]))
        for kind, name, _, taker in _KINDS:
            pointers = ws.get_ready_entities(name)
            if not pointers:
                continue
            take = self._takers[taker]
            for node, entity, handle in getattr(plan, kind):
                if handle.pointer in pointers:
                    if kind == "timers" and not handle.is_timer_ready():
                        continue  # rclpy's check: rcl reports cancelled timers ready
                    if kind == "guards":
                        entity._executor_triggered = True
                    ready.append((node, entity, take))
                    if kind == "subscriptions":
                        queued.append((node, entity, take))
        if not ready:
            return
        with self._work_tracker:
            for i, (node, entity, take) in enumerate(ready):
                try:
                    self._execute(node, entity, take)
                except BaseException:
                    for _, later, _ in ready[i + 1 :]:  # taken by the wait: not to be lost
                        if getattr(later, "_executor_triggered", False):
                            later.trigger()
                    raise
            for _ in range(MORE_TAKES):  # (an error leaves the rest queued for the next wait)
                if not queued or self._is_shutdown:
                    break
                queued = [item for item in queued if self._execute(*item)]

    def _taker(self, name: str) -> Callable[[Any], Any]:
        """rclpy's `_take_<kind>` as Iron and later shape it: take the entity's data and return an
        async function that runs its callback (None: nothing taken). Humble's takes the data and
        leaves the callback to a separate `_execute_<kind>(entity, data)` coroutine: adapted."""
        take = getattr(self, name)
        execute = getattr(self, name.replace("_take_", "_execute_", 1), None)
        if execute is None:
            return take

        subscription = name == "_take_subscription"

        def take_then_execute(entity: Any) -> Callable[[], Any] | None:
            data = take(entity)
            if subscription and data is None:
                return None  # an empty queue (Humble's other takes give None by design)
            return lambda: execute(entity, data)

        return take_then_execute

    def _execute(self, node: Any, entity: Any, take: Callable[[Any], Any]) -> bool:
        """Take `entity`'s data and run its callback (rclpy's `_make_handler`, inline); False
        when nothing was taken (its group busy, the entity destroyed, or no data)."""
        group = entity.callback_group
        if not group.beginning_execution(entity):
            if getattr(entity, "_executor_triggered", False):
                entity.trigger()  # not now: keep the event for a later turn
            return False
        try:
            execute = take(entity)
        except BaseException:
            group.ending_execution(entity)
            raise
        if execute is None:  # nothing to take after all (destroyed, or no message)
            group.ending_execution(entity)
            return False
        coroutine = _ending(execute(), group, entity)
        try:
            coroutine.send(None)
        except StopIteration:
            return True
        # the callback awaits something: finish it as a task, resumed on later turns
        # (rclpy's Task runs a started coroutine as well as a coroutine function; its typing
        # names only callables)
        task = Task(cast(Any, coroutine), executor=self)
        with self._tasks_lock:
            self._tasks.append((task, entity, node))
        return True

    def _run_tasks(self) -> bool:
        """Resume the pending tasks (rclpy's executors resume every one on every turn); True
        while some are still pending afterwards. Raises what a task raised, as rclpy does."""
        if not self._tasks:
            return False
        with self._tasks_lock:
            tasks = list(self._tasks)
        failed = None
        for task, _, _ in reversed(tasks):
            if not task.executing() and not task.done():
                task()
                if failed is None and task.done() and task.exception() is not None:
                    failed = task.exception()
        with self._tasks_lock:
            self._tasks = [t for t in self._tasks if not (t[0].done() or t[0].cancelled())]
            pending = bool(self._tasks)
        if failed is not None:
            raise failed
        return pending

    # ------------------------------------------------------------------ the plan
    def _current_plan(self) -> _Plan | None:
        nodes = sorted(self.get_nodes(), key=id)
        key = tuple(
            (
                node,
                tuple(node.timers),
                tuple(node.subscriptions),
                tuple(node.guards),
                tuple(node.clients),
                tuple(node.services),
                tuple(node.waitables),
            )
            for node in nodes
        )
        plan = self._plan
        if plan is not None and plan.key == key:
            return plan
        self._release()
        if self._is_shutdown or self._guard is None:
            return None
        self._plan = plan = self._build_plan(nodes, key)
        return plan

    def _build_plan(self, nodes: list[Any], key: tuple) -> _Plan:
        hold = ExitStack()
        try:
            counts = dict.fromkeys(("timers", "subscriptions", "guards", "clients", "services"), 0)
            plan = _Plan(key, None, hold)
            for node in nodes:
                for kind, _, _, _ in _KINDS:
                    for entity in getattr(node, kind):
                        try:
                            hold.enter_context(entity.handle)
                        except InvalidHandle:
                            continue  # destroyed meanwhile: the next turn sees it gone
                        getattr(plan, kind).append((node, entity, entity.handle))
                        counts[kind] += 1
            events = 0
            for node in nodes:
                for waitable in node.waitables:
                    try:
                        hold.enter_context(waitable)
                    except InvalidHandle:
                        continue
                    n = waitable.get_num_entities()
                    for kind, attr in (
                        ("subscriptions", "num_subscriptions"),
                        ("guards", "num_guard_conditions"),
                        ("timers", "num_timers"),
                        ("clients", "num_clients"),
                        ("services", "num_services"),
                    ):
                        counts[kind] += getattr(n, attr)
                    events += n.num_events
                    plan.waitables.append((node, waitable))
            for guard in (self._guard, getattr(self, "_sigint_gc", None)):
                if guard is None:  # (an rclpy without a SIGINT guard condition)
                    continue
                hold.enter_context(guard.handle)
                plan.own_guards.append(guard.handle)
                counts["guards"] += 1
            context = self._context.handle
            if context is None:  # (as rclpy's executors check)
                raise RuntimeError("Cannot enter context if context is None")
            hold.enter_context(context)
            plan.wait_set = _rclpy.WaitSet(
                counts["subscriptions"],
                counts["guards"],
                counts["timers"],
                counts["clients"],
                counts["services"],
                events,
                context,
            )
            return plan
        except BaseException:
            hold.close()
            raise

    def _release(self) -> None:
        """Let go of the plan's handles (entities destroyed meanwhile are destroyed now)."""
        plan, self._plan = self._plan, None
        if plan is not None:
            plan.hold.close()


async def _ending(execute: Coroutine, group: Any, entity: Any) -> None:
    """Run a callback's coroutine (rclpy's `_execute`), then tell its group it has ended."""
    try:
        await execute
    finally:
        group.ending_execution(entity)
