"""A list of independent tasks, run on the local cores or, given a scheduler's address, on a Dask
distributed cluster (`dask scheduler` and `dask worker`s, started as Dask's documentation says).

`run_tasks(function, items)` calls `function(item)` for each item in processes of their own and
yields each outcome as it finishes. The same function runs either way, so the results are the
same; Dask's scheduler reruns the tasks of a worker that dies. No queue, socket or retry of our
own: the local way is `concurrent.futures`, the other `distributed.Client.map` and `as_completed`.

Dask is an optional extra (`pip install 'kinematics_service[dask]'`), needed only with a
scheduler's address. Both offline jobs use it: many recordings (`jobs.recordings`) and the chunks
of a workspace map (`jobs.maps`).
"""

from __future__ import annotations

import ctypes
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from functools import cache, partial
from typing import Any, Generic, TypeVar

from ..core import KinematicsError

INSTALL = "pip install 'kinematics_service[dask]'"

Item = TypeVar("Item")


class TaskError(KinematicsError):
    """The tasks could not be run at all (no Dask, an unreachable scheduler), said in one line."""


@dataclass(frozen=True)
class Outcome(Generic[Item]):
    """One task's end: its item, and its result or the error it raised."""

    item: Item
    result: Any = None
    error: BaseException | None = None


#: glibc's mallopt parameters, and what `_batch_friendly_malloc` sets them to [bytes].
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
TRIM_THRESHOLD, MMAP_THRESHOLD = 64 << 20, 32 << 20


def _in_worker(function: Callable[[Item], Any], item: Item) -> Any:
    """`function(item)` in a worker process, its allocator first made fit for batches."""
    _batch_friendly_malloc()
    return function(item)


@cache
def _batch_friendly_malloc() -> None:
    """Undo, in a Dask worker, the nanny's MALLOC_TRIM_THRESHOLD_ (65536 by default).

    Setting that variable freezes glibc's mmap threshold at 128 KiB, so every array of a batch
    larger than that is mapped afresh and its pages faulted in on each use: a UR5e map's chunk
    took 928k page faults instead of 7.6k and ran at half the speed (`kinematics reach` on one
    Dask worker: 38.9 s, the same map in one local process 19.9 s; with the thresholds below,
    which are glibc's own upper bounds for its dynamic threshold, 19.9 s on the worker too).
    Elsewhere (no such variable, or not glibc) nothing changes.
    """
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ:
        return
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):
        return
    mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)


def run_tasks(
    function: Callable[[Item], Any],
    items: Sequence[Item],
    scheduler: str | None = None,
    processes: int | None = None,
    connect_timeout_s: float = 10.0,
) -> Iterator[Outcome[Item]]:
    """`function(item)` for every item, as each finishes (in no set order).

    Args:
        function: a module-level function (it is pickled to the processes or workers).
        scheduler: a Dask scheduler's address (e.g. ``tcp://10.0.0.5:8786``); None: the local
            cores, one process each (at most `processes`, default: the cores).
        connect_timeout_s: how long to try the scheduler [s].

    Raises:
        TaskError: Dask is not installed, or the scheduler cannot be reached.
    """
    if scheduler is None:
        yield from _local(function, items, processes or os.cpu_count() or 1)
    else:
        yield from _dask(function, items, scheduler, connect_timeout_s)


def _local(
    function: Callable[[Item], Any], items: Sequence[Item], processes: int
) -> Iterator[Outcome[Item]]:
    with ProcessPoolExecutor(
        max_workers=max(1, min(processes, len(items))),
        initializer=_exit_with_parent,
        initargs=(os.getpid(),),
    ) as pool:
        futures = {pool.submit(_in_worker, function, item): item for item in items}
        try:
            for future in as_completed(futures):
                item = futures[future]
                error = future.exception()
                yield Outcome(item, None if error else future.result(), error)
        except BaseException:
            # Ctrl-C, or the caller stopped early: the tasks not yet started never start (the
            # pool's exit would otherwise run every one of them first); the running ones finish
            # and their processes end before this returns (they hold the caller's files open)
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _exit_with_parent(parent: int) -> None:
    """In each local worker: end when the process that started it is gone (killed hard, it
    cannot tell its pool to stop, and the workers would wait for tasks forever)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _dask(
    function: Callable[[Item], Any], items: Sequence[Item], scheduler: str, timeout: float
) -> Iterator[Outcome[Item]]:
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise TaskError(f"--scheduler needs Dask distributed: {INSTALL}") from None
    try:
        client = Client(scheduler, timeout=f"{timeout}s")
    except (OSError, TimeoutError, ValueError) as exc:
        why = " ".join(str(exc).split()) or type(exc).__name__
        raise TaskError(f"cannot reach the Dask scheduler at {scheduler}: {why}") from None
    try:
        futures = client.map(partial(_in_worker, function), list(items), pure=False)
        owner = {f.key: item for f, item in zip(futures, items, strict=True)}
        for future in dask_completed(futures):
            item = owner[future.key]
            try:
                yield Outcome(item, future.result())
            except Exception as exc:  # the task's own error, raised again here by Dask
                yield Outcome(item, None, exc)
    finally:
        client.close()
