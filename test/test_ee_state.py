"""`JointStateTracker`: required joints reject bad samples, other tracked joints never block them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.ee_state import JUMP_BACK, JointStateTracker

ARM = ("a", "b")


def tracker() -> JointStateTracker:
    return JointStateTracker(ARM + ("gripper",), continuous=(False, True, False), required=ARM)


def test_a_bad_value_of_an_optional_joint_is_skipped_and_the_rest_merged():
    t = tracker()
    assert t.update(["a", "b", "gripper"], [0.1, 0.2, math.nan], [], 1.0)
    assert t.positions([0, 1]) == [0.1, 0.2]
    assert math.isnan(t.positions([2])[0])  # never received a valid gripper value
    assert t.update(["gripper"], [0.04], [], 1.1)
    assert t.positions([2]) == [0.04]


@pytest.mark.parametrize(
    ("names", "positions", "velocities", "needle"),
    [
        (["a", "b"], [0.1, math.nan], [], "position of 'b' is nan"),
        (["a", "b"], [math.inf, 0.0], [], "position of 'a' is inf"),
        (["a", "b"], [0.1, 0.2], [0.0, -math.inf], "velocity of 'b' is -inf"),
        (["a", "b", "a"], [0.1, 0.2, 0.3], [], "'a' more than once"),
        (["a", "b"], [0.1], [], "2 names but 1 positions"),
        (["a", "b"], [0.1, 0.2], [0.0], "2 names but 1 velocities"),
    ],
)
def test_bad_samples_of_required_joints_are_refused_whole(names, positions, velocities, needle):
    t = tracker()
    assert t.update(["a", "b"], [1.0, 2.0], [], 0.5)
    with pytest.raises(InvalidInputError, match=needle):
        t.update(names, positions, velocities, 1.0)
    assert t.positions([0, 1]) == [1.0, 2.0]  # nothing merged


def test_velocity_estimated_across_the_wrap_of_a_continuous_joint():
    t = tracker()
    t.update(["a", "b"], [0.0, math.pi - 0.01], [], 0.0)
    t.update(["a", "b"], [0.02, -math.pi + 0.01], [], 0.01)
    np.testing.assert_allclose(t.velocities([0, 1]), [2.0, 2.0], atol=1e-9)


def test_nan_velocity_means_unknown_and_is_estimated():
    t = tracker()
    t.update(["a", "b"], [0.0, 0.0], [math.nan, math.nan], 0.0)
    assert t.velocities([0, 1]) is None
    t.update(["a", "b"], [0.1, -0.1], [math.nan, 0.5], 0.1)
    np.testing.assert_allclose(t.velocities([0, 1]), [1.0, 0.5])


def test_a_jump_back_starts_a_new_timeline_and_a_small_one_is_stale():
    t = JointStateTracker(["a", "b"])
    assert t.update(["a", "b"], [0.0, 0.0], None, 10.0)
    assert t.update(["a", "b"], [0.1, 0.2], None, 10.1)  # velocities estimated: 1 and 2 rad/s
    np.testing.assert_allclose(t.qdot, [1.0, 2.0])
    # reordered in transit (older by less than JUMP_BACK): ignored
    assert not t.update(["a", "b"], [5.0, 5.0], None, 10.1 - 0.5 * JUMP_BACK)
    assert t.stale_samples == 2 and t.jumps_back == 0
    # a bag or simulation restarted: taken, with no velocity estimated across the jump
    assert t.update(["a", "b"], [0.3, 0.4], None, 10.1 - 2 * JUMP_BACK)
    assert t.jumps_back == 1 and t.qdot is None
    np.testing.assert_array_equal(t.q, [0.3, 0.4])
    assert t.update(["a", "b"], [0.4, 0.6], None, 10.2 - 2 * JUMP_BACK)  # estimated again
    np.testing.assert_allclose(t.qdot, [1.0, 2.0])
    assert t.latest_stamp == pytest.approx(10.2 - 2 * JUMP_BACK)
