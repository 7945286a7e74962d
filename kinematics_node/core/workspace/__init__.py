"""Workspace maps: where a chain's tool can be, and in which orientations (pure math, no I/O).

* `grid`: the voxel grid over a sphere that holds every tool position (`reach_bound`,
  `VoxelGrid`).
* `orientations`: tool orientations spread evenly over the sphere of approach directions, with
  rolls about each (`approach_rotations`).
* `reachability`: for voxel centres and orientations, which poses the chain reaches within its
  limits, how well (manipulability) and by how many solutions (`reach_voxels`).

The offline job around them (chunks, HDF5, Dask, base placement) is `kinematics_node.jobs.maps`.
"""

from .grid import VoxelGrid, reach_bound
from .orientations import approach_rotations
from .reachability import VoxelReach, reach_targets, reach_voxels

__all__ = [
    "VoxelGrid",
    "VoxelReach",
    "approach_rotations",
    "reach_bound",
    "reach_targets",
    "reach_voxels",
]
