"""`kinematics_node.service.ik_pool`: IK in worker processes, every job answered by its deadline (no ROS)."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from kin_testing import ur_hole_target

from kinematics_node.core import IKOptions, SerialChain
from kinematics_node.service import ik_pool
from kinematics_node.service.ik_pool import IKJob, IKOutcome, IKPool, chain_blob, solve_job

ROBOTS = Path(__file__).resolve().parents[2] / "config" / "robots"
UR5E = SerialChain.from_urdf(ROBOTS / "ur5e.urdf")
PLANAR = SerialChain.from_urdf(ROBOTS / "planar3r.urdf")
UNREACHABLE = ur_hole_target()  # inside the reach sphere: a search uses its whole timeout
Q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.1])
REACHABLE = UR5E.fk(Q)


def job(chain, T, timeout, deadline=None, key=None, **options):
    blob = chain_blob(chain)
    opts = IKOptions(timeout=timeout, max_restarts=10**5, **options)
    end = time.monotonic() + timeout if deadline is None else deadline
    return IKJob(hash(blob) if key is None else key, blob, T, None, opts, end)


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
    a, b = Answers(), Answers()
    pool.submit(job(UR5E, REACHABLE, 1.0), a)
    T_planar = PLANAR.fk(np.array([0.2, 0.4, -0.3]))
    pool.submit(job(PLANAR, T_planar, 1.0, position_only=True), b)
    assert a.done.wait(5) and b.done.wait(5)
    assert a.outcome.success and b.outcome.success
    np.testing.assert_allclose(UR5E.fk(a.outcome.q), REACHABLE, atol=1e-5)
    np.testing.assert_allclose(PLANAR.fk(b.outcome.q)[:3, 3], T_planar[:3, 3], atol=1e-5)


def test_a_job_past_its_deadline_is_answered_at_once_without_a_solve(pool):
    a = Answers()
    t0 = time.monotonic()
    pool.submit(job(UR5E, UR5E.fk(np.zeros(6)), 0.05, deadline=t0 - 1.0), a)
    assert a.done.wait(2)
    assert not a.outcome.success and a.outcome.q is None
    assert a.outcome.timed_out and "free IK worker" in a.outcome.message, a.outcome
    assert a.at - t0 < 0.5


def test_a_queued_job_that_expires_is_answered_by_its_deadline_and_never_sent(pool):
    busy = [Answers() for _ in range(2)]
    for b in busy:  # both workers busy for 2 s
        pool.submit(job(UR5E, UNREACHABLE, 2.0), b)
    before = pool.stats()
    late = Answers()
    t0 = time.monotonic()
    pool.submit(job(UR5E, UR5E.fk(np.zeros(6)), 0.05), late)
    assert late.done.wait(2)
    assert not late.outcome.success and late.outcome.q is None
    assert late.outcome.timed_out and "free IK worker" in late.outcome.message, late.outcome
    # by its deadline (+ slack for a busy machine), not when a worker frees up at 2 s
    assert late.at - t0 <= 0.05 + 0.01 + 0.8, late.at - t0
    for b in busy:
        assert b.done.wait(5)
        assert not b.outcome.success
        assert b.outcome.q is not None  # solved (unsuccessfully) in a worker
    time.sleep(0.1)
    after = pool.stats()
    assert late.calls == 1
    assert after.expired_in_queue - before.expired_in_queue == 1
    assert after.sent == before.sent  # the freed workers were not handed the expired job


def test_queued_jobs_go_to_a_free_worker_earliest_deadline_first():
    p, busy = one_busy_worker(0.5)
    later, sooner = Answers(), Answers()
    p.submit(job(UR5E, REACHABLE, 4.0), later)
    p.submit(job(UR5E, REACHABLE, 3.0), sooner)
    assert later.done.wait(10) and sooner.done.wait(10)
    assert later.outcome.success and sooner.outcome.success
    assert sooner.at < later.at  # submitted second, solved first
    assert p.stats().sent == 3
    p.shutdown()


def test_the_chain_goes_to_each_worker_once_per_key():
    p = IKPool(2, grace=0.01)
    p.warm_up()
    try:
        for _ in range(3):  # two at once: both workers solve, each gets the chain once
            pair = [Answers(), Answers()]
            for a in pair:
                p.submit(job(UR5E, REACHABLE, 2.0), a)
            for a in pair:
                assert a.done.wait(10) and a.outcome.success, a.outcome
        stats = p.stats()
        assert (stats.sent, stats.chain_blobs_sent) == (6, 2)
    finally:
        p.shutdown()


def test_a_worker_keeps_the_chains_of_its_last_keys_and_is_told_which_to_forget():
    """One worker, keys 0..K (K = the number kept): after 0..K-1 twice, K evicts 0, which must
    then be sent again. Every job succeeds: pool and worker agree on what the worker holds."""
    kept = ik_pool._CHAINS_KEPT
    p = IKPool(1, grace=0.01)
    p.warm_up()

    def solve(key):
        a = Answers()
        p.submit(job(UR5E, REACHABLE, 2.0, key=("ur5e", key)), a)
        assert a.done.wait(10) and a.outcome.success, a.outcome
        return p.stats().chain_blobs_sent

    try:
        assert [solve(k) for k in range(kept)] == list(range(1, kept + 1))
        assert [solve(k) for k in range(kept)] == [kept] * kept  # all held
        assert solve(kept) == kept + 1  # a new key: sent, and the oldest (0) forgotten
        assert solve(1) == kept + 1  # still held
        assert solve(0) == kept + 2  # forgotten, so sent again
    finally:
        p.shutdown()


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


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_shutdown_answers_pending_jobs_and_stops_busy_workers():
    p, a = one_busy_worker(30.0)
    t0 = time.monotonic()
    p.shutdown()
    assert time.monotonic() - t0 < 5.0  # did not wait out the 30 s solve
    assert a.done.wait(1) and a.calls == 1
    assert "shutting down" in a.outcome.message and not a.outcome.timed_out
    with pytest.raises(RuntimeError, match="shut down"):
        p.submit(job(UR5E, UNREACHABLE, 0.1), Answers())


def test_shutdown_with_jobs_running_and_queued_answers_each_once_and_leaves_nothing_behind():
    threads = set(threading.enumerate())
    p = IKPool(2, grace=0.01)
    p.warm_up()
    pids = p.worker_pids()
    running = [Answers() for _ in range(2)]
    for a in running:
        p.submit(job(UR5E, UNREACHABLE, 30.0), a)
    queued = [Answers() for _ in range(3)]
    for a in queued:
        p.submit(job(UR5E, REACHABLE, 30.0), a)
    time.sleep(0.3)
    assert p.stats().sent == 2
    t0 = time.monotonic()
    p.shutdown()
    assert time.monotonic() - t0 < 5.0
    time.sleep(0.2)  # room for a second, wrong, call
    for a in running + queued:
        assert a.calls == 1 and "shutting down" in a.outcome.message, a.outcome
    assert len(pids) == 2 and not any(alive(pid) for pid in pids)
    assert set(threading.enumerate()) <= threads  # the pool's thread is joined
    p.shutdown()  # a second shutdown does nothing
    assert all(a.calls == 1 for a in running + queued)


def test_a_killed_worker_fails_its_job_and_is_replaced():
    p, a = one_busy_worker(5.0)
    [pid] = p.worker_pids()
    os.kill(pid, signal.SIGKILL)  # as the OOM killer would
    assert a.done.wait(3), "the killed worker's job was never answered"
    assert not a.outcome.success and "failed" in a.outcome.message
    b = Answers()
    p.submit(job(UR5E, REACHABLE, 2.0), b)
    assert b.done.wait(10) and b.outcome.success, b.outcome
    [new_pid] = p.worker_pids()
    assert new_pid != pid
    stats = p.stats()
    assert (stats.workers_lost, stats.workers_started) == (1, 2)
    assert stats.chain_blobs_sent == 2  # the new worker had to be sent the chain
    p.shutdown()


def test_a_running_job_past_deadline_plus_grace_is_answered_and_the_worker_kept():
    """A stopped worker (as a starved one would be) gets a job: the pool answers it by deadline
    + grace; the worker's own answer, once it runs again, is dropped, and it solves the next."""
    p = IKPool(1, grace=0.01)
    p.warm_up()
    [pid] = p.worker_pids()
    os.kill(pid, signal.SIGSTOP)
    try:
        a = Answers()
        t0 = time.monotonic()
        p.submit(job(UR5E, REACHABLE, 0.1), a)
        assert a.done.wait(2)
        assert a.outcome.timed_out and "IK worker answered" in a.outcome.message
        assert a.outcome.q is None
        assert a.at - t0 <= 0.1 + 0.01 + 0.8, a.at - t0
        assert p.stats().overdue == 1
    finally:
        os.kill(pid, signal.SIGCONT)
    b = Answers()
    p.submit(job(UR5E, REACHABLE, 2.0), b)
    assert b.done.wait(10) and b.outcome.success, b.outcome
    assert a.calls == 1
    assert p.stats().late_outcomes == 1
    assert p.worker_pids() == [pid]
    p.shutdown()


def test_a_worker_that_never_answers_is_killed_and_replaced(monkeypatch):
    monkeypatch.setattr(ik_pool, "HUNG_AFTER", 0.3)
    p = IKPool(1, grace=0.01)
    p.warm_up()
    [pid] = p.worker_pids()
    os.kill(pid, signal.SIGSTOP)
    a = Answers()
    p.submit(job(UR5E, REACHABLE, 0.1), a)
    assert a.done.wait(2) and a.outcome.timed_out, a.outcome
    b = Answers()
    p.submit(job(UR5E, REACHABLE, 5.0), b)  # queued until the hung worker is replaced
    assert b.done.wait(10) and b.outcome.success, b.outcome
    assert p.worker_pids() != [pid] and not alive(pid)
    assert p.stats().workers_lost == 1
    p.shutdown()


def test_a_worker_solves_until_a_margin_before_the_deadline_that_short_timeouts_keep_small():
    margin = ik_pool.ANSWER_MARGIN
    assert ik_pool._solve_until(10.0, 10.0 - 1.0) == pytest.approx(10.0 - margin)
    share = ik_pool.ANSWER_SHARE
    assert ik_pool._solve_until(10.0, 10.0 - 0.002) == pytest.approx(10.0 - 0.002 * share)
    assert ik_pool._solve_until(10.0, 10.5) == 10.0  # already past: nothing taken off


def test_a_worker_exempts_its_inherited_heap_from_the_cyclic_gc():
    """A full collection of a worker's inherited heap took most of a 50 ms IK timeout; a worker
    starts by freezing that heap (here in a fresh interpreter, as the fork server's child)."""
    import subprocess
    import sys

    code = (
        "import gc; import kinematics_node.core; from kinematics_node.service import ik_pool; "
        "before = gc.get_freeze_count(); ik_pool._init_worker(0, False); "
        "print(before, gc.get_freeze_count())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    before, after = (int(v) for v in out.stdout.split())
    assert after - before > 10_000  # (Python 3.12 starts with a few hundred objects frozen)


def test_solve_at_once_answers_a_reachable_target_as_a_worker_would_and_leaves_the_rest():
    reachable = job(UR5E, REACHABLE, 0.05)
    now = ik_pool.solve_at_once(UR5E, reachable)
    assert now is not None and now.success and now.iterations == 0
    by_worker = solve_job(reachable)
    np.testing.assert_allclose(now.q, by_worker.q, atol=1e-12)
    assert len(now.solutions) == 1 and np.array_equal(now.solutions[0], now.q)
    np.testing.assert_allclose(UR5E.fk(now.q), REACHABLE, atol=1e-9)
    # for a worker: no exact solution (the search may still find one within the tolerances),
    # several solutions asked (the set), an arm without a closed form, no time left
    assert ik_pool.solve_at_once(UR5E, job(UR5E, UNREACHABLE, 0.05)) is None
    assert ik_pool.solve_at_once(UR5E, job(UR5E, REACHABLE, 0.05, num_solutions=2)) is None
    assert ik_pool.solve_at_once(PLANAR, job(PLANAR, PLANAR.fk(np.zeros(3)), 0.05)) is None
    late = job(UR5E, REACHABLE, 0.05, deadline=time.monotonic())
    assert ik_pool.solve_at_once(UR5E, late) is None


def test_a_negative_grace_answers_before_the_deadline_but_never_before_the_worker_stops(
    monkeypatch,
):
    """The node answers a job its (stopped, as if starved) worker has not answered a little
    before the deadline, so that the answer's way out of the node still fits in the timeout;
    but never before the worker's own stop (+ WORKER_SLACK): its answer gets its chance."""
    monkeypatch.setattr(ik_pool, "ANSWER_MARGIN", 0.5)  # the worker stops 0.4 s early (20 %)
    p = IKPool(1, grace=-1.0)
    p.warm_up()
    [pid] = p.worker_pids()
    os.kill(pid, signal.SIGSTOP)
    try:
        a = Answers()
        submitted = job(UR5E, UNREACHABLE, 2.0)
        p.submit(submitted, a)
        assert a.done.wait(5)
        assert a.outcome.timed_out and p.stats().overdue == 1
        worker_stop = submitted.deadline - 0.4
        assert worker_stop + ik_pool.WORKER_SLACK - 0.01 <= a.at, a.at - submitted.deadline
        assert a.at <= submitted.deadline - 0.2, a.at - submitted.deadline  # not at the deadline
    finally:
        os.kill(pid, signal.SIGCONT)
    p.shutdown()


@pytest.mark.skipif(not hasattr(os, "SCHED_IDLE"), reason="SCHED_IDLE is Linux's")
@pytest.mark.parametrize("idle", [True, False])
def test_workers_run_at_the_lowest_priority(idle):
    """nice 19, and SCHED_IDLE unless told not to: the node's thread finds a core whenever it has
    work (the module docstring has the measurements)."""
    p = IKPool(1, idle=idle)
    try:
        p.warm_up()
        a = Answers()
        p.submit(job(UR5E, REACHABLE, 1.0), a)  # (the worker has set its priority by its answer)
        assert a.done.wait(5) and a.outcome is not None and a.outcome.success
        (worker,) = p._all
        pid = worker.process.pid
        nice = min(os.getpriority(os.PRIO_PROCESS, 0) + 19, 19)
        assert os.getpriority(os.PRIO_PROCESS, pid) == nice
        assert os.sched_getscheduler(pid) == (os.SCHED_IDLE if idle else os.SCHED_OTHER)
    finally:
        p.shutdown()
