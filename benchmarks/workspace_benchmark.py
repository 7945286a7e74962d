"""How fast is a reachability map? `reach_voxels` on whole grids, one core, beside FK sampling and
the anchors' published figures, in one run.

    python benchmarks/workspace_benchmark.py [--maps ur5e:0.05,ur5e:0.025,panda:0.05]
        [--directions 50] [--chunk 2000] [--ab ur5e:0.05] [--samples 1000000] [--voxels N]

For each map (bundled robot : resolution [m]): `VoxelGrid.around` and `approach_rotations`, then
`reach_voxels` over the grid in chunks of `--chunk` voxels, one after the other in this process
(one core: the map job runs such chunks on several cores or a Dask cluster; timed in CPU
seconds of this process, which a shared machine's other work does not inflate as it does the
wall-clock time, printed beside), keeping per voxel
only what a map file keeps (D, best manipulability, solution count), so memory stays at a chunk's.
`--voxels N` times a random N of the grid's voxels instead and extrapolates to the whole grid
(said so in the table). Reported: voxels, IK problems (voxels x orientations), seconds, IK problems
per second, and the mean reachability index D (for FK sampling: the share of voxels hit).

`--ab MAP` times that map again with the manipulability of every solution taken as before
(`analysis.manipulability`: an SVD of each Jacobian) instead of `analysis.manipulability_det`,
in the same run, so the ratio is measured under the same load.

FK sampling (scikit-robot's `ReachabilityMap` way: random configurations binned into voxels, here
`--samples` of them into the first map's grid) is timed for comparison: cheap, but it says which
voxels some configuration reaches, not in which orientations, and misses what it does not sample.

The anchors' figures are quoted from their own reports (issue #34), not measured here.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core: no BLAS threads (before numpy is imported)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kinematics_node.core.analysis import manipulability  # noqa: E402
from kinematics_node.core.workspace import (  # noqa: E402
    VoxelGrid,
    approach_rotations,
    reach_voxels,
    reachability,
)
from kinematics_node.sim.robots import load_robot  # noqa: E402

#: The anchors' published figures (issue #34's text), for the table.
ANCHORS = [
    ("Reuleaux (ROS 1, IKFast)", "finer than 5 cm", "hours, or the system stops responding (#19)"),
    ("reuleaux_moveit", "2.5 cm, Kinova arm", "~100 days on 1 core; 14 h on 20 cores"),
    ("capability_map", "2.5 cm, PR2 arm, 200 directions", "3 h 07 min"),
    ("sampled_reachability_maps", "2.5 cm, UR5e, IK-based", "~800 h (estimate)"),
]


@dataclass
class Timing:
    name: str
    voxels: int
    problems: int
    seconds: float
    cpu: float
    reached: float
    extrapolated: bool = False

    @property
    def rate(self) -> float:
        """IK problems per CPU second (one core's rate, whatever else the machine runs)."""
        return self.problems / self.cpu


def time_map(
    robot: str,
    resolution: float,
    directions: int,
    chunk: int,
    voxels: int | None,
    seed: int,
    label: str = "",
) -> Timing:
    chain = load_robot(robot)
    grid = VoxelGrid.around(chain, resolution)
    R = approach_rotations(directions)
    centres = grid.centres
    if voxels is not None and voxels < len(grid):
        pick = np.sort(np.random.default_rng(seed).choice(len(grid), voxels, replace=False))
        centres = centres[pick]
    reach_voxels(chain, centres[:2], R)  # the family's detection and first calls, untimed
    index = np.empty(len(centres))
    best = np.empty(len(centres))
    count = np.empty(len(centres), dtype=np.int64)
    start, cpu = time.perf_counter(), time.process_time()
    for i in range(0, len(centres), chunk):
        part = reach_voxels(chain, centres[i : i + chunk], R)
        index[i : i + chunk] = part.index
        best[i : i + chunk] = part.best_manipulability
        count[i : i + chunk] = part.solution_count
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    reached = float(index.mean() / 100.0)
    scale = len(grid) / len(centres)
    name = f"{robot} {resolution * 100:g} cm x {directions}{label}"
    return Timing(
        name,
        len(grid),
        len(grid) * len(R),
        seconds * scale,
        cpu * scale,
        reached,
        extrapolated=scale > 1,
    )


def time_fk_sampling(robot: str, resolution: float, samples: int, seed: int) -> Timing:
    """Random configurations' tool positions binned into the grid's voxels (which are hit)."""
    chain = load_robot(robot)
    grid = VoxelGrid.around(chain, resolution)
    rng = np.random.default_rng(seed)
    lower = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    lo = grid.indices.min(axis=0)
    shape = grid.indices.max(axis=0) - lo + 1
    start, cpu = time.perf_counter(), time.process_time()
    hits = np.zeros(tuple(shape), dtype=np.int64)
    for i in range(0, samples, 100_000):
        q = rng.uniform(lower, upper, size=(min(100_000, samples - i), chain.dof))
        k = np.floor(chain.fk(q)[:, :3, 3] / resolution + 0.5).astype(np.int64) - lo
        np.add.at(hits, tuple(k.T), 1)
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    hit = hits[tuple((grid.indices - lo).T)] > 0
    name = f"{robot} {resolution * 100:g} cm, FK sampling ({samples:,} configurations)"
    return Timing(name, len(grid), samples, seconds, cpu, float(hit.mean()))


def _svd_manipulability(J: np.ndarray) -> np.ndarray:
    return manipulability(J)


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def table(rows: list[Timing], reference: Timing | None) -> str:
    lines = [
        "| map (one core) | voxels | IK problems | CPU time | wall | IK problems/s (CPU) | "
        "mean D (FK: voxels hit) | vs first (CPU) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for t in rows:
        cpu, wall = _duration(t.cpu), _duration(t.seconds)
        if t.extrapolated:
            cpu += " (extrapolated)"
        ratio = "" if reference is None else f"{t.cpu / reference.cpu:.2f}x"
        lines.append(
            f"| {t.name} | {t.voxels:,} | {t.problems:,} | {cpu} | {wall} | {t.rate:,.0f} | "
            f"{100 * t.reached:.1f} % | {ratio} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maps", default="ur5e:0.05,ur5e:0.025,panda:0.05")
    ap.add_argument("--directions", type=int, default=50)
    ap.add_argument("--chunk", type=int, default=2000, help="voxels per reach_voxels call")
    ap.add_argument("--ab", default="ur5e:0.05", help="map timed with the SVD too ('' for none)")
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--voxels", type=int, default=None, help="time N random voxels per map")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    print(f"# {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start")
    rows: list[Timing] = []
    maps = [(m.split(":")[0], float(m.split(":")[1])) for m in args.maps.split(",") if m]
    ab = tuple(args.ab.split(":")) if args.ab else None
    for robot, res in maps:
        rows.append(time_map(robot, res, args.directions, args.chunk, args.voxels, args.seed))
        print(table(rows[-1:], None).splitlines()[-1], flush=True)
        if ab is not None and (robot, res) == (ab[0], float(ab[1])):
            fast = reachability.manipulability_det
            reachability.manipulability_det = _svd_manipulability  # type: ignore[assignment]
            try:
                label = ", manipulability by SVD (before)"
                t = time_map(robot, res, args.directions, args.chunk, args.voxels, args.seed, label)
            finally:
                reachability.manipulability_det = fast  # type: ignore[assignment]
            rows.append(t)
            print(table(rows[-1:], None).splitlines()[-1], flush=True)
    if maps:
        robot, res = maps[0]
        rows.append(time_fk_sampling(robot, res, args.samples, args.seed))
        print(table(rows[-1:], None).splitlines()[-1], flush=True)
    print(f"\n# load average {os.getloadavg()[0]:.1f} at the end\n")
    print(table(rows, rows[0] if rows else None))
    print("\n| anchor (published, not measured here) | map | time |\n|---|---|---|")
    for name, what, when in ANCHORS:
        print(f"| {name} | {what} | {when} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
