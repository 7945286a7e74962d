"""`ReachMap`: a whole reachability map in memory, what the files hold and what placement reads.

Voxel centres (M, 3) and orientations (K, 3, 3) in the base frame of the chain, and per voxel and
orientation: reached, the number of distinct solutions, the best manipulability. Derived per voxel:
Reuleaux's reachability index D, the best manipulability, the number of solutions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class ReachMap:
    """A reachability map of one chain (module docstring).

    Attributes:
        robot, base_link, tip_link: the chain it maps.
        resolution: voxel edge [m].
        directions, rolls: approach directions and rolls about each (K = directions × rolls).
        centres: (M, 3) voxel centres [m] in the base frame.
        rotations: (K, 3, 3) tool orientations in the base frame.
        reached: (M, K) the pose [rotations[k], centres[m]] has a solution within the limits.
        solutions: (M, K) distinct solutions found.
        manipulability: (M, K) best manipulability of those solutions (0 where none).
        method: "closed_form" or "numeric".
    """

    robot: str
    base_link: str
    tip_link: str
    resolution: float
    directions: int
    rolls: int
    centres: FloatArray = field(repr=False)
    rotations: FloatArray = field(repr=False)
    reached: BoolArray = field(repr=False)
    solutions: IntArray = field(repr=False)
    manipulability: FloatArray = field(repr=False)
    method: str = "closed_form"

    @property
    def index(self) -> FloatArray:
        """(M,) reachability index D = 100 · reached orientations / K."""
        return 100.0 * self.reached.sum(axis=1) / self.reached.shape[1]

    @property
    def best_manipulability(self) -> FloatArray:
        """(M,) best manipulability per voxel (0 where nothing is reached)."""
        return self.manipulability.max(axis=1, initial=0.0)

    @property
    def solution_count(self) -> IntArray:
        """(M,) solutions over every orientation of each voxel."""
        return self.solutions.sum(axis=1)
