"""`SerialChain.reach_sphere`: a bound no configuration exceeds, and not a loose one."""

from __future__ import annotations

import numpy as np
import pytest
from kin_testing import random_q

from kinematics_node.robots import available_robots, load_robot


@pytest.mark.parametrize("robot", available_robots())
def test_every_configuration_lies_inside_and_the_bound_is_reached_or_close(robot):
    chain = load_robot(robot)
    center, radius = chain.reach_sphere
    q = random_q(chain, np.random.default_rng(1), 20_000)
    distance = np.linalg.norm(chain.fk(q)[:, :3, 3] - center, axis=1)
    assert distance.max() <= radius + 1e-12
    # a bound by the triangle inequality: reached by arms that can stretch out straight, and
    # within a factor 2 for the others (the SCARA's vertical offsets, the UR's elbow offsets)
    assert distance.max() >= 0.5 * radius
    assert not center.flags.writeable


def test_real_arms_too(real_arm):
    chain, _ = real_arm
    center, radius = chain.reach_sphere
    q = random_q(chain, np.random.default_rng(2), 5_000)
    assert np.linalg.norm(chain.fk(q)[:, :3, 3] - center, axis=1).max() <= radius + 1e-12
