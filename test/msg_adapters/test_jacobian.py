"""msg_adapters.jacobian against real ROS 2 message classes (rosbags): row order, refusals."""

from __future__ import annotations

import numpy as np
import pytest

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError


# --------------------------------------------------------------------------- Jacobian
def test_jacobian_fields_are_ros_ordered_row_major_and_invert(ros):
    rng = np.random.default_rng(2)
    J = rng.normal(size=(6, 4))  # core rows (ω, v)
    resp = ros.response("ComputeJacobian")
    ma.fill_jacobian_fields(resp, J, ["a", "b", "c", "d"])
    assert ros.rclpy_type_problems(resp) == []
    assert resp.rows == 6 and resp.cols == 4
    assert resp.row_labels[0] == "linear_x" and resp.row_labels[3] == "angular_x"
    assert resp.jacobian[1 * 4 + 2] == J[4, 2]  # ROS row 1 = linear y = core row 4
    assert resp.jacobian[3 * 4 + 0] == J[0, 0]  # ROS row 3 = angular x = core row 0
    np.testing.assert_array_equal(ma.jacobian_from_fields(ros.roundtrip(resp)), J)


def test_jacobian_fields_refuse_inconsistent_sizes(ros):
    resp = ros.response("ComputeJacobian")
    resp.rows, resp.cols, resp.jacobian = 6, 2, [0.0] * 11
    with pytest.raises(InvalidInputError, match="11 values"):
        ma.jacobian_from_fields(resp)
    with pytest.raises(InvalidInputError, match="2 joint names"):
        ma.fill_jacobian_fields(resp, np.zeros((6, 3)), ["a", "b"])
