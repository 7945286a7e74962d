"""`Mailbox`: items wait for the collector's own turn, and the bell rings only when they waited
their patience out."""

from __future__ import annotations

import threading
import time

import pytest

from kinematics_node.ros.mailbox import Mailbox


class Bell:
    def __init__(self) -> None:
        self.rung: list[tuple[float, str]] = []  # (monotonic time, thread name)
        self.event = threading.Event()

    def __call__(self) -> None:
        self.rung.append((time.monotonic(), threading.current_thread().name))
        self.event.set()


@pytest.fixture
def bell_and_box():
    bell = Bell()
    box: Mailbox[int] = Mailbox(bell, name="test-watcher")
    yield bell, box
    box.close()


def test_no_patience_rings_at_once_from_the_putting_thread(bell_and_box):
    bell, box = bell_and_box
    box.put(1, 0.0)
    assert [name for _, name in bell.rung] == [threading.current_thread().name]
    assert box.collect() == [1] and len(box) == 0


def test_items_collected_within_their_patience_ring_no_bell(bell_and_box):
    bell, box = bell_and_box
    for i in range(3):
        box.put(i, 0.05)
    assert box.collect() == [0, 1, 2]  # oldest first
    time.sleep(0.2)  # well past the patience: the watcher must have let it go
    assert bell.rung == []


def test_an_item_left_waiting_rings_once_its_patience_is_out(bell_and_box):
    bell, box = bell_and_box
    start = time.monotonic()
    box.put(7, 0.05)
    assert bell.event.wait(5.0), "the bell never rang"
    ((at, name),) = bell.rung
    assert at - start >= 0.05 and name == "test-watcher"
    assert box.collect() == [7]


def test_the_earliest_patience_decides(bell_and_box):
    bell, box = bell_and_box
    start = time.monotonic()
    box.put(1, 10.0)
    box.put(2, 0.05)  # a later item with less patience
    assert bell.event.wait(5.0)
    assert bell.rung[0][0] - start < 5.0
    assert box.collect() == [1, 2]


def test_no_patience_after_a_patient_item_rings_at_once(bell_and_box):
    bell, box = bell_and_box
    box.put(1, 10.0)
    box.put(2, 0.0)
    assert len(bell.rung) == 1 and box.collect() == [1, 2]


def test_close_stops_the_watcher():
    bell = Bell()
    box: Mailbox[int] = Mailbox(bell, name="closing-watcher")
    box.put(1, 10.0)
    box.close()
    assert not any(t.name == "closing-watcher" for t in threading.enumerate())
    assert box.collect() == [1] and bell.rung == []
