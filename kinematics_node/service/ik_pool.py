"""IK solves in worker processes, each answered by its deadline (no rclpy here).

Why processes: the node's pose path must keep up with 1 kHz joint_states, and a Python thread that
runs IK in the same process holds the GIL away from it (measured in ../shared/ROS2_FROM_PYPI.md:
69 % of messages answered instead of 100 %). So IK runs in worker processes at the lowest CPU
priority, so the pose path keeps its core whenever it has work, and the solves share what is left:
nice 19 and, on Linux, the SCHED_IDLE policy (which runs a task only on CPU time that no normal
task wants). Measured with benchmarks/node_benchmark.py, 4 IK clients at 500 Hz joint_states, on a
shared 2-core machine where the harness's own processes take most of a core: in the episodes where
pose latency built up to 25-200 ms, the node's thread was runnable but waiting for a core 30-45 %
of the time (/proc/<tid>/schedstat), while the nice-19 workers ran (42 % of a core in one such
episode). Over 14 alternating pairs of runs, the pose p99 was over 10 ms in 5 runs with SCHED_IDLE
and in 12 with nice 19 alone (medians 9.0 and 36.6 ms), and IK answers came later than
timeout + 20 ms in 4 runs (9 answers) against 9 (52). (One plausible reason: the scheduler places
a waking thread on an idle core, and it counts a core that runs only SCHED_IDLE tasks as idle, but
not one that runs a nice-19 task.) Before reachable targets were solved in the node's own thread,
SCHED_IDLE starved some of their solves; now most never reach a worker.

Mechanics, chosen to cost the node's process (and its GIL) as little as possible: each worker is a
process forked from a fork server that has imported the core, joined to the node by one duplex
pipe. `submit` sends a job (a compact pickle) straight from the caller's thread to an idle worker;
when every worker is busy the job waits in a queue in the node, ordered by deadline. One thread,
the only one the pool adds to the node, waits on every worker's pipe and exit sentinel: it takes
each answer, calls `on_done`, sends the next queued job to the worker that answered, answers
overdue jobs, and replaces workers that die or hang. (`concurrent.futures.ProcessPoolExecutor`
needed a feeder and a management thread, pickled through a shared queue and sent the chain with
every job: about twice the node-side CPU per job.)

Deadlines: a job carries the monotonic time by which it must be answered (the client's send of the
request + its timeout, `service.prepare_ik`; `time.monotonic` is the system-wide CLOCK_MONOTONIC,
the same in every process). A worker solves with the time left, less a few ms (`ANSWER_MARGIN`) for
its answer to reach the node, so time spent waiting in the queue counts against the timeout, and a
queued job whose deadline comes before a worker is free is answered as timed out without being
sent. A job still running `grace` seconds after its deadline (a starved or stopped worker) is
answered as timed out then (with a negative grace, before the deadline, but never before the
worker's own stop + `WORKER_SLACK`); the worker's own answer, when it comes, is dropped. A worker
that dies (killed, out of memory) has its job answered as failed and is replaced; one that has not
answered `HUNG_AFTER` seconds after its job's deadline is killed and replaced. So `on_done` is
called exactly once per job, by its deadline + grace at the latest, from the pool's thread (for
jobs still open at `shutdown`, from the thread calling it): the caller hands the result to its own
thread.

Models: a job names its chain by a key and carries the pickled chain (a few kB) with its
closed-form family (`chain_blob`: detected once in the node, so no worker spends a job's time
detecting it; `SerialChain.ik` then answers from the closed form where it applies). The chain goes
down a worker's pipe only the first time that worker sees the key; each worker keeps the chains of
the last `_CHAINS_KEPT` keys it used (the pool tracks which, and says which one to forget). So a
model reload is atomic per job: a job is solved on the model it was submitted with, never on half
of one.
"""

from __future__ import annotations

import gc
import heapq
import itertools
import logging
import math
import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, replace
from multiprocessing.connection import Connection, wait
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import IKOptions, IKResult, SerialChain
from ..core.ik.closed_form import export_family, import_family, pose_errors
from ..core.ik.result import check_seed
from ..core.ik.solver import beyond_reach, nearest_first, solve_closed_form

FloatArray = NDArray[np.float64]

#: Solves shorter than this are not started: the answer could not arrive in time anyway [s].
MIN_SOLVE_TIME = 5e-4
#: A worker solves until this long before its job's deadline (at most `ANSWER_SHARE` of the time
#: left), so that its answer reaches the node by the deadline: niced workers on a busy machine
#: answer late by a few ms (measured: 1.3 ms median, 9-10 ms p99 at 500 Hz + 4 IK clients). At
#: 5 ms, 12 % of the answers in that benchmark reached the node after their deadline (worst
#: 15-22 ms after); at 8 ms, 5 % (worst 14 ms after) [s].
ANSWER_MARGIN = 0.008
ANSWER_SHARE = 0.2
#: With a negative `grace`, a job is still given this long after its worker's own stop [s].
WORKER_SLACK = 0.001
#: A worker that has not answered this long after its job's deadline is killed and replaced [s].
HUNG_AFTER = 5.0
#: After a failed start of a worker process, the next attempt waits this long [s].
RESTART_BACKOFF = 1.0

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class IKJob:
    """One IK problem for a worker.

    Attributes:
        chain_key: names `chain_blob`: equal keys must mean equal chains (a digest of the blob).
        chain_blob: `chain_blob(chain)`: the pickled `SerialChain` with its closed-form family.
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

    `timed_out`: the job's deadline came before a solve could start or before its worker
    answered; `message` then says when, as a phrase that follows "the timeout ran out" ("while
    the job waited for a free IK worker"), so that the caller can say it with the request's own
    timeout and the time it really took.

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
    timed_out: bool = False

    @classmethod
    def failed(cls, reason: str, timed_out: bool = False) -> IKOutcome:
        """An outcome of no solve (`q` None, errors NaN) and the reason."""
        return cls(None, False, math.nan, math.nan, 0, reason, timed_out=timed_out)


# ---------------------------------------------------------------------- worker process side
_chains: dict[Any, SerialChain] = {}
_CHAINS_KEPT = 4


def _init_worker(niceness: int, idle: bool) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when workers stop
    if niceness:
        os.nice(niceness)
    if idle and hasattr(os, "SCHED_IDLE"):  # (Linux)
        try:
            os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
        except OSError:
            pass  # not allowed here (a seccomp profile): the nice value alone
    # Exempt the heap inherited from the fork server (numpy, the core: ~80k objects) from the
    # cyclic GC, as the node does with its own: a full collection of it took 34-38 ms, most of
    # a 50 ms IK timeout, and came at random inside solves. (freeze is O(1): it touches no object,
    # so the pages stay shared with the fork server.)
    gc.freeze()


def chain_blob(chain: SerialChain) -> bytes:
    """What an `IKJob` carries of its chain: the chain and its closed-form family
    (`closed_form.export_family`, detected here once if needed), pickled; a worker installs the
    family with the chain instead of detecting it (20–100 ms) inside its first job."""
    return pickle.dumps((chain, export_family(chain)), pickle.HIGHEST_PROTOCOL)


def solve_job(job: IKJob) -> IKOutcome:
    """Solve `job` in this process with the time left before its deadline (what a worker runs)."""
    left = job.deadline - time.monotonic()
    if left < MIN_SOLVE_TIME:
        if job.options.timeout < MIN_SOLVE_TIME:  # (the request's own: only the deadline moves)
            return _failed(
                f"the timeout of {job.options.timeout * 1e3:.2g} ms is shorter than the "
                f"{MIN_SOLVE_TIME * 1e3:g} ms a solve needs at least"
            )
        return _timed_out("before an IK worker could start on the job")
    chain = _chains.get(job.chain_key)
    if chain is None:
        chain, family = pickle.loads(job.chain_blob)
        import_family(chain, family)  # the family the node detected: no detection here
        if len(_chains) >= _CHAINS_KEPT:
            _chains.pop(next(iter(_chains)))
        _chains[job.chain_key] = chain
    if (
        job.options.num_solutions > 1
        and _closed_form_applies(chain, job.options)
        and not beyond_reach(chain, job.T_base_target, job.options)  # (`chain.ik` says so)
    ):
        outcome = _closed_form_set(chain, job)
        if outcome is not None:
            return outcome
    left = job.deadline - time.monotonic()
    result = chain.ik(job.T_base_target, job.q_seed, replace(job.options, timeout=max(left, 1e-4)))
    return _outcome(result, job.options.num_solutions)


def solve_at_once(chain: SerialChain, job: IKJob) -> IKOutcome | None:
    """`job`'s answer from the closed form, in the caller's thread, when it finds a solution at
    its first try (`core.ik.solve_closed_form`; per call with the node's options: a UR5e
    0.14 ms, 0.03 ms for a miss; an iiwa14 0.23 ms, 0.18 ms for a miss); None otherwise, and
    then a worker solves the job. One solution asked only: the set of several (`ik_all`) costs a
    UR5e ~0.7 ms.

    Why in the node's thread: handing a job to a worker costs the node more than this (the job's
    pickle, the pool's thread, the answer's hand-back), and a niced worker on a busy machine
    waits for the CPU: in the IK phase of benchmarks/node_benchmark.py, reachable targets took
    5-9 ms median and 14-33 ms p99 to be answered, and 0-3 per run were not solved by their
    50 ms deadline, while each needs ~0.2 ms of CPU."""
    opts = job.options
    if opts.num_solutions != 1 or not _closed_form_applies(chain, opts):
        return None
    if job.deadline - time.monotonic() < MIN_SOLVE_TIME:
        return None
    # the request's own options, full timeout included: one try takes the same time whatever
    # the timeout, and options the core has seen find their prepared problem (a new timeout on
    # every call rebuilt it: ~0.07 ms more per call, measured)
    result = solve_closed_form(chain, job.T_base_target, job.q_seed, opts)
    return None if result is None else _outcome(result, 1)


def _outcome(result: IKResult, num_solutions: int) -> IKOutcome:
    q = np.asarray(result.q, dtype=np.float64)
    solutions: tuple[FloatArray, ...] = ()
    if result.success:
        found = [np.array(s, dtype=np.float64) for s in result.solutions]
        # q first, whatever the solver put in `solutions` (with one solution asked it may be empty)
        found = [q.copy()] + [s for s in found if not np.array_equal(s, q)]
        solutions = tuple(found[:num_solutions])
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
    meet the job's tolerances, and with them the answer the same job asking for one solution gets
    (`_single_answer`); None when `ik_all` has none (the numeric search then gets its chance:
    a configuration within looser tolerances may exist where no exact one does)."""
    opts = job.options
    result = chain.ik_all(job.T_base_target, q_seed=job.q_seed)
    if not result.solutions:
        return None
    Q = np.array(result.solutions, dtype=np.float64)  # (K, n), nearest the seed first
    dropped = False
    if min(opts.position_tolerance, opts.orientation_tolerance) < CLOSED_FORM_TOLERANCE:
        # tighter than what ik_all checked: keep the solutions that meet the job's tolerances
        pos, ori = pose_errors(chain.fk(Q), job.T_base_target[None])
        keep = (pos <= opts.position_tolerance) & (ori <= opts.orientation_tolerance)
        dropped = not bool(np.all(keep))
        Q = Q[keep]
        if Q.shape[0] == 0:
            return None
    single = _single_answer(chain, job)
    if single is not None:
        seed = single.seed
        order, new = nearest_first(
            single.q, Q, seed, _joint_weights(chain, opts), opts.solution_separation
        )
        Q = np.vstack((single.q, Q))[order]
        dropped = dropped or new  # a solution ik_all did not list: the set was not every one
    n_all = Q.shape[0]
    Q = Q[: opts.num_solutions]
    pos, ori = pose_errors(chain.fk(Q[:1]), job.T_base_target[None])
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


@dataclass(frozen=True)
class _Single:
    q: FloatArray  # (n,) the solution
    seed: FloatArray  # (n,) the seed it is nearest, within the limits (as `ik` took it)


def _single_answer(chain: SerialChain, job: IKJob) -> _Single | None:
    """The solution `job` gets when it asks for one solution (mode "speed"), as `solve_job`
    finds it (`chain.ik`, the closed form first), or None where that fails. A set's first must
    never be farther from the seed than this (ComputeIK.srv: "nearest the seed first"), and the
    set of `ik_all` sweeps a 7R arm's held joint over fixed values, none of them the seed's, where
    `ik` holds it at the seed's value first (on a Panda 10 of 60 random targets had the set's
    first up to 0.08 rad farther); at a singular target of a 6R arm the two differ by ~1e-8."""
    opts = replace(job.options, mode="speed", num_solutions=1)
    # `solve_closed_form` first (`solve_at_once`'s way: the job's own options, whose prepared
    # problem the core keeps): where its first try finds one, `ik` returns exactly that
    result = solve_closed_form(chain, job.T_base_target, job.q_seed, opts)
    if result is None:
        left = job.deadline - time.monotonic()
        result = chain.ik(job.T_base_target, job.q_seed, replace(opts, timeout=max(left, 1e-4)))
    if not result.success:
        return None
    seed = check_seed(chain, job.q_seed, "q_seed", None)  # as `ik` took it: clamped, or default
    return _Single(np.array(result.q, dtype=np.float64), seed)


def _joint_weights(chain: SerialChain, opts: IKOptions) -> FloatArray:
    """(n,) the weights of `ik`'s joint-space distance to the seed."""
    if opts.joint_weights is None:
        return np.ones(chain.dof)
    return np.array(opts.joint_weights, dtype=np.float64)


def _timed_out(when: str) -> IKOutcome:
    """No solve, because the deadline came `when` (follows "the timeout ran out")."""
    return IKOutcome.failed(when, timed_out=True)


_failed = IKOutcome.failed


def _serve(conn: Connection, niceness: int, idle: bool) -> None:
    """A worker process: answer each job that arrives on `conn` with its `IKOutcome`, until the
    pool closes the pipe. A message is (job without its chain blob, the blob when this worker has
    not seen the job's key yet, else None, a key whose blob to forget or None)."""
    _init_worker(niceness, idle)
    blobs: dict[Any, bytes] = {}  # the pool tracks this worker's keys, and says which to forget
    while True:
        try:
            message = conn.recv_bytes()
        except (EOFError, OSError):
            return  # the pool (or the node) is gone
        try:
            job, blob, forget = pickle.loads(message)
            if forget is not None:
                blobs.pop(forget, None)
            if blob is not None:
                blobs[job.chain_key] = blob
            outcome = solve_job(replace(job, chain_blob=blobs[job.chain_key]))
        except Exception as exc:  # noqa: BLE001 - every job must be answered
            outcome = _failed(f"IK worker failed: {exc!r}")
        try:
            answer = pickle.dumps(outcome, pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # noqa: BLE001
            answer = pickle.dumps(_failed(f"IK worker failed: {exc!r}"), pickle.HIGHEST_PROTOCOL)
        try:
            conn.send_bytes(answer)
        except OSError:
            return


# ---------------------------------------------------------------------- caller side
@dataclass
class IKPoolStats:
    """Counts since the pool was made (`IKPool.stats`)."""

    submitted: int = 0  #: jobs submitted
    sent: int = 0  #: jobs sent to a worker
    chain_blobs_sent: int = 0  #: of those, sent with their chain (the worker's first of its key)
    expired_in_queue: int = 0  #: answered as timed out while queued, never sent
    overdue: int = 0  #: answered as timed out at deadline + grace while a worker still ran them
    late_outcomes: int = 0  #: workers' answers that came after their job was answered (dropped)
    workers_started: int = 0  #: worker processes started, replacements included
    workers_lost: int = 0  #: worker processes that died or were killed as hung


class _Open:
    """A submitted job and whom to tell; `answered` flips once, under the pool's lock, and the one
    who flips it calls `on_done` (after releasing the lock)."""

    __slots__ = ("job", "on_done", "answered", "due")

    def __init__(self, job: IKJob, on_done: Callable[[IKOutcome], None]) -> None:
        self.job, self.on_done, self.answered = job, on_done, False
        self.due = job.deadline  # answered as timed out then if its worker has not answered


class _Worker:
    """A worker process, the node's end of its pipe, the job it is solving (None: idle) and the
    chain keys it holds, least recently used first."""

    __slots__ = ("process", "conn", "open", "keys", "killed")

    def __init__(self, process: Any, conn: Connection) -> None:
        self.process, self.conn = process, conn
        self.open: _Open | None = None
        self.keys: OrderedDict[Any, None] = OrderedDict()
        self.killed = False


class IKPool:
    """Runs `IKJob`s in `workers` low-priority processes and calls back by each deadline.

    Args:
        workers: number of processes (solves that run at once; more jobs wait in a queue).
        niceness: added to the workers' nice value (0 = same priority as the caller; 19 = run
            only on what normal-priority work leaves, at about 1.5 % of a contended core).
        grace: how long after a job's deadline a job still running is answered as timed out [s];
            negative: that long before it, but not before the worker's own stop + WORKER_SLACK.
            0 (the default) keeps a caller's deadline even when a niced worker is starved; the
            node passes a few ms less (`node.EARLY_ANSWER`), for the answer's way out. Measured
            in the IK phase of benchmarks/node_benchmark.py: with 10 ms, 9 answers in 6 runs
            reached the clients later than timeout + 20 ms; with 0, 2 in 9 runs.
        idle: also run the workers under Linux's SCHED_IDLE policy (elsewhere, or where it is
            not allowed: the nice value alone); see the module docstring.

    Locking: `_lock` guards every field below that `submit` and the pool's thread share; neither
    calls `on_done` while holding it. Only the pool's thread reads the workers' pipes; a worker's
    pipe is written only while the worker is idle, under the lock.
    """

    def __init__(
        self, workers: int, niceness: int = 19, grace: float = 0.0, idle: bool = True
    ) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self._niceness = niceness
        self._sched_idle = idle
        self._grace = grace
        self._lock = threading.Lock()
        self._start_lock = threading.Lock()  # one warm_up at a time
        self._thread: threading.Thread | None = None
        self._closed = False
        self._all: list[_Worker] = []
        self._idle: list[_Worker] = []  # a stack: the last to answer is the next to solve
        self._queue: list[tuple[float, int, _Open]] = []  # heap of (deadline, order, job)
        self._order = itertools.count()
        self._outbox: list[tuple[_Open, IKOutcome]] = []  # decided answers, for the thread to give
        self._missing = workers  # worker processes to start
        self._retry_at = 0.0
        self._wake_at = math.inf  # when the thread wakes up by itself
        self._owner: dict[Any, _Worker] = {}  # pipe or exit sentinel -> its worker
        self._stats = IKPoolStats()
        self._wake_r, self._wake_w = os.pipe()  # a byte written here wakes the thread
        os.set_blocking(self._wake_r, False)
        os.set_blocking(self._wake_w, False)

    # ------------------------------------------------------------------ public
    def warm_up(self) -> None:
        """Start every worker process and the pool's thread now (about a second, for the first
        import of the core in the fork server). `submit` does it itself when it was not done,
        but blocks its caller meanwhile."""
        with self._start_lock:
            if self._thread is not None:
                return
            with self._lock:
                if self._closed:
                    raise RuntimeError("the IK pool is shut down")
                count, self._missing = self._missing, 0
            started: list[_Worker] = []
            error: BaseException | None = None
            try:
                for _ in range(count):
                    started.append(_start_worker(self._niceness, self._sched_idle))
            except Exception as exc:  # noqa: BLE001 - the thread retries; the caller hears of it
                error = exc
            with self._lock:
                self._missing += count - len(started)
                self._retry_at = time.monotonic() + RESTART_BACKOFF
                rejected = [w for w in started if not self._adopt_locked(w)]
                if not self._closed:
                    self._thread = threading.Thread(target=self._run, name="ik-pool", daemon=True)
                    self._thread.start()
            for w in rejected:
                _stop(w)
            if error is not None:
                raise error

    def submit(self, job: IKJob, on_done: Callable[[IKOutcome], None]) -> None:
        """Queue `job`; `on_done(outcome)` follows exactly once, by `job.deadline + grace`."""
        if self._thread is None:
            self.warm_up()
        with self._lock:
            if self._closed:
                raise RuntimeError("the IK pool is shut down")
            self._stats.submitted += 1
            heapq.heappush(self._queue, (job.deadline, next(self._order), _Open(job, on_done)))
            self._dispatch_locked(time.monotonic())
            if self._outbox or self._next_wake_locked() < self._wake_at:
                self._poke_locked()

    def stats(self) -> IKPoolStats:
        """A copy of the pool's counts so far."""
        with self._lock:
            return replace(self._stats)

    def worker_pids(self) -> list[int]:
        """Process ids of the live workers."""
        with self._lock:
            return [w.process.pid for w in self._all]

    def shutdown(self) -> None:
        """Stop the workers (running solves are abandoned), answer every open job as timed out
        and join the pool's thread. Further `submit`s raise RuntimeError."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            open_jobs = [o for _, _, o in self._queue]
            self._queue.clear()
            open_jobs += [w.open for w in self._all if w.open is not None and not w.open.answered]
            for o in open_jobs:
                o.answered = True
            outbox, self._outbox = self._outbox, []
            workers = list(self._all)
            self._poke_locked()
        for w in workers:  # SIGTERM: a worker stops within its current numpy call
            w.process.terminate()
        thread = self._thread
        joined = thread is None or thread is not threading.current_thread()
        if thread is not None and joined:
            thread.join()
        for w in workers:
            _stop(w)
        if joined:  # (not from on_done in the pool's thread, which still reads the pipe)
            with self._lock:  # where _poke_locked writes: no write can reach a reused fd
                os.close(self._wake_r)
                os.close(self._wake_w)
                self._wake_w = -1
        _deliver(outbox)
        _deliver([(o, _failed("the node is shutting down")) for o in open_jobs])

    # ------------------------------------------------------------------ under the lock
    def _dispatch_locked(self, now: float) -> None:
        """Send queued jobs to idle workers, earliest deadline first; answer those whose deadline
        is too close to start a solve."""
        while self._queue and (self._idle or self._queue[0][0] - MIN_SOLVE_TIME <= now):
            item = heapq.heappop(self._queue)
            deadline, _, o = item
            if deadline - MIN_SOLVE_TIME <= now:
                self._stats.expired_in_queue += 1
                self._settle_locked(o, _timed_out("while the job waited for a free IK worker"))
                continue
            worker = self._idle.pop()
            if not self._send_locked(worker, o):
                heapq.heappush(self._queue, item)  # that worker is gone: try another

    def _send_locked(self, w: _Worker, o: _Open) -> bool:
        """Send `o` to the idle worker `w`; False when `w`'s pipe is broken (it died)."""
        job = o.job
        key = job.chain_key
        known = key in w.keys
        forget = None
        if not known and len(w.keys) >= _CHAINS_KEPT:
            forget = next(iter(w.keys))
        try:
            sent = replace(
                job, chain_blob=b"", deadline=_solve_until(job.deadline, time.monotonic())
            )
            message = pickle.dumps(
                (sent, None if known else job.chain_blob, forget), pickle.HIGHEST_PROTOCOL
            )
        except Exception as exc:  # noqa: BLE001 - every job must be answered
            self._settle_locked(o, _failed(f"the IK job cannot be sent to a worker: {exc!r}"))
            self._idle.append(w)
            return True
        try:
            w.conn.send_bytes(message)
        except OSError:
            return False  # not idle any more; the thread sees its pipe's end and replaces it
        if known:
            w.keys.move_to_end(key)
        else:
            if forget is not None:
                del w.keys[forget]
            w.keys[key] = None
            self._stats.chain_blobs_sent += 1
        w.open = o
        # never before the worker's own stop (plus WORKER_SLACK to hear from it)
        o.due = max(job.deadline + self._grace, sent.deadline + WORKER_SLACK)
        self._stats.sent += 1
        return True

    def _settle_locked(self, o: _Open, outcome: IKOutcome) -> None:
        """Decide `o`'s answer; the thread (or `shutdown`) calls `on_done` after the lock."""
        if not o.answered:
            o.answered = True
            self._outbox.append((o, outcome))

    def _answered_locked(self, w: _Worker, outcome: IKOutcome) -> None:
        o, w.open = w.open, None
        if o is None:
            return  # nothing was asked: ignore
        if o.answered:
            self._stats.late_outcomes += 1
        self._settle_locked(o, outcome)
        if w in self._all and not w.killed:
            self._idle.append(w)

    def _adopt_locked(self, w: _Worker) -> bool:
        if self._closed:
            return False
        self._all.append(w)
        self._idle.append(w)
        self._stats.workers_started += 1
        self._watch_locked()
        self._dispatch_locked(time.monotonic())
        return True

    def _bury_locked(self, w: _Worker) -> None:
        """`w` died (or was killed): answer its job as failed and have it replaced."""
        if w not in self._all:
            return
        self._all.remove(w)
        if w in self._idle:
            self._idle.remove(w)
        o, w.open = w.open, None
        if o is not None:
            code = w.process.exitcode
            how = f"exit code {code}" if code is not None else "its pipe closed"
            self._settle_locked(o, _failed(f"IK worker failed: its process ended ({how})"))
        self._stats.workers_lost += 1
        self._missing += 1
        self._watch_locked()

    def _watch_locked(self) -> None:
        owner: dict[Any, _Worker] = {}
        for w in self._all:
            owner[w.conn] = w
            owner[w.process.sentinel] = w
        self._owner = owner

    def _overdue_locked(self, now: float) -> list[_Worker]:
        """Answer running jobs past deadline + grace; return the workers to kill as hung."""
        hung = []
        for w in self._all:
            o = w.open
            if o is None or w.killed:
                continue
            if not o.answered and o.due <= now:
                self._stats.overdue += 1
                self._settle_locked(o, _timed_out("before its IK worker answered"))
            if o.job.deadline + HUNG_AFTER <= now:
                w.killed = True
                hung.append(w)
        return hung

    def _next_wake_locked(self) -> float:
        """When the thread must act next by itself (math.inf: only when a worker answers)."""
        t = self._queue[0][0] - MIN_SOLVE_TIME if self._queue else math.inf
        for w in self._all:
            o = w.open
            if o is not None and not w.killed:
                t = min(t, (o.job.deadline + HUNG_AFTER) if o.answered else o.due)
        if self._missing:
            t = min(t, self._retry_at)
        return t

    # ------------------------------------------------------------------ the pool's thread
    def _poke_locked(self) -> None:
        """Wake the pool's thread (a byte on its wake-up pipe)."""
        if self._wake_w < 0:
            return  # closed by shutdown
        try:
            os.write(self._wake_w, b"\0")
        except BlockingIOError:
            pass  # full: the thread has bytes to read anyway

    def _run(self) -> None:
        while True:
            try:
                if not self._step():
                    return
            except Exception:  # a bug here must not leave every later job unanswered
                _log.exception("IK pool thread")
                time.sleep(0.01)

    def _step(self) -> bool:
        """One turn of the pool's thread; False once the pool is shut down."""
        with self._lock:
            if self._closed:
                return False
            now = time.monotonic()
            self._dispatch_locked(now)  # expires queued jobs whose deadline is too close
            hung = self._overdue_locked(now)
            outbox, self._outbox = self._outbox, []
            restart = self._missing > 0 and self._retry_at <= now
            self._wake_at = wake_at = self._next_wake_locked()
            watched = [self._wake_r, *self._owner]
        for w in hung:
            _log.warning(
                "IK worker %d is %.1f s past its job's deadline: killing it",
                w.process.pid,
                HUNG_AFTER,
            )
            w.process.kill()  # its sentinel wakes this thread, which replaces it
        _deliver(outbox)
        if restart:
            self._restart_missing()
        if outbox or restart:
            return True  # time went by: look again before waiting
        timeout = None if wake_at == math.inf else max(0.0, wake_at - time.monotonic())
        self._take(wait(watched, timeout))
        return True

    def _take(self, ready: list[Any]) -> None:
        """Read what `wait` found ready: answers, ended workers, wake-up bytes."""
        answers: list[tuple[_Worker, IKOutcome]] = []
        ended: list[_Worker] = []
        for obj in ready:
            if obj == self._wake_r:
                try:
                    while os.read(self._wake_r, 4096):
                        pass
                except (BlockingIOError, OSError):
                    pass
                continue
            w = self._owner.get(obj)
            if w is None:
                continue
            if obj is w.conn:
                try:
                    message = w.conn.recv_bytes()
                except (EOFError, OSError):
                    ended.append(w)
                    continue
                try:
                    answers.append((w, pickle.loads(message)))
                except Exception as exc:  # noqa: BLE001
                    answers.append((w, _failed(f"unreadable answer from an IK worker: {exc!r}")))
            else:
                ended.append(w)
        if not answers and not ended:
            return
        with self._lock:
            for w, outcome in answers:
                self._answered_locked(w, outcome)
            for w in ended:
                self._bury_locked(w)
            self._dispatch_locked(time.monotonic())
            outbox, self._outbox = self._outbox, []
        _deliver(outbox)  # now, not on the next turn: an answer is due as soon as it is known
        for w in ended:
            _discard(w)

    def _restart_missing(self) -> None:
        """Start the missing workers (from this thread: a fork from the fork server takes a few
        ms; after a failure the next attempt waits RESTART_BACKOFF)."""
        while True:
            with self._lock:
                if self._closed or not self._missing:
                    return
                self._missing -= 1
            try:
                w = _start_worker(self._niceness, self._sched_idle)
            except Exception:
                _log.exception("cannot start an IK worker; trying again in %g s", RESTART_BACKOFF)
                with self._lock:
                    self._missing += 1
                    self._retry_at = time.monotonic() + RESTART_BACKOFF
                return
            with self._lock:
                adopted = self._adopt_locked(w)
            if not adopted:
                _stop(w)


def _solve_until(deadline: float, now: float) -> float:
    """The deadline a worker solves to: `ANSWER_MARGIN` before the job's, or less when little
    time is left (a 2 ms timeout still gets 1.6 ms of solve)."""
    return deadline - min(ANSWER_MARGIN, ANSWER_SHARE * max(deadline - now, 0.0))


def _start_worker(niceness: int, idle: bool) -> _Worker:
    ctx = multiprocessing.get_context("forkserver")
    # Workers fork from a server that has imported the core once, so each starts in ~10 ms.
    # "__main__" too: a worker otherwise re-imports the main script (the node's, with rclpy)
    # by itself; imported once in the server, the workers inherit it.
    ctx.set_forkserver_preload(
        ["__main__", "kinematics_node.core", "kinematics_node.service.ik_pool"]
    )
    ours, theirs = ctx.Pipe(duplex=True)
    process = ctx.Process(
        target=_serve, args=(theirs, niceness, idle), name="ik-worker", daemon=True
    )
    try:
        process.start()
    finally:
        theirs.close()  # the worker has its own copy: the pool sees EOF when the worker ends
    return _Worker(process, ours)


def _stop(w: _Worker) -> None:
    """End `w`'s process (if still running) and close the node's end of its pipe."""
    w.process.terminate()
    w.process.join(1.0)
    if w.process.exitcode is None:
        w.process.kill()
        w.process.join(1.0)
    w.conn.close()


def _discard(w: _Worker) -> None:
    """Forget an ended worker without waiting for it: the fork server reaps it."""
    if w.process.exitcode is None:
        w.process.kill()
    w.conn.close()


def _deliver(answers: list[tuple[_Open, IKOutcome]]) -> None:
    for o, outcome in answers:
        try:
            o.on_done(outcome)
        except Exception:
            _log.exception("an IK job's on_done raised")
