"""FK, Jacobians and link poses against Pinocchio on real arm descriptions (agreement to 1e-9)."""

import numpy as np
import pytest
from kin_testing import PinocchioOracle, random_q

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip 'pin') is the oracle for these tests")


def _oracle(chain, path) -> PinocchioOracle:
    oracle = PinocchioOracle.from_urdf(path, chain.joint_names)
    oMb = oracle.pose(np.zeros(chain.dof), chain.base_link)
    assert np.allclose(oMb, np.eye(4))  # chain base is Pinocchio's world here
    return oracle


def test_fk_and_all_jacobians_match_pinocchio(real_arm):
    chain, path = real_arm
    oracle = _oracle(chain, path)
    rng = np.random.default_rng(11)
    for q in random_q(chain, rng, 25):
        T_ref, J_ref = oracle.pose_and_jacobians(q, chain.tip_link)
        np.testing.assert_allclose(chain.fk(q), T_ref, atol=1e-9, rtol=0)
        for frame in ("world", "body", "space"):
            np.testing.assert_allclose(chain.jacobian(q, frame), J_ref[frame], atol=1e-9, rtol=0)


def test_batched_fk_and_jacobian_match_pinocchio(real_arm):
    chain, path = real_arm
    oracle = _oracle(chain, path)
    Q = random_q(chain, np.random.default_rng(12), 40).reshape(4, 10, chain.dof)
    T = chain.fk(Q)
    assert T.shape == (4, 10, 4, 4)
    for frame in ("world", "body", "space"):
        J = chain.jacobian(Q, frame)
        assert J.shape == (4, 10, 6, chain.dof)
        for idx in [(0, 0), (1, 3), (3, 9)]:
            T_ref, J_ref = oracle.pose_and_jacobians(Q[idx], chain.tip_link)
            np.testing.assert_allclose(T[idx], T_ref, atol=1e-9, rtol=0)
            np.testing.assert_allclose(J[idx], J_ref[frame], atol=1e-9, rtol=0)


def test_every_chain_link_pose_matches_pinocchio(real_arm):
    chain, path = real_arm
    oracle = _oracle(chain, path)
    q = random_q(chain, np.random.default_rng(13))
    poses = chain.link_poses(q)
    assert poses.shape == (len(chain.link_names), 4, 4)
    for link, T in zip(chain.link_names, poses, strict=True):
        T_ref, _ = oracle.pose_and_jacobians(q, oracle.model.getFrameId(link, pin.BODY))
        np.testing.assert_allclose(T, T_ref, atol=1e-9, rtol=0, err_msg=link)
    np.testing.assert_allclose(chain.link_pose(q, chain.tip_link), chain.fk(q), atol=1e-12)


def test_mimic_finger_chain_matches_pinocchio_with_mimic_applied():
    """Panda base → right finger: finger_joint2 mimics finger_joint1 (its column, θ = q)."""
    from kin_testing import erd_path

    from kinematics_node.core import SerialChain

    path = erd_path("panda_description/urdf/panda.urdf")
    text = path.read_text()
    if "mimic" not in text:
        pytest.skip("this panda.urdf has no mimic joint")
    chain = SerialChain.from_urdf(path, "panda_link0", "panda_rightfinger")
    assert chain.joint_names[-1] == "panda_finger_joint1"  # the leader, though not on the path
    assert "panda_finger_joint2" not in chain.joint_names
    oracle = PinocchioOracle.from_urdf(path, chain.joint_names)
    finger2 = oracle.model.joints[oracle.model.getJointId("panda_finger_joint2")].idx_q
    rng = np.random.default_rng(14)
    for q in random_q(chain, rng, 10):
        qp = oracle.q(q)
        qp[finger2] = q[chain.joint_index("panda_finger_joint1")]  # the mimic, applied by hand
        T_ref = oracle.pose_of_configuration(qp, "panda_rightfinger")
        np.testing.assert_allclose(chain.fk(q), T_ref, atol=1e-9)
