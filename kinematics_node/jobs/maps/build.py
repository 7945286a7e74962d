"""The map job: a reachability map of a chain, in chunks of voxels on the local cores or a Dask
cluster, written to its file chunk by chunk and resumable (`build_map`).

The grid (`core.workspace.VoxelGrid.around`) is split into chunks of `chunk_voxels` voxels in
grid order; each chunk is one task (`jobs.tasks.run_tasks`) that gets what a worker needs (the
URDF text, base and tip links, the chunk's centres and the orientations, the settings), builds
the chain once per process and returns the chunk's arrays (`solve_chunk`). Finished chunks go
into the HDF5 file as they come (`storage.MapWriter`), so memory holds a few chunks, not the map;
running the same job again keeps the chunks done and solves only the others. The numeric IK's
random restarts are seeded by the chunk's first target, so a chunk gives the same bits in any
process and the map the same from any run.
"""

from __future__ import annotations

import functools
import hashlib
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ...core import KinematicsError, SerialChain
from ...core.workspace import VoxelGrid, approach_rotations, reach_voxels
from ..tasks import run_tasks
from .reach_map import ReachMap
from .storage import MapFileError, MapHeader, MapWriter, chunk_ranges, h5py_module, write_npz

#: Voxels per chunk by default: UR5e, 50 orientations: ~100k IK problems, about a second.
CHUNK_VOXELS = 2048


class MapInterrupted(KinematicsError):
    """Ctrl-C during a map: the chunks done so far are kept in the file."""

    def __init__(self, kept: int, total: int, out: Path):
        self.kept, self.total, self.out = kept, total, out
        if out.suffix.lower() == ".npz":
            text = f"interrupted: nothing kept ({out} is written at the end; .h5 maps resume)"
        else:
            text = (
                f"interrupted: {kept} of {total} chunks kept in {out}; run the same command "
                "again to finish"
            )
        super().__init__(text)


@dataclass(frozen=True)
class MapRobot:
    """The chain to map: a name for the files, its URDF text and the base and tip links."""

    name: str
    urdf: str = field(repr=False)
    base_link: str
    tip_link: str

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.urdf.encode("utf-8")).hexdigest()

    def chain(self) -> SerialChain:
        return _chain(self.urdf, self.base_link, self.tip_link)

    @classmethod
    def from_text(
        cls, name: str, urdf: str, base_link: str | None = None, tip_link: str | None = None
    ) -> MapRobot:
        """A URDF's text; links default as `SerialChain.from_urdf`'s (the root, the one leaf).
        (A bundled robot: `sim.robots.robot_path` and `default_chain_links` give both.)

        Raises:
            RobotDescriptionError, UnknownNameError: what `SerialChain.from_urdf` raises.
        """
        from ...core.urdf import RobotDescription

        description = RobotDescription(urdf)
        spec = description.chain_spec(base_link, tip_link)
        return cls(name, urdf, spec.base_link, spec.tip_link)


@functools.lru_cache(maxsize=4)
def _chain(urdf: str, base_link: str, tip_link: str) -> SerialChain:
    """The chain, built once per process (a worker solves many chunks of one map)."""
    return SerialChain.from_urdf(urdf, base_link=base_link, tip_link=tip_link)


@dataclass(frozen=True)
class ChunkTask:
    """What a worker needs to solve one chunk."""

    chunk: int
    first_voxel: int
    robot: MapRobot
    centres: NDArray[np.float64] = field(repr=False)
    rotations: NDArray[np.float64] = field(repr=False)
    method: str = "auto"
    tolerance: float = 1e-9


@dataclass(frozen=True)
class ChunkResult:
    """One chunk's arrays: reached (m, K), solutions (m, K) int32, manipulability (m, K)."""

    chunk: int
    reached: NDArray[np.bool_] = field(repr=False)
    solutions: NDArray[np.int32] = field(repr=False)
    manipulability: NDArray[np.float64] = field(repr=False)
    method: str


def solve_chunk(task: ChunkTask) -> ChunkResult:
    """`reach_voxels` of one chunk (module docstring); runs in a worker process."""
    reach = reach_voxels(
        task.robot.chain(),
        task.centres,
        task.rotations,
        tolerance=task.tolerance,
        method=task.method,
        seed=task.first_voxel * len(task.rotations),
    )
    return ChunkResult(
        task.chunk,
        reach.reached,
        reach.solutions.astype(np.int32),
        reach.manipulability,
        reach.method,
    )


@dataclass(frozen=True)
class MapRun:
    """What `build_map` did: the map, its chunks (kept from before and solved now), the time."""

    reach_map: ReachMap
    out: Path
    chunks: int
    kept: int
    problems: int
    seconds: float


def build_map(
    robot: MapRobot,
    out: str | os.PathLike[str],
    resolution: float = 0.05,
    directions: int = 50,
    rolls: int = 1,
    *,
    scheduler: str | None = None,
    processes: int | None = None,
    chunk_voxels: int = CHUNK_VOXELS,
    method: str = "auto",
    tolerance: float = 1e-9,
    force: bool = False,
    progress: Callable[[int, int], None] | None = None,
    task: Callable[[ChunkTask], ChunkResult] = solve_chunk,
    connect_timeout_s: float = 10.0,
) -> MapRun:
    """The reachability map of `robot` into `out` (.h5, with a .npz beside it; or .npz alone).

    Args:
        out: `.h5` (h5py): written chunk by chunk, resumed when it exists with the same settings;
            a `.npz` of the same name is written beside it at the end. `.npz`: computed in
            memory and written at the end (no h5py needed, nothing to resume).
        resolution: voxel edge [m]; directions, rolls: orientations per voxel.
        scheduler: a Dask scheduler's address; None: the local cores (`processes` at most).
        chunk_voxels: voxels per task (part of the settings: a resumed file keeps its own).
        method, tolerance: as `reach_voxels`'s.
        force: start again over an existing file, whatever it holds.
        progress: called with (chunks done, chunks in all) as each chunk is in.
        task: the function each chunk runs (module-level, picklable; `solve_chunk`).
        connect_timeout_s: how long to try the scheduler [s].

    Raises:
        InvalidInputError: resolution, counts or method refused by the core.
        MapFileError: h5py missing for .h5, the file made otherwise (without `force`), or not
            writable.
        TaskError: Dask missing or the scheduler unreachable.
        MapInterrupted: Ctrl-C; the chunks done are kept in `out`.
    """
    path = Path(out)
    if path.suffix.lower() not in (".h5", ".hdf5", ".npz"):
        raise MapFileError(f"--out {path}: the map file must end in .h5 or .npz")
    if not path.parent.is_dir():
        raise MapFileError(f"--out {path}: the folder {path.parent} does not exist")
    if isinstance(chunk_voxels, bool) or not isinstance(chunk_voxels, int) or chunk_voxels < 1:
        raise MapFileError(f"chunk_voxels must be a whole number ≥ 1, got {chunk_voxels!r}")
    h5 = path.suffix.lower() != ".npz"
    if h5:
        h5py_module()
    chain = robot.chain()
    grid = VoxelGrid.around(chain, resolution)
    rotations = np.asarray(approach_rotations(directions, rolls))
    if method not in ("auto", "closed_form", "numeric"):
        raise MapFileError(f"method must be 'auto', 'closed_form' or 'numeric', got {method!r}")
    header = MapHeader(
        robot=robot.name,
        base_link=robot.base_link,
        tip_link=robot.tip_link,
        urdf_sha256=robot.sha256,
        resolution=float(grid.resolution),
        directions=int(directions),
        rolls=int(rolls),
        requested_method=method,
        tolerance=float(tolerance),
        chunk_voxels=int(chunk_voxels),
    )
    started = time.perf_counter()
    centres = np.asarray(grid.centres)
    if not h5:
        n = len(chunk_ranges(len(centres), chunk_voxels))
        try:
            reach_map = _in_memory(
                robot,
                header,
                centres,
                rotations,
                scheduler,
                processes,
                progress,
                task,
                connect_timeout_s,
            )
        except KeyboardInterrupt:
            raise MapInterrupted(0, n, path) from None
        write_npz(path, reach_map, header)
        problems = reach_map.reached.size
        return MapRun(reach_map, path, n, 0, problems, time.perf_counter() - started)
    with MapWriter.open(path, header, np.asarray(grid.indices), rotations, force) as writer:
        kept = int(writer.done.sum())
        todo = [
            ChunkTask(c, a, robot, centres[a:b], rotations, method, tolerance)
            for c, (a, b) in enumerate(writer.chunks)
            if not writer.done[c]
        ]
        total = len(writer.chunks)
        problems = sum(len(t.centres) for t in todo) * len(rotations)
        if progress is not None:
            progress(kept, total)
        try:
            for result in _results(task, todo, scheduler, processes, connect_timeout_s):
                writer.write_chunk(
                    result.chunk,
                    result.reached,
                    result.solutions,
                    result.manipulability,
                    result.method,
                )
                if progress is not None:
                    progress(int(writer.done.sum()), total)
        except KeyboardInterrupt:
            raise MapInterrupted(int(writer.done.sum()), total, path) from None
        writer.finish()
        reach_map = writer.read()
    write_npz(path.with_suffix(".npz"), reach_map, header)
    return MapRun(reach_map, path, total, kept, problems, time.perf_counter() - started)


def _results(
    task: Callable[[ChunkTask], ChunkResult],
    todo: list[ChunkTask],
    scheduler: str | None,
    processes: int | None,
    connect_timeout_s: float,
) -> Iterator[ChunkResult]:
    """Each chunk's result as it finishes; a chunk whose task failed stops the map with its
    error (the chunks in so far are kept)."""
    if not todo:
        return
    outcomes = run_tasks(
        task, todo, scheduler=scheduler, processes=processes, connect_timeout_s=connect_timeout_s
    )
    for outcome in outcomes:
        if isinstance(outcome.error, KeyboardInterrupt):  # Ctrl-C reached a worker first
            raise KeyboardInterrupt
        if outcome.error is not None:
            why = " ".join(str(outcome.error).split()) or type(outcome.error).__name__
            raise MapFileError(f"chunk {outcome.item.chunk} failed: {why}")
        yield outcome.result


def _in_memory(
    robot: MapRobot,
    header: MapHeader,
    centres: NDArray[np.float64],
    rotations: NDArray[np.float64],
    scheduler: str | None,
    processes: int | None,
    progress: Callable[[int, int], None] | None,
    task: Callable[[ChunkTask], ChunkResult],
    connect_timeout_s: float,
) -> ReachMap:
    M, K = len(centres), len(rotations)
    reached = np.zeros((M, K), dtype=bool)
    solutions = np.zeros((M, K), dtype=np.int64)
    manip = np.zeros((M, K))
    chunks = chunk_ranges(M, header.chunk_voxels)
    todo = [
        ChunkTask(c, a, robot, centres[a:b], rotations, header.requested_method, header.tolerance)
        for c, (a, b) in enumerate(chunks)
    ]
    methods = set()
    done = 0
    for result in _results(task, todo, scheduler, processes, connect_timeout_s):
        a, b = chunks[result.chunk]
        reached[a:b], solutions[a:b], manip[a:b] = (
            result.reached,
            result.solutions,
            result.manipulability,
        )
        methods.add(result.method)
        done += 1
        if progress is not None:
            progress(done, len(chunks))
    return ReachMap(
        robot=header.robot,
        base_link=header.base_link,
        tip_link=header.tip_link,
        resolution=header.resolution,
        directions=header.directions,
        rolls=header.rolls,
        centres=centres,
        rotations=rotations,
        reached=reached,
        solutions=solutions,
        manipulability=manip,
        method=methods.pop() if methods else header.requested_method,
    )
