"""Tool orientations for a workspace map: approach directions spread evenly over the sphere, and
rolls about each.

The approach direction is the tool's z axis. The n directions are the points of a Fibonacci
lattice on the unit sphere (zᵢ = 1 − (2i + 1)/n, azimuth i times the golden angle): every one
covers about the same area, 4π/n, unlike a latitude–longitude grid, which crowds the poles.
(Reuleaux places 50 points per voxel on a sphere the same way.) Each direction gets `rolls`
rotations about it, 2π k / rolls apart; its x axis at roll 0 is the direction's own "east"
(perpendicular to it and to the base z axis; the base x axis at the poles).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..exceptions import InvalidInputError
from ..model import readonly

FloatArray = NDArray[np.float64]

#: Orientations per voxel at most (directions × rolls).
MAX_ORIENTATIONS = 100_000


def approach_directions(n: int) -> FloatArray:
    """(n, 3) unit vectors evenly spread over the sphere (the Fibonacci lattice)."""
    i = np.arange(n, dtype=np.float64)
    z = 1.0 - (2.0 * i + 1.0) / n
    rho = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    phi = i * math.pi * (3.0 - math.sqrt(5.0))  # the golden angle
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)


def approach_rotations(directions: int = 50, rolls: int = 1) -> FloatArray:
    """(directions × rolls, 3, 3) tool orientations: rotation matrices whose z axis is each
    approach direction, `rolls` of them about it (direction-major order).

    Raises:
        InvalidInputError: a count that is not a whole number ≥ 1, or too many in all.
    """
    n, m = _count(directions, "directions"), _count(rolls, "rolls")
    if n * m > MAX_ORIENTATIONS:
        raise InvalidInputError(
            f"{n} directions × {m} rolls = {n * m} orientations per voxel (at most "
            f"{MAX_ORIENTATIONS:,})"
        )
    z = approach_directions(n)
    east = np.cross([0.0, 0.0, 1.0], z)
    norm = np.linalg.norm(east, axis=1)
    pole = norm < 1e-9
    east[pole] = [1.0, 0.0, 0.0]
    east[~pole] /= norm[~pole, None]
    north = np.cross(z, east)
    angles = 2.0 * math.pi * np.arange(m) / m
    c, s = np.cos(angles)[None, :, None], np.sin(angles)[None, :, None]
    x = c * east[:, None, :] + s * north[:, None, :]  # (n, m, 3)
    y = np.cross(np.broadcast_to(z[:, None, :], x.shape), x)
    R = np.stack([x, y, np.broadcast_to(z[:, None, :], x.shape)], axis=-1)  # columns x, y, z
    return readonly(R.reshape(n * m, 3, 3))


def _count(value: int, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InvalidInputError(f"{name} must be a whole number ≥ 1, got {value!r}")
    return int(value)
