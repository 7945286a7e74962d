"""Tool orientations of a workspace map: proper rotations, approach directions spread evenly
over the sphere, rolls about the approach axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics_node.core import InvalidInputError
from kinematics_node.core.workspace import approach_rotations
from kinematics_node.core.workspace.orientations import MAX_ORIENTATIONS


def _cap_angle(n: int) -> float:
    """The half-angle of a spherical cap of area 4π/n, the share of each of n even directions."""
    return math.acos(1.0 - 2.0 / n)


@pytest.mark.parametrize(("directions", "rolls"), [(1, 1), (2, 3), (50, 1), (50, 4), (333, 2)])
def test_every_orientation_is_a_proper_rotation(directions, rolls):
    R = approach_rotations(directions, rolls)
    assert R.shape == (directions * rolls, 3, 3)
    np.testing.assert_allclose(
        R.swapaxes(1, 2) @ R, np.broadcast_to(np.eye(3), R.shape), atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    assert not R.flags.writeable


@pytest.mark.parametrize("n", [10, 50, 200, 1000])
def test_directions_are_spread_evenly(n):
    z = approach_rotations(n)[:, :, 2]
    cap = _cap_angle(n)
    # every direction's nearest neighbour within a narrow band around the cap's size: no two
    # crowd together (a latitude-longitude grid's poles) and none stands alone
    cos = np.clip(z @ z.T, -1.0, 1.0)
    np.fill_diagonal(cos, -1.0)
    nearest = np.arccos(cos.max(axis=1))
    assert 1.4 * cap <= nearest.min() and nearest.max() <= 1.9 * cap
    # and every direction of the sphere is near one of them (the covering radius)
    rng = np.random.default_rng(4)
    u = rng.normal(size=(100_000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    covering = np.arccos(np.clip((u @ z.T).max(axis=1), -1.0, 1.0)).max()
    assert covering <= 1.5 * cap
    # and no hemisphere is favoured
    assert np.linalg.norm(z.mean(axis=0)) <= 2.0 / n


def test_rolls_turn_about_the_approach_axis():
    rolls = 5
    R = approach_rotations(40, rolls).reshape(40, rolls, 3, 3)
    # the same z axis for every roll of a direction
    np.testing.assert_allclose(R[:, :, :, 2], np.broadcast_to(R[:, :1, :, 2], (40, rolls, 3)))
    # each roll the first one turned about its own z by 2π k / rolls: R_k = R_0 Rz(2π k / rolls)
    for k in range(rolls):
        a = 2 * math.pi * k / rolls
        Rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
        np.testing.assert_allclose(R[:, k], R[:, 0] @ Rz, atol=1e-14)


def test_the_default_is_reuleaux_count_of_fifty_directions():
    R = approach_rotations()
    assert R.shape == (50, 3, 3)
    assert len({tuple(np.round(z, 12)) for z in R[:, :, 2].tolist()}) == 50


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"directions": 0}, "directions"),
        ({"directions": -3}, "directions"),
        ({"directions": 1.5}, "directions"),
        ({"directions": 50.0}, "directions"),
        ({"directions": True}, "directions"),
        ({"directions": "50"}, "directions"),
        ({"rolls": 0}, "rolls"),
        ({"rolls": 2.5}, "rolls"),
        ({"rolls": False}, "rolls"),
        ({"rolls": math.nan}, "rolls"),
    ],
)
def test_a_bad_count_is_refused_naming_it(kwargs, name):
    with pytest.raises(InvalidInputError, match=f"{name} must be a whole number"):
        approach_rotations(**kwargs)


def test_too_many_orientations_name_the_limit():
    with pytest.raises(InvalidInputError, match=f"{MAX_ORIENTATIONS:,}"):
        approach_rotations(1000, 101)


def test_numpy_integers_are_counts_too():
    assert approach_rotations(np.int64(7), np.int32(2)).shape == (14, 3, 3)
