"""Base placement from a reachability map (`jobs.maps.placement`): the ranking finds a known base,
the map's lookup agrees with a brute-force one, the verification agrees with `ik_all`, and bad
task files, maps and robots are refused in one line."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from map_testing import small_map

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.core.rotations import matrix_from_quaternion
from kinematics_node.jobs.maps.placement import (
    PlacementError,
    floor_pose,
    place_base,
    read_tasks,
    score_placements,
    tasks_from_lines,
)
from kinematics_node.sim.robots import load_robot


def _tasks_from(B: np.ndarray, count: int, seed: int) -> np.ndarray:
    """`count` tool poses the UR5e reaches from base B (world frame), from random
    configurations within the limits whose tool stays above the floor and off the base axis."""
    chain = load_robot("ur5e")
    rng = np.random.default_rng(seed)
    tasks = []
    while len(tasks) < count:
        q = rng.uniform(-math.pi, math.pi, chain.dof)
        T = chain.fk(q)
        if T[2, 3] > 0.1 and math.hypot(T[0, 3], T[1, 3]) > 0.25:
            tasks.append(B @ T)
    return np.array(tasks)


def _reached_by_ik_all(chain, B: np.ndarray, tasks: np.ndarray) -> int:
    """Tasks the chain reaches from B by `ik_all` (every solution within the limits), an IK path
    other than the placement's `branches_within_limits`."""
    inv = np.linalg.inv(B)
    return sum(len(chain.ik_all(inv @ T).solutions) > 0 for T in tasks)


@pytest.mark.parametrize("seed", [3, 4])
def test_known_base_or_one_as_good_is_in_the_top_three(seed: int) -> None:
    m = small_map()
    chain = load_robot("ur5e")
    B = floor_pose(0.4, -0.6, math.radians(120.0))  # on the grid: 0.2 m, 36 yaws
    tasks = _tasks_from(B, 8, seed)
    assert _reached_by_ik_all(chain, B, tasks) == len(tasks)
    result = place_base(m, tasks, chain, top=3)
    best = result.placements[:3]
    # B*, or one reaching as many by IK (checked here by ik_all), is among the top 3
    assert any(
        p.verified == len(tasks) and _reached_by_ik_all(chain, p.T_world_base, tasks) == len(tasks)
        for p in best
    )
    # the verified counts are ik_all's, and the ranking is by them
    for p in best:
        assert p.verified == _reached_by_ik_all(chain, p.T_world_base, tasks)
    counts = [p.verified or 0 for p in result.placements]
    assert counts[:3] == sorted(counts[:3], reverse=True) and counts[0] == max(counts)
    positions = {(round(p.x / m.resolution), round(p.y / m.resolution)) for p in result.placements}
    assert len(positions) == len(result.placements)  # one placement per position
    assert result.candidates > 1000
    assert "verified" in result.report(3)


def test_a_base_reaching_few_tasks_is_not_ranked_first() -> None:
    """Tasks spread so that no single spot near B2 reaches them all: the ranking must still put
    a placement reaching the most (by IK) first, checked against every placement it verified."""
    m = small_map()
    chain = load_robot("ur5e")
    tasks = np.concatenate(
        [
            _tasks_from(floor_pose(0.0, 0.0, 0.0), 4, 5),
            _tasks_from(floor_pose(2.4, 0.0, 0.0), 4, 6),
        ]
    )
    result = place_base(m, tasks, chain, top=5)
    counts = [p.verified for p in result.placements if p.verified is not None]
    assert counts == sorted(counts, reverse=True)
    assert counts[0] == _reached_by_ik_all(chain, result.placements[0].T_world_base, tasks)
    assert counts[0] < len(tasks)  # 2.4 m apart: beyond the UR5e's reach from one spot


def test_map_scores_equal_a_brute_force_lookup() -> None:
    """For some placements, the map's answer per task equals the one of the nearest voxel centre
    (within half a voxel in each axis) and the nearest approach direction, found by brute force."""
    m = small_map()
    tasks = _tasks_from(floor_pose(0.2, 0.4, 1.0), 6, 7)
    scores = score_placements(m, tasks, yaw_steps=12)
    assert len(scores.bases) > 100
    rng = np.random.default_rng(0)
    z = np.asarray(m.rotations)[:, :, 2]
    for i in rng.choice(len(scores.bases), 40, replace=False):
        x, y, yaw = scores.bases[i]
        inv = np.linalg.inv(floor_pose(x, y, yaw))
        for t, T in enumerate(tasks):
            T_b = inv @ T
            gap = np.abs(np.asarray(m.centres) - T_b[:3, 3]).max(axis=1)
            inside = np.flatnonzero(gap <= m.resolution / 2 + 1e-9)
            k = int(np.argmax(z @ T_b[:3, 2]))
            expected = bool(len(inside)) and bool(m.reached[inside[0], k])
            assert scores.per_task[i, t] == expected
        assert scores.reached[i] == scores.per_task[i].sum()


def test_rolls_are_matched_about_the_approach() -> None:
    """With rolls, the task's roll picks the map orientation: a map that reaches only roll 0
    answers yes for a task at roll 0 and no at the roll half a turn away."""
    m = small_map(directions=8, rolls=4)
    reached = np.zeros_like(m.reached)
    reached[:, 0::4] = True  # roll 0 of each direction everywhere
    only_roll_0 = replace(m, reached=reached, manipulability=reached * 1.0)
    R0 = np.asarray(m.rotations)[0]
    turned = R0 @ np.diag([-1.0, -1.0, 1.0])  # half a turn about its own z
    tasks = np.stack([np.eye(4), np.eye(4)])
    tasks[0, :3, :3], tasks[1, :3, :3] = R0, turned
    tasks[:, :3, 3] = [0.4, 0.0, 0.4]
    s = score_placements(only_roll_0, tasks, yaw_steps=1)
    at_origin = np.flatnonzero(np.all(np.abs(s.bases) < 1e-9, axis=1))
    assert s.per_task[at_origin[0]].tolist() == [True, False]


def test_without_a_robot_the_ranking_is_the_map_estimate_and_says_so() -> None:
    m = small_map()
    tasks = _tasks_from(floor_pose(0.0, 0.0, 0.0), 3, 8)
    result = place_base(m, tasks, top=4)
    assert all(p.verified is None for p in result.placements)
    assert result.placements[0].map_reached == 3
    text = result.report(4)
    assert "not verified" in text and "map estimate" in text


def test_unreachable_tasks_give_an_empty_ranking() -> None:
    tasks = np.stack([np.eye(4)])
    tasks[0, 2, 3] = 5.0  # 5 m above the floor: the UR5e reaches 1 m
    result = place_base(small_map(), tasks, load_robot("ur5e"))
    assert result.placements == ()
    assert "no floor placement" in result.report()


# ---------------------------------------------------------------------- the task file
def test_task_file_with_header_and_comments(tmp_path) -> None:
    path = tmp_path / "tasks.csv"
    path.write_text("x,y,z,qx,qy,qz,qw\n# a comment\n0.4, 0.1, 0.3, 0, 1, 0, 0\n\n1,2,3,0,0,0,2\n")
    T = read_tasks(path)
    assert T.shape == (2, 4, 4)
    np.testing.assert_allclose(T[0, :3, 3], [0.4, 0.1, 0.3])
    np.testing.assert_allclose(T[0, :3, :3], np.diag([-1.0, 1.0, -1.0]), atol=1e-15)
    # a non-unit quaternion is normalised (as kinematics ik --target does)
    np.testing.assert_allclose(T[1, :3, :3], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(
        tasks_from_lines(["0,0,0,1,1,0,0"])[0, :3, :3],
        matrix_from_quaternion([1, 1, 0, 0] / np.sqrt(2.0)),
    )


@pytest.mark.parametrize(
    "text, words",
    [
        ("", "no task pose"),
        ("x,y,z,qx,qy,qz,qw\n", "no task pose"),
        ("0,0,0,0,0,0,1\n0,0,zero,0,0,0,1\n", "line 2"),
        ("0,0,0,0,0,1\n", "line 1: 6 values, expected 7"),
        ("0,0,0,0,0,0,1\n\n0,0,nan,0,0,0,1\n", "line 3: every value must be finite"),
        ("0,0,0,0,0,0,0\n", "line 1: the quaternion qx,qy,qz,qw is zero"),
        ("x,y,z,qx,qy,qz,qw\nx,y,z,qx,qy,qz,qw\n", "line 2"),
    ],
)
def test_bad_task_files_are_refused_naming_the_line(tmp_path, text: str, words: str) -> None:
    path = tmp_path / "tasks.csv"
    path.write_text(text)
    with pytest.raises(PlacementError, match=words):
        read_tasks(path)


def test_missing_task_file(tmp_path) -> None:
    with pytest.raises(PlacementError, match="cannot read task poses"):
        read_tasks(tmp_path / "none.csv")


# ---------------------------------------------------------------------- map and robot
def test_a_robot_of_other_links_is_refused() -> None:
    tasks = _tasks_from(floor_pose(0.0, 0.0, 0.0), 2, 9)
    with pytest.raises(PlacementError, match="panda_link0 → panda_hand_tcp"):
        place_base(small_map(), tasks, load_robot("panda"))


def test_a_robot_with_the_same_links_but_another_reach_is_refused() -> None:
    """The SCARA's chain is base_link → tool0 too: the map's poses tell them apart."""
    tasks = _tasks_from(floor_pose(0.0, 0.0, 0.0), 2, 9)
    with pytest.raises(PlacementError, match="reaches only .* map .*of ur5e.* another robot"):
        place_base(small_map(), tasks, load_robot("scara"))


@pytest.mark.parametrize(
    "tasks, top, yaw_steps, words",
    [
        (np.full((1, 4, 4), np.nan), 1, 36, "finite"),
        (np.zeros((1, 3, 3)), 1, 36, "shape"),
        (np.eye(4)[None], 0, 36, "top"),
        (np.eye(4)[None], 1, 0, "yaw_steps"),
    ],
)
def test_bad_arguments(tasks, top: int, yaw_steps: int, words: str) -> None:
    with pytest.raises(InvalidInputError, match=words):
        place_base(small_map(), tasks, top=top, yaw_steps=yaw_steps)


def test_an_empty_map_is_refused() -> None:
    m = small_map()
    empty = replace(
        m,
        centres=m.centres[:0],
        reached=m.reached[:0],
        solutions=m.solutions[:0],
        manipulability=m.manipulability[:0],
    )
    with pytest.raises(PlacementError, match="empty"):
        place_base(empty, np.eye(4)[None])
