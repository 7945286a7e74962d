"""`kinematics_node.ik_pool`: IK in worker processes, every job answered by its deadline (no ROS)."""

from __future__ import annotations

import os
import pickle
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from kinematics_node.core import IKOptions, SerialChain
from kinematics_node.ik_pool import IKJob, IKOutcome, IKPool, solve_job

ROBOTS = Path(__file__).resolve().parents[1] / "config" / "robots"
UR5E = SerialChain.from_urdf(ROBOTS / "ur5e.urdf")
PLANAR = SerialChain.from_urdf(ROBOTS / "planar3r.urdf")
UNREACHABLE = np.eye(4)
UNREACHABLE[:3, 3] = [5.0, 0.0, 0.0]  # the UR5e reaches < 1 m: a search uses its whole timeout


def job(chain, T, timeout, deadline=None, **options):
    blob = pickle.dumps(chain)
    opts = IKOptions(timeout=timeout, max_restarts=10**5, **options)
    end = time.monotonic() + timeout if deadline is None else deadline
    return IKJob(hash(blob), blob, T, None, opts, end)


class Answers:
    def __init__(self) -> None:
        self.done = threading.Event()
        self.outcome: IKOutcome | None = None
        self.at = 0.0
        self.calls = 0

    def __call__(self, outcome: IKOutcome) -> None:
        self.calls += 1
        self.outcome, self.at = outcome, time.monotonic()
        self.done.set()


@pytest.fixture(scope="module")
def pool():
    p = IKPool(2, grace=0.01)
    p.warm_up()
    yield p
    p.shutdown()


def test_solves_in_a_worker_and_chains_with_equal_names_stay_apart(pool):
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.1])
    a, b = Answers(), Answers()
    pool.submit(job(UR5E, UR5E.fk(q), 1.0), a)
    T_planar = PLANAR.fk(np.array([0.2, 0.4, -0.3]))
    pool.submit(job(PLANAR, T_planar, 1.0, position_only=True), b)
    assert a.done.wait(5) and b.done.wait(5)
    assert a.outcome.success and b.outcome.success
    np.testing.assert_allclose(UR5E.fk(a.outcome.q), UR5E.fk(q), atol=1e-5)
    np.testing.assert_allclose(PLANAR.fk(b.outcome.q)[:3, 3], T_planar[:3, 3], atol=1e-5)


def test_a_job_past_its_deadline_is_answered_at_once_without_a_solve(pool):
    a = Answers()
    t0 = time.monotonic()
    pool.submit(job(UR5E, UR5E.fk(np.zeros(6)), 0.05, deadline=t0 - 1.0), a)
    assert a.done.wait(2)
    assert not a.outcome.success and a.outcome.q is None
    assert "timeout" in a.outcome.message
    assert a.at - t0 < 0.5


def test_queued_jobs_are_answered_by_deadline_plus_grace_when_every_worker_is_busy(pool):
    busy = [Answers() for _ in range(2)]
    for b in busy:  # both workers busy for 2 s
        pool.submit(job(UR5E, UNREACHABLE, 2.0), b)
    late = Answers()
    t0 = time.monotonic()
    pool.submit(job(UR5E, UR5E.fk(np.zeros(6)), 0.05), late)
    assert late.done.wait(2)
    assert not late.outcome.success and "timeout" in late.outcome.message
    # by deadline + grace (+ slack for a busy machine), not when a worker frees up at 2 s
    assert late.at - t0 <= 0.05 + 0.01 + 0.8, late.at - t0
    for b in busy:
        assert b.done.wait(5)
        assert not b.outcome.success
        assert b.outcome.q is not None  # solved (unsuccessfully) in a worker
    time.sleep(0.1)
    assert late.calls == 1  # the worker's own answer, arriving later, is dropped


def test_time_in_the_queue_counts_against_the_timeout():
    """A job whose deadline is 60 ms away solves with those 60 ms, not with its 1.5 s timeout:
    an unreachable target is answered by the deadline (+ slack for a busy machine)."""
    t0 = time.monotonic()
    outcome = solve_job(job(UR5E, UNREACHABLE, 1.5, deadline=t0 + 0.06))
    assert not outcome.success and outcome.q is not None
    assert time.monotonic() - t0 < 0.06 + 0.5


def one_busy_worker(seconds: float) -> tuple[IKPool, Answers]:
    """A pool of one worker, busy with an unreachable target for `seconds`."""
    p = IKPool(1, grace=0.01)
    p.warm_up()
    a = Answers()
    p.submit(job(UR5E, UNREACHABLE, seconds), a)
    time.sleep(0.3)
    return p, a


def test_shutdown_answers_pending_jobs_and_stops_busy_workers():
    p, a = one_busy_worker(30.0)
    t0 = time.monotonic()
    p.shutdown()
    assert time.monotonic() - t0 < 5.0  # did not wait out the 30 s solve
    assert a.done.wait(1) and a.calls == 1
    assert "shutting down" in a.outcome.message
    with pytest.raises(RuntimeError, match="shut down"):
        p.submit(job(UR5E, UNREACHABLE, 0.1), Answers())


def test_a_killed_worker_fails_its_job_and_the_next_job_gets_a_new_pool():
    p, a = one_busy_worker(5.0)
    for pid in list(p._executor._processes):  # as the OOM killer would
        os.kill(pid, signal.SIGKILL)
    assert a.done.wait(3), "the killed worker's job was never answered"
    assert not a.outcome.success and "failed" in a.outcome.message
    b = Answers()
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.1])
    p.submit(job(UR5E, UR5E.fk(q), 2.0), b)
    assert b.done.wait(10) and b.outcome.success, b.outcome
    p.shutdown()
