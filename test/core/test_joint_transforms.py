"""core.joint_transforms: the parent -> child transform of every joint of a real description
with a gripper (example-robot-data's Panda, fingers and a mimic joint), against Pinocchio's
forward kinematics of every link; the chain's links against the chain's own link poses."""

from __future__ import annotations

import numpy as np
import pytest
from kin_testing import erd_path
from scipy.spatial.transform import Rotation

from kinematics_node.core import SerialChain
from kinematics_node.core.exceptions import RobotDescriptionError, UnknownNameError
from kinematics_node.core.joint_transforms import JointTransforms
from kinematics_node.core.urdf import RobotDescription

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the oracle")

#: finger 2 follows finger 1 with a multiplier and an offset of our choosing, so that the mimic
#: rule is tested beyond the identity (Pinocchio is given the follower's value by hand).
MIMIC = (
    '<mimic joint="panda_finger_joint1"/>',
    '<mimic joint="panda_finger_joint1" multiplier="-0.5" offset="0.01"/>',
)


@pytest.fixture(scope="module")
def panda_text() -> str:
    text = erd_path("panda_description/urdf/panda.urdf").read_text()
    assert MIMIC[0] in text
    return text.replace(*MIMIC)


def test_every_joint_of_the_panda_with_its_fingers_matches_pinocchio(panda_text):
    description = RobotDescription(panda_text)
    tf = JointTransforms(description)
    assert set(tf.joint_names) == description.joint_names  # every joint: fixed ones too
    assert "panda_finger_joint2" not in tf.inputs and "panda_finger_joint1" in tf.inputs
    assert tf.moving.sum() == 9 and (~tf.moving).sum() == len(tf.joint_names) - 9
    model = pin.buildModelFromXML(panda_text)  # no mimic: finger 2 is set by hand below
    data = model.createData()
    rng = np.random.default_rng(11)
    values = rng.uniform(-2.5, 2.5, size=(25, len(tf.inputs)))
    values[:, tf.inputs.index("panda_finger_joint1")] = rng.uniform(0, 0.04, 25)
    t, quat = tf.transforms(values)
    assert (quat[..., 3] >= 0).all()
    for row, v in enumerate(values):
        q = pin.neutral(model)
        by_name = dict(zip(tf.inputs, v, strict=True))
        by_name["panda_finger_joint2"] = -0.5 * by_name["panda_finger_joint1"] + 0.01
        for name, value in by_name.items():
            q[model.joints[model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(model, data, q)
        for k, (parent, child) in enumerate(zip(tf.parents, tf.children, strict=True)):
            T = (
                data.oMf[model.getFrameId(parent)].inverse() * data.oMf[model.getFrameId(child)]
            ).homogeneous
            np.testing.assert_allclose(t[row, k], T[:3, 3], atol=1e-12)
            R = Rotation.from_quat(quat[row, k]).as_matrix()
            np.testing.assert_allclose(R, T[:3, :3], atol=1e-12)


def test_the_chains_links_agree_with_the_chain(panda_path):
    """Over a chain's links (what a recording writes), each link's pose in the one before it is
    the chain's own FK of the two, T_base_parent⁻¹ T_base_child, to rounding; the fixed ones do
    not move with q."""
    from kinematics_node.core.so3 import quaternion_from_matrix

    description = RobotDescription(str(panda_path))
    chain = SerialChain.from_urdf(panda_path, tip_link="panda_hand")
    tf = JointTransforms.of_links(description, chain.link_names)
    assert tf.children == chain.link_names[1:]
    assert tf.inputs == chain.joint_names
    q = np.random.default_rng(2).uniform(chain.lower, chain.upper, size=(50, chain.dof))
    t, quat = tf.transforms(q)
    T = chain.link_poses(q)
    rel = np.linalg.inv(T[:, :-1]) @ T[:, 1:]
    np.testing.assert_allclose(t, rel[..., :3, 3], atol=1e-12)
    np.testing.assert_allclose(quat, quaternion_from_matrix(rel[..., :3, :3]), atol=1e-12)
    spread = np.ptp(rel, axis=0).max(axis=(-1, -2))
    assert (spread[~tf.moving] < 1e-12).all() and (spread[tf.moving] > 1e-3).all()


def test_refusals_name_the_problem(panda_path):
    description = RobotDescription(str(panda_path))
    with pytest.raises(UnknownNameError, match="no_such_joint"):
        JointTransforms(description, ["no_such_joint"])
    with pytest.raises(RobotDescriptionError, match="not a chain"):
        JointTransforms.of_links(description, ["panda_link0", "panda_link2"])
    tf = JointTransforms(description, ["panda_joint1"])
    with pytest.raises(ValueError, match=r"\(N, 1\)"):
        tf.transforms(np.zeros((3, 2)))
    circle = RobotDescription(
        '<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="j2"/></joint>'
        '<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="j1"/></joint></robot>'
    )
    with pytest.raises(RobotDescriptionError, match="circle"):
        JointTransforms(circle)
