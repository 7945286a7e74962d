"""IK solves in worker processes, each answered by its deadline (no rclpy here).

Why processes: the node's pose path must keep up with 1 kHz joint_states, and a Python thread that
runs IK in the same process holds the GIL away from it (measured in ../shared/ROS2_FROM_PYPI.md:
69 % of messages answered instead of 100 %). So IK runs in a `concurrent.futures` process pool
whose workers run at the lowest CPU priority (nice 19), so the pose path keeps its core whenever
it has work, and the solves share what is left. (Measured with benchmarks/node_benchmark.py, 4 IK
clients at 500 Hz joint_states: nice 10 let the workers delay joint_states by up to 14 ms at
the node; nice 19 kept that under 10 ms and every IK answer in time. SCHED_IDLE did as well for
the poses but starved some reachable solves.)

Deadlines: a job carries the monotonic time by which it must be answered (request arrival +
timeout; `time.monotonic` is the system-wide CLOCK_MONOTONIC, the same in every process). A worker
solves with the time left, so time spent waiting in the queue counts against the timeout, and a
job whose deadline has passed before a worker takes it is answered at once as timed out. A
watchdog thread answers, as timed out, any job still running `grace` seconds after its deadline
(all workers busy, a worker died). So `on_done` is called exactly once per job, by its
deadline + grace at the latest, from a pool thread: the caller hands the result to its own thread.

Models: a job names its chain by a key and carries the pickled chain (a few kB); each worker keeps
the chains it has seen, so a model reload is atomic per job: a job is solved on the model it was
submitted with, never on half of one.
"""

from __future__ import annotations

import heapq
import itertools
import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .core import IKOptions, SerialChain

FloatArray = NDArray[np.float64]

#: Solves shorter than this are not started: the answer could not arrive in time anyway [s].
MIN_SOLVE_TIME = 5e-4


@dataclass(frozen=True)
class IKJob:
    """One IK problem for a worker.

    Attributes:
        chain_key: names `chain_blob`: equal keys must mean equal chains (a digest of the blob).
        chain_blob: the pickled `SerialChain`.
        T_base_target: (4, 4) target pose of the tip in the chain's base.
        q_seed: (n,) seed, or None for the middle of the limits.
        options: IK options; `timeout` is replaced by the time left before `deadline`.
        deadline: `time.monotonic()` by which the answer is due [s].
    """

    chain_key: Any
    chain_blob: bytes
    T_base_target: FloatArray
    q_seed: FloatArray | None
    options: IKOptions
    deadline: float


@dataclass(frozen=True)
class IKOutcome:
    """A worker's answer. `q` is None when no solve ran (timed out in the queue, worker failure);
    then `message` says why. Errors are [m] and [rad].

    `solutions` holds, on success, up to `options.num_solutions` distinct solutions nearest the
    seed first, `q` first (empty on failure). `complete` says they are provably every solution
    within the limits (closed form of a 6R arm, a target that is not singular, none left out).
    """

    q: FloatArray | None
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    message: str
    solutions: tuple[FloatArray, ...] = ()
    complete: bool = False


# ---------------------------------------------------------------------- worker process side
_chains: dict[Any, SerialChain] = {}
_CHAINS_KEPT = 4


def _init_worker(niceness: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when workers stop
    if niceness:
        os.nice(niceness)


def solve_job(job: IKJob) -> IKOutcome:
    """Solve `job` in this process with the time left before its deadline (what a worker runs)."""
    left = job.deadline - time.monotonic()
    if left < MIN_SOLVE_TIME:
        return _timed_out(f"waited {job.options.timeout * 1e3:.1f} ms for a free IK worker")
    chain = _chains.get(job.chain_key)
    if chain is None:
        chain = pickle.loads(job.chain_blob)
        if len(_chains) >= _CHAINS_KEPT:
            _chains.pop(next(iter(_chains)))
        _chains[job.chain_key] = chain
    if job.options.num_solutions > 1 and _closed_form_applies(chain, job.options):
        outcome = _closed_form_set(chain, job)
        if outcome is not None:
            return outcome
    left = job.deadline - time.monotonic()
    result = chain.ik(job.T_base_target, job.q_seed, replace(job.options, timeout=max(left, 1e-4)))
    q = np.asarray(result.q, dtype=np.float64)
    solutions: tuple[FloatArray, ...] = ()
    if result.success:
        found = [np.array(s, dtype=np.float64) for s in result.solutions]
        # q first, whatever the solver put in `solutions` (with one solution asked it may be empty)
        found = [q.copy()] + [s for s in found if not np.array_equal(s, q)]
        solutions = tuple(found[: job.options.num_solutions])
    return IKOutcome(
        q=q,
        success=bool(result.success),
        position_error=float(result.position_error),
        orientation_error=float(result.orientation_error),
        iterations=int(result.iterations),
        message=str(getattr(result, "message", "") or ""),
        solutions=solutions,
    )


#: What `SerialChain.ik_all` guarantees every solution reproduces the target to [m, rad].
CLOSED_FORM_TOLERANCE = 1e-9


def _closed_form_applies(chain: SerialChain, options: IKOptions) -> bool:
    """The closed form gives the set when the chain has a family and the whole pose is asked for
    with the two scalar tolerances (per-axis bounds, weights or position_only leave a continuum
    of solutions, which only the numeric search can sample)."""
    return (
        chain.ik_family is not None
        and not options.position_only
        and options.axis_tolerances is None
        and options.weights is None
    )


def _closed_form_set(chain: SerialChain, job: IKJob) -> IKOutcome | None:
    """Up to `options.num_solutions` solutions from `chain.ik_all`, nearest the seed first, that
    meet the job's tolerances; None when there is none (the numeric search then gets its chance:
    a configuration within looser tolerances may exist where no exact one does)."""
    opts = job.options
    result = chain.ik_all(job.T_base_target, q_seed=job.q_seed)
    if not result.solutions:
        return None
    Q = np.array(result.solutions, dtype=np.float64)  # (K, n), nearest the seed first
    dropped = False
    if min(opts.position_tolerance, opts.orientation_tolerance) < CLOSED_FORM_TOLERANCE:
        # tighter than what ik_all checked: keep the solutions that meet the job's tolerances
        pos, ori = _pose_errors(chain.fk(Q), job.T_base_target)
        keep = (pos <= opts.position_tolerance) & (ori <= opts.orientation_tolerance)
        dropped = not bool(np.all(keep))
        Q = Q[keep]
        if Q.shape[0] == 0:
            return None
    n_all = Q.shape[0]
    Q = Q[: opts.num_solutions]
    pos, ori = _pose_errors(chain.fk(Q[:1]), job.T_base_target)
    complete = not (dropped or n_all > Q.shape[0] or result.singular or result.held_values.size > 0)
    return IKOutcome(
        q=Q[0].copy(),
        success=True,
        position_error=float(pos[0]),
        orientation_error=float(ori[0]),
        iterations=0,
        message=str(result.message),
        solutions=tuple(Q.copy()),
        complete=complete,
    )


def _pose_errors(T: FloatArray, T_target: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Position error [m] and rotation angle of R(q)ᵀ R_target [rad] of poses T (K, 4, 4). The
    angle comes from ‖R − R_target‖_F = 2√2 sin(θ/2), accurate near 0 (unlike arccos)."""
    pos = np.linalg.norm(T[:, :3, 3] - T_target[:3, 3], axis=-1)
    chord = np.linalg.norm(T[:, :3, :3] - T_target[:3, :3], axis=(-2, -1)) / (2.0 * np.sqrt(2.0))
    return pos, 2.0 * np.arcsin(np.minimum(chord, 1.0))


def _timed_out(reason: str) -> IKOutcome:
    return IKOutcome(None, False, float("nan"), float("nan"), 0, f"timeout: {reason}")


# ---------------------------------------------------------------------- caller side
class IKPool:
    """Runs `IKJob`s in `workers` processes at CPU priority `nice` and calls back by each deadline.

    Args:
        workers: number of processes (solves that run at once; more jobs wait in a queue).
        niceness: added to the workers' nice value (0 = same priority as the caller; 19 = run
            only on what normal-priority work leaves, at about 1.5 % of a contended core).
        grace: how long after a job's deadline the watchdog answers it as timed out [s].
    """

    def __init__(self, workers: int, niceness: int = 19, grace: float = 0.01) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self._niceness = niceness
        self._executor = self._new_executor()
        self._grace = grace
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._pending: dict[int, Callable[[IKOutcome], None]] = {}
        self._deadlines: list[tuple[float, int]] = []  # heap of (deadline + grace, job id)
        self._ids = itertools.count()
        self._closed = False
        self._watchdog = threading.Thread(target=self._watch, name="ik-watchdog", daemon=True)
        self._watchdog.start()

    def _new_executor(self) -> ProcessPoolExecutor:
        ctx = multiprocessing.get_context("forkserver")
        # Workers fork from a server that has imported the core once, so each starts in ~10 ms.
        # "__main__" too: a worker otherwise re-imports the main script (the node's, with rclpy)
        # by itself; imported once in the server, the workers inherit it.
        ctx.set_forkserver_preload(["__main__", "kinematics_node.core", "kinematics_node.ik_pool"])
        return ProcessPoolExecutor(
            self.workers, mp_context=ctx, initializer=_init_worker, initargs=(self._niceness,)
        )

    def warm_up(self) -> None:
        """Start every worker process now (about a second, for the first import of the core in
        the fork server): `submit` starts missing workers itself, but blocks its caller meanwhile.
        The executor starts a process for each job submitted while none is idle, so `workers`
        jobs submitted at once start them all."""
        futures = [self._executor.submit(time.sleep, 0.1) for _ in range(self.workers)]
        for f in futures:
            f.result()

    def submit(self, job: IKJob, on_done: Callable[[IKOutcome], None]) -> None:
        """Queue `job`; `on_done(outcome)` follows exactly once, by `job.deadline + grace`."""
        with self._lock:
            if self._closed:
                raise RuntimeError("the IK pool is shut down")
            job_id = next(self._ids)
            self._pending[job_id] = on_done
            heapq.heappush(self._deadlines, (job.deadline + self._grace, job_id))
            self._wake.notify()
        try:
            future = self._executor.submit(solve_job, job)
        except BrokenProcessPool:  # a worker died (killed, out of memory): start a new pool
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = self._new_executor()
            try:
                future = self._executor.submit(solve_job, job)
            except Exception as exc:  # noqa: BLE001 - every job must be answered
                self._finish(job_id, _failed(f"no IK worker could be started: {exc!r}"))
                return
        future.add_done_callback(lambda f: self._finish(job_id, _outcome_of(f)))

    def _finish(self, job_id: int, outcome: IKOutcome) -> None:
        with self._lock:
            on_done = self._pending.pop(job_id, None)
        if on_done is not None:
            on_done(outcome)

    def _watch(self) -> None:
        while True:
            expired = []
            with self._lock:
                while not self._closed:
                    now = time.monotonic()
                    while self._deadlines and (
                        self._deadlines[0][0] <= now or self._deadlines[0][1] not in self._pending
                    ):
                        _, job_id = heapq.heappop(self._deadlines)
                        if job_id in self._pending:
                            expired.append(self._pending.pop(job_id))
                    if expired:
                        break
                    wait = self._deadlines[0][0] - now if self._deadlines else None
                    self._wake.wait(wait)
                if self._closed and not expired:
                    return
            for on_done in expired:
                on_done(_timed_out("no IK worker answered before the deadline"))

    def shutdown(self) -> None:
        """Stop the workers (running solves are abandoned) and answer every pending job."""
        with self._lock:
            self._closed = True
            pending = list(self._pending.values())
            self._pending.clear()
            self._wake.notify()
        # Abandon running solves: stopping must not wait for them (up to their timeouts). The
        # executor has no public way to stop busy workers before Python 3.14's terminate_workers.
        for process in list((getattr(self._executor, "_processes", None) or {}).values()):
            process.terminate()
        self._executor.shutdown(wait=True, cancel_futures=True)  # returns once they are gone
        for on_done in pending:
            on_done(_timed_out("the node is shutting down"))


def _outcome_of(future: Future[IKOutcome]) -> IKOutcome:
    if future.cancelled():
        return _timed_out("the job was cancelled")
    exc = future.exception()
    if exc is not None:
        return _failed(f"IK worker failed: {exc!r}")
    return future.result()


def _failed(reason: str) -> IKOutcome:
    return IKOutcome(None, False, float("nan"), float("nan"), 0, reason)
