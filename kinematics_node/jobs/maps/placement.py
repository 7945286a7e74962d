"""Base placement from a reachability map: where on the floor to put the robot so that it reaches
the task poses (`kinematics place`).

The relation is Reuleaux's inverse reachability: a base pose B reaches a task pose T (both in the
world frame) when the map holds the tool pose B⁻¹·T (in the base frame). Reuleaux turns it round:
for every task it scatters T·P⁻¹ over every reachable map pose P, votes the base poses found into
spheres, and takes the spheres with the most votes. Here the base stands on the floor (upright,
z = 0), a 3-parameter family (x, y, yaw), and T·P⁻¹ is almost never upright or at z = 0, so the
same relation is evaluated the other way round, exactly on that family: every floor placement of a
grid (x, y at whole multiples of the map's resolution, `yaw_steps` yaws) looks each task up in the
map.

* Position: the map's voxel that holds the position of B⁻¹·T (off its centre by at most
  resolution·√3/2).
* Orientation: the map orientation nearest to B⁻¹·T's rotation: first the nearest approach
  direction (tool z axis; with D directions neighbours are about √(4π/D) rad apart, 29° for
  Reuleaux's 50), then among that direction's rolls the nearest about it. A map with one roll
  says nothing about the roll about the approach: it stands for every roll, which is right for
  arms whose last joint turns the tool about z over a full turn (UR, most 6R arms) and is checked
  by the verification below everywhere else. The nearest orientation alone decides (not the union
  of the nearest few): the union counts a pose as reached when the map reaches it only up to two
  spacings away, which overestimates near the edge of the reachable orientations, and every
  estimate is verified by IK anyway.

A placement's map score is the number of tasks the map says it reaches, ties broken by the summed
reachability index D of their voxels (how many orientations the arm has there: room for the
estimate's error), then by their summed manipulability. The best `verify` placements by map score
are verified by IK on the task poses themselves (`verify_placements`: closed form where the chain
has a family, every branch within the limits; numeric batch IK elsewhere) and ranked again: by the
verified count, then the map score.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...core.exceptions import InvalidInputError, KinematicsError
from ...core.rotations import matrix_from_quaternion
from ...core.workspace import reach_targets
from .reach_map import ReachMap

if TYPE_CHECKING:
    from ...core.chain import SerialChain

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: A task pose counts as verified when IK reproduces it to this [m, rad] within the limits.
VERIFY_TOLERANCE = 1e-6
#: Task lookups per pass of the scoring (bounds the working arrays to some tens of MB).
LOOKUPS_PER_PASS = 2_000_000
#: Yaws of one position verified at most (the best by the map).
YAWS_VERIFIED = 3
#: Share of the map's reached poses the verifying chain must reach (`check_map_matches`).
MATCH_SHARE = 0.9


class PlacementError(KinematicsError):
    """A problem with the task poses or the map (one line: `kinematics place` prints it)."""


@dataclass(frozen=True)
class Placement:
    """One floor placement of the base: position (x, y) [m], yaw [rad] about the world z axis,
    z = 0, upright.

    Attributes:
        map_reached: tasks the map says it reaches (nearest voxel and orientation).
        map_index: summed reachability index D [%] of those tasks' voxels.
        map_manipulability: summed manipulability of those (voxel, orientation) entries.
        verified: tasks IK reaches from it (None: not verified).
        verified_manipulability: summed best manipulability of the verified solutions.
        reached: (T,) per task: the map's answer, or IK's where verified.
    """

    x: float
    y: float
    yaw: float
    map_reached: int
    map_index: float
    map_manipulability: float
    verified: int | None = None
    verified_manipulability: float = 0.0
    reached: BoolArray = field(default_factory=lambda: np.zeros(0, dtype=bool), repr=False)

    @property
    def T_world_base(self) -> FloatArray:
        """(4, 4) the base's pose in the world."""
        return floor_pose(self.x, self.y, self.yaw)


@dataclass(frozen=True)
class PlacementResult:
    """The ranking of `place_base`: `placements` best first (the verified ones first, by verified
    count; then the rest by map score), `candidates` floor placements scored by the map, `seconds` spent,
    `orientation_spacing` [rad] between neighbouring approach directions of the map, and why
    nothing was verified (`unverified_reason`, "" when verified)."""

    placements: tuple[Placement, ...]
    tasks: int
    candidates: int
    seconds: float
    orientation_spacing: float
    unverified_reason: str = ""

    def report(self, top: int | None = None) -> str:
        """The ranking as text, best first, one line each (x, y, yaw, tasks reached)."""
        shown = self.placements if top is None else self.placements[:top]
        verified = any(p.verified is not None for p in shown)
        lines = [
            f"{self.candidates} floor placements scored against {self.tasks} task poses in "
            f"{self.seconds:.2f} s (map orientations {math.degrees(self.orientation_spacing):.0f}"
            "° apart)",
            "rank       x [m]     y [m]  yaw [deg]  reached "
            + ("(verified by IK / map estimate)" if verified else "(map estimate)"),
        ]
        for rank, p in enumerate(shown, 1):
            count = (
                f"{p.verified}/{self.tasks} verified, {p.map_reached}/{self.tasks} map"
                if p.verified is not None
                else f"{p.map_reached}/{self.tasks} map"
            )
            lines.append(f"{rank:4d}  {p.x:10.3f}{p.y:10.3f}{math.degrees(p.yaw):11.1f}  {count}")
        if not shown:
            lines.append("   (no floor placement reaches any task pose, by the map)")
        if self.unverified_reason:
            lines.append(f"not verified: {self.unverified_reason}")
        return "\n".join(lines)

    def as_dict(self, top: int | None = None) -> dict[str, object]:
        """The ranking as plain data (JSON)."""
        shown = self.placements if top is None else self.placements[:top]
        return {
            "tasks": self.tasks,
            "candidates": self.candidates,
            "seconds": self.seconds,
            "orientation_spacing_deg": math.degrees(self.orientation_spacing),
            "unverified_reason": self.unverified_reason or None,
            "placements": [
                {
                    "rank": rank,
                    "x": p.x,
                    "y": p.y,
                    "yaw": p.yaw,
                    "yaw_deg": math.degrees(p.yaw),
                    "map_reached": p.map_reached,
                    "map_index_sum": p.map_index,
                    "verified": p.verified,
                    "reached": [bool(r) for r in p.reached],
                }
                for rank, p in enumerate(shown, 1)
            ],
        }


def floor_pose(x: float, y: float, yaw: float) -> FloatArray:
    """(4, 4) T_world_base of a base at (x, y, 0) turned by `yaw` [rad] about the world z axis."""
    c, s = math.cos(yaw), math.sin(yaw)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[0, 3], T[1, 3] = x, y
    return T


# ---------------------------------------------------------------------- task poses
def read_tasks(path: str | Path) -> FloatArray:
    """(T, 4, 4) task poses of a CSV file: one pose a line, x, y, z [m], qx, qy, qz, qw (the
    world frame; the quaternion is normalised, as `kinematics ik --target` does). A first line
    that is not numbers is a header; blank lines and lines starting with # are skipped.

    Raises:
        PlacementError: the file cannot be read, holds no pose, or a line is not 7 finite numbers
            with a non-zero quaternion (the message names the line).
    """
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise PlacementError(f"cannot read task poses {str(path)!r}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise PlacementError(f"task poses {str(path)!r}: not a text (UTF-8 CSV) file") from None
    return tasks_from_lines(text.splitlines(), str(path))


def tasks_from_lines(lines: Iterable[str], source: str = "tasks") -> FloatArray:
    """`read_tasks` of lines of text (`source` names them in errors)."""
    poses = []
    first = True
    for number, line in enumerate(lines, 1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        items = [item.strip() for item in stripped.replace(";", ",").split(",")]
        if len(items) == 1:
            items = stripped.split()
        try:
            values = [float(item) for item in items]
        except ValueError:
            if first and not any(_is_number(item) for item in items):
                first = False
                continue  # a header
            raise PlacementError(
                f"{source}, line {number}: {_short(stripped)} is not 7 numbers x,y,z,qx,qy,qz,qw"
            ) from None
        first = False
        if len(values) != 7:
            raise PlacementError(
                f"{source}, line {number}: {len(values)} values, expected 7: x,y,z,qx,qy,qz,qw"
            )
        if not all(math.isfinite(v) for v in values):
            raise PlacementError(f"{source}, line {number}: every value must be finite")
        if math.hypot(*values[3:]) < 1e-12:
            raise PlacementError(
                f"{source}, line {number}: the quaternion qx,qy,qz,qw is zero (any non-zero "
                "quaternion is normalised)"
            )
        T = np.eye(4)
        T[:3, :3] = matrix_from_quaternion(values[3:])
        T[:3, 3] = values[:3]
        poses.append(T)
    if not poses:
        raise PlacementError(f"{source}: no task pose (one line each: x,y,z,qx,qy,qz,qw)")
    return np.stack(poses)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _short(text: str, limit: int = 40) -> str:
    return repr(text if len(text) <= limit else text[: limit - 1] + "…")


# ---------------------------------------------------------------------- the map, looked up
@dataclass(frozen=True)
class _Lookup:
    """The map as dense arrays: voxel of each lattice index, orientations as (direction, roll)."""

    resolution: float
    low: IntArray  # (3,) smallest lattice index
    voxel: NDArray[np.int32]  # lattice index − low → voxel row, −1 where none
    directions: FloatArray  # (D, 3) approach directions (tool z)
    roll_x: FloatArray  # (D, R, 3) each orientation's x axis
    rolls: int

    @classmethod
    def of(cls, reach_map: ReachMap) -> _Lookup:
        res = float(reach_map.resolution)
        k = np.rint(np.asarray(reach_map.centres) / res).astype(np.int64)
        low = k.min(axis=0)
        size = k.max(axis=0) - low + 1
        voxel = np.full(tuple(int(s) for s in size), -1, dtype=np.int32)
        voxel[tuple((k - low).T)] = np.arange(len(k), dtype=np.int32)
        R = np.asarray(reach_map.rotations, dtype=np.float64)
        rolls = int(reach_map.rolls)
        d = R.shape[0] // rolls
        R = R.reshape(d, rolls, 3, 3)
        return cls(res, low, voxel, R[:, 0, :, 2].copy(), R[..., :, 0].copy(), rolls)

    def voxels(self, p: FloatArray) -> NDArray[np.int32]:
        """Voxel row holding each position (..., 3) [m], −1 outside the map."""
        k = np.rint(p / self.resolution).astype(np.int64) - self.low
        inside = np.all((k >= 0) & (k < self.voxel.shape), axis=-1)
        out = np.full(p.shape[:-1], -1, dtype=np.int32)
        kk = k[inside]
        out[inside] = self.voxel[kk[:, 0], kk[:, 1], kk[:, 2]]
        return out

    def orientations(self, R: FloatArray) -> IntArray:
        """Index of the nearest map orientation of each rotation (..., 3, 3) (module docstring)."""
        z = R[..., :, 2]
        d = np.argmax(z @ self.directions.T, axis=-1)
        if self.rolls == 1:
            return d
        x = R[..., :, 0]
        r = np.argmax(np.einsum("...rj,...j->...r", self.roll_x[d], x), axis=-1)
        return d * self.rolls + r

    def spacing(self) -> float:
        """Median angle [rad] between an approach direction and its nearest neighbour."""
        if len(self.directions) < 2:
            return math.pi
        cos = self.directions @ self.directions.T
        np.fill_diagonal(cos, -1.0)
        return float(np.median(np.arccos(np.clip(cos.max(axis=1), -1.0, 1.0))))


def _check_map(reach_map: ReachMap) -> None:
    M, K = np.shape(reach_map.reached)
    if M == 0 or K == 0:
        raise PlacementError("the map is empty (no voxel or no orientation)")
    if K % int(reach_map.rolls) != 0 or np.shape(reach_map.rotations) != (K, 3, 3):
        raise PlacementError(
            f"the map's {K} orientations do not match its {reach_map.directions} directions × "
            f"{reach_map.rolls} rolls"
        )
    if not (math.isfinite(reach_map.resolution) and reach_map.resolution > 0):
        raise PlacementError(f"the map's resolution {reach_map.resolution!r} is not a length > 0")


# ---------------------------------------------------------------------- scoring
@dataclass(frozen=True)
class Scores:
    """Map scores of floor placements (`score_placements`): `bases` (C, 3) x, y [m], yaw [rad];
    `reached` (C,) tasks the map reaches; `index` (C,) their summed D [%]; `manipulability` (C,)
    summed; `per_task` (C, T) the map's answer per task. Only placements that reach a task are
    kept; `considered` counts every placement scored."""

    bases: FloatArray
    reached: IntArray
    index: FloatArray
    manipulability: FloatArray
    per_task: BoolArray
    considered: int


def score_placements(reach_map: ReachMap, tasks: ArrayLike, yaw_steps: int = 36) -> Scores:
    """Map scores of every floor placement of the grid that may reach a task (module docstring):
    (x, y) at whole multiples of the map's resolution within the map's horizontal reach of a
    task, `yaw_steps` yaws 2π/yaw_steps apart."""
    T_tasks = _check_tasks(tasks)
    _check_map(reach_map)
    if isinstance(yaw_steps, bool) or not isinstance(yaw_steps, (int, np.integer)) or yaw_steps < 1:
        raise InvalidInputError(f"yaw_steps must be a whole number ≥ 1, got {yaw_steps!r}")
    look = _Lookup.of(reach_map)
    res = look.resolution
    reached_voxels = np.asarray(reach_map.reached).any(axis=1)
    D = np.asarray(reach_map.index, dtype=np.float64)
    W = np.asarray(reach_map.manipulability, dtype=np.float64)
    R_map = np.asarray(reach_map.reached, dtype=bool)
    c = np.asarray(reach_map.centres)[reached_voxels]
    if not len(c):
        return _no_scores(len(T_tasks), 0)
    # a base farther than this (horizontally) from a task cannot reach it
    reach = float(np.max(np.hypot(c[:, 0], c[:, 1]))) + res * math.sqrt(2) / 2 + 1e-9
    p = T_tasks[:, :3, 3]
    lo = np.floor((p[:, :2].min(axis=0) - reach) / res).astype(np.int64)
    hi = np.ceil((p[:, :2].max(axis=0) + reach) / res).astype(np.int64)
    gx, gy = np.meshgrid(
        np.arange(lo[0], hi[0] + 1) * res, np.arange(lo[1], hi[1] + 1) * res, indexing="ij"
    )
    xy = np.stack([gx.ravel(), gy.ravel()], axis=1)
    near = np.zeros(len(xy), dtype=bool)
    for task_xy in p[:, :2]:
        near |= np.hypot(*(xy - task_xy).T) <= reach
    xy = xy[near]
    yaws = 2.0 * math.pi * np.arange(yaw_steps) / yaw_steps
    n_t = len(T_tasks)
    found: list[tuple[FloatArray, IntArray, FloatArray, FloatArray, BoolArray]] = []
    step = max(1, LOOKUPS_PER_PASS // n_t)
    for yaw in yaws:
        Rz_inv = floor_pose(0.0, 0.0, -yaw)[:3, :3]  # R_base_world
        k = look.orientations(Rz_inv @ T_tasks[:, :3, :3])  # (T,) the same for every x, y
        for start in range(0, len(xy), step):
            b = xy[start : start + step]
            rel = np.zeros((len(b), n_t, 3))
            rel[..., :2] = p[None, :, :2] - b[:, None, :]
            rel[..., 2] = p[None, :, 2]
            p_base = rel @ Rz_inv.T  # (C, T, 3) the tasks' positions in the base frame
            v = look.voxels(p_base)
            ok = v >= 0
            hit = np.zeros(v.shape, dtype=bool)
            cols = np.broadcast_to(k, v.shape)
            hit[ok] = R_map[v[ok], cols[ok]]
            count = hit.sum(axis=1)
            keep = count > 0
            if not keep.any():
                continue
            d_sum = np.where(hit, D[np.maximum(v, 0)], 0.0).sum(axis=1)
            w_sum = np.where(hit, W[np.maximum(v, 0), cols], 0.0).sum(axis=1)
            bases = np.column_stack([b[keep], np.full(int(keep.sum()), yaw)])
            found.append((bases, count[keep], d_sum[keep], w_sum[keep], hit[keep]))
    considered = len(xy) * yaw_steps
    if not found:
        return _no_scores(n_t, considered)
    bases, count, d_sum, w_sum, hit = (np.concatenate(part) for part in zip(*found, strict=True))
    return Scores(bases, count.astype(np.int64), d_sum, w_sum, hit, considered)


def _no_scores(tasks: int, considered: int) -> Scores:
    return Scores(
        np.zeros((0, 3)),
        np.zeros(0, np.int64),
        np.zeros(0),
        np.zeros(0),
        np.zeros((0, tasks), dtype=bool),
        considered,
    )


def _nth_of_kind(keys: IntArray) -> IntArray:
    """For rows of `keys` (N, k): how many equal rows come before each (0 for the first)."""
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    order = np.argsort(inverse, kind="stable")
    group = inverse[order]
    starts = np.r_[0, np.flatnonzero(group[1:] != group[:-1]) + 1]
    run_start = np.repeat(starts, np.diff(np.r_[starts, len(group)]))
    nth = np.empty(len(keys), dtype=np.int64)
    nth[order] = np.arange(len(group)) - run_start
    return nth


def _check_tasks(tasks: ArrayLike) -> FloatArray:
    T = np.asarray(tasks, dtype=np.float64)
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[1:] != (4, 4) or not len(T):
        raise InvalidInputError(f"tasks must be (T, 4, 4) poses, got shape {np.shape(tasks)}")
    if not np.all(np.isfinite(T)):
        raise InvalidInputError("tasks must be finite poses")
    return T


# ---------------------------------------------------------------------- verification
def reach_by_ik(
    chain: SerialChain, T_base_targets: ArrayLike, *, restarts: int = 20, seed: int = 0
) -> tuple[BoolArray, FloatArray]:
    """Which tool poses (N, 4, 4) in the base frame `chain` reaches within its limits, and the
    best manipulability of the solutions (0 where none): every branch in closed form where the
    chain has a family, else the numeric batch IK with `restarts` random restarts from `seed`.
    Both to `VERIFY_TOLERANCE`."""
    T = np.asarray(T_base_targets, dtype=np.float64)
    if not len(T):
        return np.zeros(0, dtype=bool), np.zeros(0)
    reach = reach_targets(chain, T, tolerance=VERIFY_TOLERANCE, restarts=restarts, seed=seed)
    return reach.reached[0], reach.manipulability[0]


def verify_placements(
    chain: SerialChain, placements: Iterable[Placement], tasks: ArrayLike
) -> list[Placement]:
    """Each placement with `verified` (tasks reached by IK from it), its summed manipulability and
    per-task `reached`, all placements' IK in one batch."""
    T_tasks = _check_tasks(tasks)
    todo = list(placements)
    if not todo:
        return []
    T_world_base = np.stack([p.T_world_base for p in todo])
    T_base_tasks = np.linalg.inv(T_world_base)[:, None] @ T_tasks[None]  # (P, T, 4, 4)
    reached, best = reach_by_ik(chain, T_base_tasks.reshape(-1, 4, 4))
    reached = reached.reshape(len(todo), -1)
    best = best.reshape(len(todo), -1)
    return [
        Placement(
            p.x,
            p.y,
            p.yaw,
            p.map_reached,
            p.map_index,
            p.map_manipulability,
            int(r.sum()),
            float(w.sum()),
            r.copy(),
        )
        for p, r, w in zip(todo, reached, best, strict=True)
    ]


def check_map_matches(chain: SerialChain, reach_map: ReachMap, samples: int = 32) -> None:
    """Refuse a chain that is not the map's: its base and tip links differ, or it reaches fewer
    than `MATCH_SHARE` of `samples` poses the map counts as reached (a UR10e against a UR5e map:
    the same link names).

    Raises:
        PlacementError: naming what differs.
    """
    if (chain.base_link, chain.tip_link) != (reach_map.base_link, reach_map.tip_link):
        raise PlacementError(
            f"the map is of the chain {reach_map.base_link} → {reach_map.tip_link}"
            f"{f' of {reach_map.robot}' if reach_map.robot else ''}, the robot given is "
            f"{chain.base_link} → {chain.tip_link}"
        )
    m, k = np.nonzero(np.asarray(reach_map.reached))
    if not len(m):
        return
    pick = np.random.default_rng(0).choice(len(m), size=min(samples, len(m)), replace=False)
    T = np.zeros((len(pick), 4, 4))
    T[:, :3, :3] = np.asarray(reach_map.rotations)[k[pick]]
    T[:, :3, 3] = np.asarray(reach_map.centres)[m[pick]]
    T[:, 3, 3] = 1.0
    reached, _ = reach_by_ik(chain, T)
    if reached.mean() < MATCH_SHARE:
        raise PlacementError(
            f"the robot given reaches only {int(reached.sum())} of {len(pick)} poses the map "
            f"counts as reached: the map{f' (of {reach_map.robot})' if reach_map.robot else ''} "
            "is of another robot"
        )


# ---------------------------------------------------------------------- the whole
def place_base(
    reach_map: ReachMap,
    tasks: ArrayLike,
    chain: SerialChain | None = None,
    *,
    yaw_steps: int = 36,
    top: int = 10,
    verify: int | None = None,
    unverified_reason: str = "no robot given to verify with",
) -> PlacementResult:
    """Rank floor placements of the base for the task poses (T, 4, 4) in the world frame (module
    docstring). With `chain` (the map's; checked by `check_map_matches`), the best `verify`
    placements by map score (default max(20·top, 200), at most `YAWS_VERIFIED` yaws of a
    position) are verified by IK and ranked first. The ranking holds one placement per position.

    Raises:
        PlacementError: an empty or inconsistent map, or a chain that is not the map's.
        InvalidInputError: tasks not finite (T, 4, 4) poses, yaw_steps or top not ≥ 1.
    """
    start = time.perf_counter()
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise InvalidInputError(f"top must be a whole number ≥ 1, got {top!r}")
    T_tasks = _check_tasks(tasks)
    _check_map(reach_map)
    if chain is not None:
        check_map_matches(chain, reach_map)
    scores = score_placements(reach_map, T_tasks, yaw_steps)
    bases, count, d_sum, w_sum = scores.bases, scores.reached, scores.index, scores.manipulability
    order = np.lexsort((-w_sum, -d_sum, -count))  # count, then D, then manipulability
    cell = np.rint(bases[order, :2] / reach_map.resolution).astype(np.int64)
    # at most YAWS_VERIFIED yaws of one position go to the verification, its best by the map: an
    # arm whose first joint turns fully reaches the same from every yaw, and the verification
    # should see many positions rather than every yaw of a few
    order = order[_nth_of_kind(cell) < YAWS_VERIFIED]
    n_verify = max(20 * int(top), 200) if verify is None else max(int(verify), 0)

    def placement(i: int) -> Placement:
        b = bases[i]
        return Placement(
            float(b[0]),
            float(b[1]),
            float(b[2]),
            int(count[i]),
            float(d_sum[i]),
            float(w_sum[i]),
            reached=scores.per_task[i],
        )

    checked: list[Placement] = []
    reason = unverified_reason
    if chain is not None and n_verify:
        checked = verify_placements(chain, [placement(i) for i in order[:n_verify]], T_tasks)
        checked.sort(
            key=lambda p: (
                -(p.verified or 0),
                -p.map_reached,
                -p.map_index,
                -p.verified_manipulability,
            )
        )
        reason = ""
    else:
        n_verify = 0
    # the ranking: one placement per position, its best (verified ones first)
    ranked: list[Placement] = []
    seen: set[tuple[int, int]] = set()
    rest = (placement(i) for i in order[n_verify:])
    for p in (*checked, *rest):
        key = (round(p.x / reach_map.resolution), round(p.y / reach_map.resolution))
        if key not in seen:
            seen.add(key)
            ranked.append(p)
    return PlacementResult(
        tuple(ranked),
        len(T_tasks),
        scores.considered,
        time.perf_counter() - start,
        _Lookup.of(reach_map).spacing(),
        reason,
    )
