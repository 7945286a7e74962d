"""`SerialChain.reach_sphere`: a bound no configuration exceeds, met by arms that stand straight."""

from __future__ import annotations

import numpy as np
import pytest
from kin_testing import random_q

from kinematics_node.sim.robots import available_robots, load_robot


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


@pytest.mark.parametrize("robot", ["iiwa14", "planar3r"])
def test_an_arm_standing_straight_reaches_the_bound_exactly(robot):
    # at q = 0 an iiwa stands straight up and the planar 3R lies straight out: every joint origin
    # on one ray from the first, so the triangle inequality is an equality and the tip lies on the
    # sphere
    chain = load_robot(robot)
    center, radius = chain.reach_sphere
    tip = chain.fk(np.zeros(chain.dof))[:3, 3]
    assert np.linalg.norm(tip - center) == pytest.approx(radius, abs=1e-12)
