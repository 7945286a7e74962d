"""Small reachability maps built in memory for the map tests (coarse: a fraction of a second)."""

from __future__ import annotations

from functools import cache

import numpy as np

from kinematics_node.core.workspace import VoxelGrid, approach_rotations, reach_voxels
from kinematics_node.jobs.maps.reach_map import ReachMap
from kinematics_node.sim.robots import load_robot


@cache
def small_map(
    robot: str = "ur5e", resolution: float = 0.2, directions: int = 26, rolls: int = 1
) -> ReachMap:
    """The map of a bundled robot's default chain, built with the core's `reach_voxels`."""
    chain = load_robot(robot)
    grid = VoxelGrid.around(chain, resolution)
    rotations = approach_rotations(directions, rolls)
    reach = reach_voxels(chain, grid.centres, rotations)
    return ReachMap(
        robot,
        chain.base_link,
        chain.tip_link,
        resolution,
        directions,
        rolls,
        np.asarray(grid.centres),
        np.asarray(rotations),
        reach.reached,
        reach.solutions,
        reach.manipulability,
        reach.method,
    )


def save_npz(reach_map: ReachMap, path) -> None:
    """`reach_map` as the map job's `.npz` (`storage.write_npz`), for tests that read it back."""
    from kinematics_node.jobs.maps.storage import MapHeader, write_npz

    header = MapHeader(
        reach_map.robot,
        reach_map.base_link,
        reach_map.tip_link,
        "",
        reach_map.resolution,
        reach_map.directions,
        reach_map.rolls,
        reach_map.method,
        1e-9,
        2048,
    )
    write_npz(path, reach_map, header)
