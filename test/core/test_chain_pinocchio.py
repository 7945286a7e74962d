"""FK, Jacobians and link poses against Pinocchio on real arm descriptions (agreement to 1e-9)."""

import numpy as np
import pytest
from kin_testing import random_q

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip 'pin') is the oracle for these tests")


class PinOracle:
    def __init__(self, chain, path):
        self.model = pin.buildModelFromUrdf(str(path))
        self.data = self.model.createData()
        self.chain = chain
        self.base = self.model.getFrameId(chain.base_link)
        self.tip = self.model.getFrameId(chain.tip_link)
        self.cols = [self.model.joints[self.model.getJointId(n)].idx_v for n in chain.joint_names]

    def q(self, q):
        qp = pin.neutral(self.model)
        for name, v in zip(self.chain.joint_names, q, strict=True):
            joint = self.model.joints[self.model.getJointId(name)]
            if joint.nq == 2:  # continuous joints are (cos, sin) in Pinocchio
                qp[joint.idx_q : joint.idx_q + 2] = (np.cos(v), np.sin(v))
            else:
                qp[joint.idx_q] = v
        return qp

    def fk_and_jacobians(self, q, frame_id=None):
        fid = self.tip if frame_id is None else frame_id
        qp = self.q(q)
        pin.computeJointJacobians(self.model, self.data, qp)
        pin.updateFramePlacements(self.model, self.data)
        oMb = self.data.oMf[self.base]
        T = (oMb.inverse() * self.data.oMf[fid]).homogeneous
        J = {}
        for name, ref in (
            ("world", pin.LOCAL_WORLD_ALIGNED),
            ("body", pin.LOCAL),
            ("space", pin.WORLD),
        ):
            Jp = pin.getFrameJacobian(self.model, self.data, fid, ref)[:, self.cols]
            J[name] = np.vstack((Jp[3:], Jp[:3]))  # Pinocchio orders (v, ω); we order (ω, v)
        assert np.allclose(oMb.homogeneous, np.eye(4))  # chain base is Pinocchio's world here
        return T, J


def test_fk_and_all_jacobians_match_pinocchio(real_arm):
    chain, path = real_arm
    oracle = PinOracle(chain, path)
    rng = np.random.default_rng(11)
    for q in random_q(chain, rng, 25):
        T_ref, J_ref = oracle.fk_and_jacobians(q)
        np.testing.assert_allclose(chain.fk(q), T_ref, atol=1e-9, rtol=0)
        for frame in ("world", "body", "space"):
            np.testing.assert_allclose(chain.jacobian(q, frame), J_ref[frame], atol=1e-9, rtol=0)


def test_batched_fk_and_jacobian_match_pinocchio(real_arm):
    chain, path = real_arm
    oracle = PinOracle(chain, path)
    Q = random_q(chain, np.random.default_rng(12), 40).reshape(4, 10, chain.dof)
    T = chain.fk(Q)
    assert T.shape == (4, 10, 4, 4)
    for frame in ("world", "body", "space"):
        J = chain.jacobian(Q, frame)
        assert J.shape == (4, 10, 6, chain.dof)
        for idx in [(0, 0), (1, 3), (3, 9)]:
            T_ref, J_ref = oracle.fk_and_jacobians(Q[idx])
            np.testing.assert_allclose(T[idx], T_ref, atol=1e-9, rtol=0)
            np.testing.assert_allclose(J[idx], J_ref[frame], atol=1e-9, rtol=0)


def test_every_chain_link_pose_matches_pinocchio(real_arm):
    chain, path = real_arm
    oracle = PinOracle(chain, path)
    q = random_q(chain, np.random.default_rng(13))
    poses = chain.link_poses(q)
    assert poses.shape == (len(chain.link_names), 4, 4)
    for link, T in zip(chain.link_names, poses, strict=True):
        T_ref, _ = oracle.fk_and_jacobians(q, oracle.model.getFrameId(link, pin.BODY))
        np.testing.assert_allclose(T, T_ref, atol=1e-9, rtol=0, err_msg=link)
    np.testing.assert_allclose(chain.link_pose(q, chain.tip_link), chain.fk(q), atol=1e-12)


def test_mimic_finger_chain_matches_pinocchio_with_mimic_applied():
    """Panda base → right finger: finger_joint2 mimics finger_joint1 (folded into its column)."""
    from kin_testing import erd_path

    from kinematics_node.core import SerialChain

    path = erd_path("panda_description/urdf/panda.urdf")
    text = path.read_text()
    if "mimic" not in text:
        pytest.skip("this panda.urdf has no mimic joint")
    chain = SerialChain.from_urdf(path, "panda_link0", "panda_rightfinger")
    assert chain.joint_names[-1] == "panda_finger_joint1"  # the leader, though not on the path
    assert "panda_finger_joint2" not in chain.joint_names
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    rng = np.random.default_rng(14)
    for q in random_q(chain, rng, 10):
        qp = pin.neutral(model)
        for name in model.names[1:]:
            jid = model.getJointId(name)
            src = "panda_finger_joint1" if name == "panda_finger_joint2" else name
            if src in chain.joint_names:
                qp[model.joints[jid].idx_q] = q[chain.joint_index(src)]
        pin.framesForwardKinematics(model, data, qp)
        T_ref = data.oMf[model.getFrameId("panda_rightfinger")].homogeneous
        np.testing.assert_allclose(chain.fk(q), T_ref, atol=1e-9)
