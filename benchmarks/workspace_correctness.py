"""Are a reachability map's numbers right? Issue #34's three checks, per arm, as a table.

    python benchmarks/workspace_correctness.py [--arms ur5e:0.05,panda:0.1] [--directions 50]
        [--unreached 2000] [--restarts 50] [--samples 1000000] [--held 36] [--seed 0]

For each arm (bundled robot name : resolution [m]) the map of `reach_voxels` over
`VoxelGrid.around(chain, resolution)` and `approach_rotations(directions)` is built, then:

(a) every (voxel, orientation) counted as reached has its solution q within the limits, and FK(q)
    reproduces the target to 1e-9 m and 1e-9 rad (all of them are checked);
(b) `--unreached` (voxel, orientation) pairs drawn at random among those counted unreachable are
    given to the numeric IK (`ik_batch`, method "numeric", `--restarts` random restarts, tolerance
    1e-9 as the map's): the share it solves must be <= 0.5 %. Each one it solves is explained: for
    a 7R arm, whether the closed form finds it with the held joint at the numeric solution's value
    (a pose between the swept values: the sweep is too coarse) or not (a closed-form miss);
(c) `--samples` random configurations within the limits: every voxel their tool positions land in
    should have D > 0. Those with D = 0 are split into voxels whose centre no configuration reaches
    (boundary voxels: position-only numeric IK with `--restarts` restarts fails; allowed, <= 0.5 %
    of the voxels hit) and voxels whose centre is reached in some orientation but in none of the
    map's (the orientation sampling's miss: stated).

`--held N` sets the 7R arms' sweep (N values across the held joint's limits; 36 is
`reach_voxels`' default). Figures go to docs/performance.md ("Workspace maps").
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kinematics_node.core import IKOptions, SerialChain  # noqa: E402
from kinematics_node.core.ik.closed_form import branches_within_limits, family_of  # noqa: E402
from kinematics_node.core.workspace import (  # noqa: E402
    VoxelGrid,
    VoxelReach,
    approach_rotations,
    reach_voxels,
)
from kinematics_node.core.workspace.reachability import targets  # noqa: E402
from kinematics_node.sim.robots import load_robot  # noqa: E402

#: The map's tolerance, and the checks' [m, rad].
TOLERANCE = 1e-9


@dataclass
class Figures:
    """The three checks' counts for one map."""

    voxels: int
    orientations: int
    reached: int
    seconds: float
    # (a)
    worst_position: float
    worst_rotation: float
    outside_limits: int
    # (b)
    unreached_tried: int
    numeric_found: int
    between_held_values: int
    # (c)
    samples: int
    voxels_hit: int
    hit_with_d0: int
    hit_d0_centre_out_of_reach: int
    hit_d0_other_orientation: int
    samples_in_d0: int


def pose_errors(chain: SerialChain, q: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] and rotation-angle [rad] gaps of FK(q) from the targets T."""
    F = chain.fk(q)
    ep = np.linalg.norm(F[:, :3, 3] - T[:, :3, 3], axis=1)
    R = F[:, :3, :3].swapaxes(1, 2) @ T[:, :3, :3]
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    # the angle from the skew part where it is small (arccos loses half the digits near 1)
    skew = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], 1)
    er = np.arctan2(np.linalg.norm(skew, axis=1) / 2.0, cos)
    return ep, er


def check_reached(chain: SerialChain, reach: VoxelReach, T: np.ndarray) -> tuple[float, float, int]:
    """(a): (worst position gap, worst rotation gap, solutions outside the limits)."""
    n = chain.dof
    hit = np.flatnonzero(reach.reached.reshape(-1))
    q = reach.q.reshape(-1, n)[hit]
    worst_p = worst_r = 0.0
    for part in np.array_split(np.arange(hit.size), max(1, hit.size // 100_000)):
        if not part.size:
            continue
        ep, er = pose_errors(chain, q[part], T[hit[part]])
        worst_p, worst_r = max(worst_p, float(ep.max())), max(worst_r, float(er.max()))
    outside = int(np.sum(np.any((q < chain.lower) | (q > chain.upper), axis=1)))
    return worst_p, worst_r, outside


def numeric_options(restarts: int, seed: int, position_only: bool = False) -> IKOptions:
    return IKOptions(
        position_tolerance=TOLERANCE,
        orientation_tolerance=TOLERANCE,
        timeout=60.0,
        batch_timeout=1e6,
        max_restarts=restarts,
        rng_seed=seed,
        method="numeric",
        position_only=position_only,
    )


def check_unreached(
    chain: SerialChain,
    reach: VoxelReach,
    T: np.ndarray,
    count: int,
    restarts: int,
    rng: np.random.Generator,
    held: np.ndarray | None,
) -> tuple[int, int, int, np.ndarray, np.ndarray]:
    """(b): (tried, solved by the numeric IK, of those found by the closed form at the numeric
    solution's held value, the targets solved, their solutions)."""
    missed = np.flatnonzero(~reach.reached.reshape(-1))
    pick = rng.choice(missed, size=min(count, missed.size), replace=False)
    result = chain.ik_batch(T[pick], options=numeric_options(restarts, int(rng.integers(1 << 31))))
    ok = np.asarray(result.success)
    q = np.asarray(result.q)[ok]
    found = pick[ok]
    # a numeric "solution" must be one: within the limits, reproducing the target to 1e-9
    ep, er = pose_errors(chain, q, T[found]) if found.size else (np.zeros(0), np.zeros(0))
    assert np.all(ep <= TOLERANCE) and np.all(er <= TOLERANCE)
    between = 0
    family = family_of(chain)
    if found.size and family is not None and family.held_joint is not None:
        j = chain.joint_names.index(family.held_joint)
        for t, qi in zip(found, q, strict=True):
            b = branches_within_limits(chain, T[t : t + 1], held=[qi[j]], tolerance=TOLERANCE)
            between += int(b.target.size > 0)
    return int(pick.size), int(found.size), between, found, q


def check_sampled(
    chain: SerialChain,
    grid: VoxelGrid,
    reach: VoxelReach,
    samples: int,
    restarts: int,
    rng: np.random.Generator,
    held: np.ndarray | None,
) -> tuple[int, int, int, int, int, np.ndarray]:
    """(c): (voxels hit, of those with D = 0, of those whose centre no configuration reaches
    (position-only numeric IK), of the others those whose centre the map's own solver reaches in
    the orientation the numeric IK found, samples that landed in D = 0 voxels, rows of the D = 0
    voxels hit whose centre is reached)."""
    lo = grid.indices.min(axis=0)
    shape = grid.indices.max(axis=0) - lo + 1
    row_of = np.full(tuple(shape), -1, dtype=np.int64)
    row_of[tuple((grid.indices - lo).T)] = np.arange(len(grid))
    hits = np.zeros(len(grid), dtype=np.int64)
    lower = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    for start in range(0, samples, 100_000):
        q = rng.uniform(lower, upper, size=(min(100_000, samples - start), chain.dof))
        p = chain.fk(q)[:, :3, 3]
        k = np.floor(p / grid.resolution + 0.5).astype(np.int64) - lo
        inside = np.all((k >= 0) & (k < shape), axis=1)
        rows = row_of[tuple(k[inside].T)]
        assert inside.all() and np.all(rows >= 0), "a tool position outside the grid"
        np.add.at(hits, rows, 1)
    hit = hits > 0
    d0 = np.flatnonzero(hit & (reach.index == 0.0))
    in_reach = np.zeros(d0.size, dtype=bool)
    other_orientation = 0
    if d0.size:
        T = np.tile(np.eye(4), (d0.size, 1, 1))
        T[:, :3, 3] = grid.centres[d0]
        options = numeric_options(restarts, int(rng.integers(1 << 31)), position_only=True)
        result = chain.ik_batch(T, options=options)
        in_reach = np.asarray(result.success)
        if in_reach.any():
            # the orientation the numeric IK reached the centre in: does the map's own solver
            # reach it there? (then D = 0 only because no sampled orientation is reachable)
            R = chain.fk(np.asarray(result.q)[in_reach])[:, :3, :3]
            for centre, Rk in zip(grid.centres[d0[in_reach]], R, strict=True):
                other = reach_voxels(chain, centre[None], Rk[None], held=held, restarts=restarts)
                other_orientation += int(other.reached.any())
    return (
        int(hit.sum()),
        int(d0.size),
        int((~in_reach).sum()),
        other_orientation,
        int(hits[d0].sum()),
        d0[in_reach],
    )


def held_values(chain: SerialChain, count: int | None) -> np.ndarray | None:
    family = family_of(chain)
    if count is None or family is None or family.held_joint is None:
        return None
    j = chain.joint_names.index(family.held_joint)
    return np.linspace(chain.lower[j], chain.upper[j], count)


def run(
    robot: str,
    resolution: float,
    directions: int,
    unreached: int,
    restarts: int,
    samples: int,
    held_count: int | None,
    seed: int,
    verbose: bool = True,
) -> Figures:
    chain = load_robot(robot)
    grid = VoxelGrid.around(chain, resolution)
    R = approach_rotations(directions)
    held = held_values(chain, held_count)
    start = time.perf_counter()
    reach = reach_voxels(chain, grid.centres, R, held=held)
    seconds = time.perf_counter() - start
    T = targets(grid.centres, R)
    rng = np.random.default_rng(seed)
    worst_p, worst_r, outside = check_reached(chain, reach, T)
    tried, found, between, found_at, q_found = check_unreached(
        chain, reach, T, unreached, restarts, rng, held
    )
    if verbose and found:
        print(f"# {robot}: the numeric IK solved {found} targets counted unreachable:")
        K = len(R)
        for t, q in list(zip(found_at, q_found, strict=True))[:10]:
            J = chain.jacobian(q)
            s = np.linalg.svd(J, compute_uv=False)
            margin = np.minimum(q - chain.lower, chain.upper - q).min()
            print(
                f"#   voxel {t // K} {np.round(grid.centres[t // K], 3).tolist()} orientation "
                f"{t % K}: q={np.round(q, 4).tolist()} sigma_min={s[-1]:.2e} "
                f"limit margin={margin:.2e} rad"
            )
    hit, d0, out_of_reach, other_orientation, d0_samples, d0_in_reach = check_sampled(
        chain, grid, reach, samples, restarts, rng, held
    )
    if verbose and d0_in_reach.size:
        print(
            f"# {robot}: {d0_in_reach.size} voxels hit with D = 0 whose centre is in reach, e.g. "
            f"{np.round(grid.centres[d0_in_reach[:3]], 3).tolist()}"
        )
    return Figures(
        len(grid),
        len(R),
        int(reach.reached.sum()),
        seconds,
        worst_p,
        worst_r,
        outside,
        tried,
        found,
        between,
        samples,
        hit,
        d0,
        out_of_reach,
        other_orientation,
        d0_samples,
    )


def table(rows: list[tuple[str, float, int | None, Figures]]) -> str:
    head = (
        "| arm | resolution | voxels x orientations | map [s] | (a) worst FK gap [m / rad], "
        "outside limits | (b) unreached solved by numeric IK | (c) voxels hit by FK samples "
        "with D = 0: centre out of reach / in reach (in another orientation by the map's own "
        "solver); samples in them |\n|---|---|---|---|---|---|---|"
    )
    lines = [head]
    for robot, res, held, f in rows:
        name = robot if held is None else f"{robot} ({held} held values)"
        in_reach = f.hit_with_d0 - f.hit_d0_centre_out_of_reach
        share_b = 100.0 * f.numeric_found / max(f.unreached_tried, 1)
        extra = f" ({f.between_held_values} between held values)" if held is not None else ""
        lines.append(
            f"| {name} | {res * 100:g} cm | {f.voxels:,} x {f.orientations} "
            f"({f.reached:,} reached) | {f.seconds:.1f} | {f.worst_position:.1e} / "
            f"{f.worst_rotation:.1e}, {f.outside_limits} | {f.numeric_found}/{f.unreached_tried} "
            f"= {share_b:.2f} %{extra} | {f.hit_with_d0} of {f.voxels_hit:,} "
            f"({100.0 * f.hit_with_d0 / max(f.voxels_hit, 1):.2f} %): "
            f"{f.hit_d0_centre_out_of_reach} / {in_reach} ({f.hit_d0_other_orientation}); "
            f"{f.samples_in_d0:,} of {f.samples:,} ({100.0 * f.samples_in_d0 / f.samples:.3f} %) |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--arms", default="ur5e:0.05,panda:0.1", help="robot:resolution[m],...")
    ap.add_argument("--directions", type=int, default=50)
    ap.add_argument("--unreached", type=int, default=2000)
    ap.add_argument("--restarts", type=int, default=50)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument(
        "--held", default="36", help="7R arms' held values, comma-separated counts (36,72)"
    )
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rows = []
    for item in args.arms.split(","):
        robot, res = item.split(":")
        counts: list[int | None] = [None]
        if family_of(load_robot(robot)) is not None and family_of(load_robot(robot)).held_joint:
            counts = [int(h) for h in args.held.split(",")]
        for held in counts:
            f = run(
                robot,
                float(res),
                args.directions,
                args.unreached,
                args.restarts,
                args.samples,
                held,
                args.seed,
            )
            rows.append((robot, float(res), held, f))
            print(table(rows[-1:]).splitlines()[-1], flush=True)
    print()
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
