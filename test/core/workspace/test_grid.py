"""The voxel grid of a workspace map: `reach_bound` holds every tool position and is nearly
tight, and `VoxelGrid` covers that sphere."""

from __future__ import annotations

import math

import numpy as np
import pytest
from kin_testing import random_q

from kinematics_node.core import InvalidInputError, SerialChain
from kinematics_node.core.workspace import VoxelGrid, reach_bound
from kinematics_node.core.workspace.grid import MAX_VOXELS
from kinematics_node.sim.robots import available_robots, load_robot


def _check_bound(chain: SerialChain, rng: np.random.Generator) -> tuple[float, float]:
    """(largest sampled distance from the bound's centre, its radius), after checking that no
    FK sample lies outside."""
    centre, radius = reach_bound(chain)
    tip = chain.fk(random_q(chain, rng, 20_000))[:, :3, 3]
    distance = np.linalg.norm(tip - centre, axis=1)
    assert distance.max() <= radius + 1e-12
    return float(distance.max()), radius


@pytest.mark.parametrize("robot", available_robots())
def test_every_fk_sample_of_a_bundled_robot_lies_within_the_bound(robot):
    chain = load_robot(robot)
    far, radius = _check_bound(chain, np.random.default_rng(1))
    assert radius <= chain.reach_sphere[1] + 1e-12
    if np.allclose(np.linalg.norm(np.asarray(chain.S)[:3], axis=0), 1.0):  # revolute only
        # nearly tight: random configurations come within 0.2 % of it
        assert far >= 0.998 * radius


def test_every_fk_sample_of_a_real_arm_lies_within_the_bound(real_arm):
    chain, _ = real_arm
    far, radius = _check_bound(chain, np.random.default_rng(2))
    assert far >= 0.998 * radius
    assert radius <= chain.reach_sphere[1] + 1e-12


@pytest.mark.parametrize(("robot", "most"), [("ur5e", 0.75), ("iiwa14", 0.75), ("panda", 0.9)])
def test_the_bound_is_tighter_than_the_frames_sphere_where_axes_are_offset(robot, most):
    # The frames' origins sit off the axes' common points (UR5e: 1.31 m through the origins,
    # 0.97 m along the axes), so the sum of the origins' gaps overstates the reach.
    chain = load_robot(robot)
    assert reach_bound(chain)[1] <= most * chain.reach_sphere[1]


def test_a_prismatic_joint_falls_back_to_the_frames_sphere():
    chain = load_robot("scara")
    centre, radius = reach_bound(chain)
    frame_centre, frame_radius = chain.reach_sphere
    assert radius == frame_radius
    np.testing.assert_array_equal(centre, frame_centre)


@pytest.mark.parametrize(("robot", "resolution"), [("ur5e", 0.2), ("panda", 0.15), ("scara", 0.3)])
def test_every_point_of_the_bound_lies_in_a_voxel(robot, resolution):
    chain = load_robot(robot)
    grid = VoxelGrid.around(chain, resolution)
    rng = np.random.default_rng(3)
    # points filling the ball, half of them on its surface
    u = rng.normal(size=(40_000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    r = grid.radius * np.concatenate([rng.uniform(0, 1, 20_000) ** (1 / 3), np.ones(20_000)])
    points = grid.centre + u * r[:, None]
    # with the tool positions of random configurations
    points = np.vstack([points, chain.fk(random_q(chain, rng, 10_000))[:, :3, 3]])
    voxel = np.floor(points / resolution + 0.5).astype(np.int64)  # the cube each point lies in
    known = {tuple(k) for k in grid.indices.tolist()}
    missing = [tuple(k) for k in voxel.tolist() if tuple(k) not in known]
    assert not missing, f"{len(missing)} points in no voxel, e.g. {missing[:3]}"
    # and every voxel's cube meets the sphere (none wasted beyond it)
    nearest = np.clip(grid.centre, grid.centres - resolution / 2, grid.centres + resolution / 2)
    assert np.linalg.norm(nearest - grid.centre, axis=1).max() <= grid.radius + 1e-12


def test_the_grid_is_aligned_with_the_base_and_ordered():
    grid = VoxelGrid.around(load_robot("ur5e"), 0.25)
    np.testing.assert_array_equal(grid.centres, grid.indices * 0.25)
    order = np.lexsort(grid.indices.T[::-1])  # x, then y, then z
    np.testing.assert_array_equal(order, np.arange(len(grid)))
    assert len({tuple(k) for k in grid.indices.tolist()}) == len(grid)
    assert not grid.centres.flags.writeable


def test_the_voxel_count_follows_the_volume():
    grid = VoxelGrid.around(load_robot("ur5e"), 0.05)
    ball = 4 / 3 * math.pi * grid.radius**3 / 0.05**3
    assert ball < len(grid) < 1.4 * ball  # the cubes meeting the sphere: a shell more


@pytest.mark.parametrize(
    ("resolution", "words"),
    [
        (0.0, "finite length > 0"),
        (-0.05, "finite length > 0"),
        (math.nan, "finite length > 0"),
        (math.inf, "finite length > 0"),
        ("fine", "must be a number"),
        (None, "must be a number"),
        (1e-4, "choose a coarser one"),
    ],
)
def test_a_bad_resolution_is_refused_saying_why(resolution, words):
    with pytest.raises(InvalidInputError, match="resolution") as err:
        VoxelGrid.around(load_robot("ur5e"), resolution)
    assert words in str(err.value)


def test_too_fine_names_the_limit():
    with pytest.raises(InvalidInputError, match=f"{MAX_VOXELS:,}"):
        VoxelGrid.around(load_robot("ur5e"), 2e-3)
