"""Test helpers: real robot descriptions nobody here wrote, sampling within limits."""

from __future__ import annotations

import sysconfig
from pathlib import Path

import numpy as np
import pytest

ERD = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"

#: (name, file below ERD, base link or None, tip link) of real arms from `example-robot-data`.
REAL_ARMS = [
    ("ur5", "ur_description/urdf/ur5_robot.urdf", None, "tool0"),
    ("panda", "panda_description/urdf/panda.urdf", None, "panda_hand"),
    ("xarm7", "xarm_description/urdf/xarm7.urdf", None, "link_eef"),
    ("z1", "z1_description/urdf/z1.urdf", None, "gripperMover"),
]


def erd_path(relative: str) -> Path:
    path = ERD / relative
    if not path.exists():
        pytest.skip(f"example-robot-data not installed ({path} missing): pip install '.[test]'")
    return path


def random_q(chain, rng, n=None):
    """Uniform samples within limits (continuous joints in [-π, π])."""
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    size = (chain.dof,) if n is None else (n, chain.dof)
    return rng.uniform(lo, hi, size=size)
