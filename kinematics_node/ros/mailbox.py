"""Items from other threads, collected by one thread on its own turns (no rclpy here).

The node's IK answers come back from the pool's thread, and only the executor thread may send
them. Waking the executor for each answer (triggering a guard condition) costs a turn of its own
(two of rclpy's SingleThreadedExecutor, each setting up its wait set again: ~0.3 ms of the node's
CPU per answer, a third of what an IK request cost it). While joint_states stream in, the executor takes a turn for
every message anyway (every 1-2 ms at 500 Hz-1 kHz), and can collect the answers then.

So a `Mailbox` takes each item with a patience: how long it may wait for the collector's next
turn. When the collector has not collected it by then, the mailbox rings (`ring`, the guard
condition's trigger), from a watcher thread of its own that sleeps until then. A patience of 0
rings at once, from the putting thread: the node gives that when no joint_states are streaming.
So an item waits at most its patience (plus scheduling) for the collector to be woken.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


class Mailbox(Generic[T]):
    """Items for one collecting thread; `ring` wakes it (see the module docstring).

    Args:
        ring: wakes the collector (thread-safe; called from the putting thread or the watcher).
        name: of the watcher thread.
    """

    def __init__(self, ring: Callable[[], None], name: str = "mailbox") -> None:
        self._ring = ring
        self._items: deque[T] = deque()
        self._cond = threading.Condition(threading.Lock())
        self._due = math.inf  # when the bell rings for the items waiting (monotonic time [s])
        self._closed = False
        self._thread = threading.Thread(target=self._watch, name=name, daemon=True)
        self._thread.start()

    def __len__(self) -> int:
        return len(self._items)

    def put(self, item: T, patience: float) -> None:
        """Add `item`; the collector is woken if it has not collected it within `patience` [s]."""
        with self._cond:
            self._items.append(item)
            if patience > 0.0:
                due = time.monotonic() + patience
                if due < self._due:
                    self._due = due
                    self._cond.notify()
                return
            self._due = math.inf
        self._ring()

    def collect(self) -> list[T]:
        """Every item waiting, oldest first (from the collecting thread)."""
        with self._cond:
            items = list(self._items)
            self._items.clear()
            self._due = math.inf
        return items

    def close(self) -> None:
        """Stop the watcher thread (items still waiting stay collectable)."""
        with self._cond:
            self._closed = True
            self._cond.notify()
        if self._thread is not threading.current_thread():
            self._thread.join()

    def _watch(self) -> None:
        while True:
            with self._cond:
                while not self._closed:
                    left = self._due - time.monotonic()
                    if left <= 0.0:
                        break
                    self._cond.wait(None if left == math.inf else left)
                if self._closed:
                    return
                self._due = math.inf
            self._ring()
