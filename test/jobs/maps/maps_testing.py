"""What the map job's tests share: a small map's settings, the robot, and a whole-file compare."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kinematics_node.jobs.maps.build import MapRobot
from kinematics_node.jobs.maps.storage import h5_datasets
from kinematics_node.sim.robots import default_chain_links, robot_path

ROOT = Path(__file__).resolve().parents[3]
#: A coarse UR5e map: 413 voxels × 12 orientations, in 26 chunks of 16 voxels (a fraction of a s).
SMALL = {"resolution": 0.25, "directions": 12, "rolls": 1, "chunk_voxels": 16}
CLI_SMALL = ["--resolution", "0.25", "--directions", "12", "--chunk-voxels", "16"]


def ur5e() -> MapRobot:
    text = robot_path("ur5e").read_text(encoding="utf-8")
    return MapRobot.from_text("ur5e", text, *default_chain_links("ur5e"))


def assert_same_file(a: Path, b: Path) -> None:
    """Every group, dataset and attribute of two HDF5 files equal, bit for bit."""
    left, right = list(h5_datasets(a)), list(h5_datasets(b))
    assert [n for n, _, _ in left] == [n for n, _, _ in right]
    for (name, x, xa), (_, y, ya) in zip(left, right, strict=True):
        assert xa.keys() == ya.keys(), name
        for key in xa:
            assert np.array_equal(np.asarray(xa[key]), np.asarray(ya[key])), (name, key)
        if x is not None:
            assert x.dtype == y.dtype and x.shape == y.shape, name
            assert x.tobytes() == y.tobytes(), name
