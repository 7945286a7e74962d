"""Real descriptions from example-robot-data (Panda with its hand, Tiago, PR2, Baxter, Z1, UR5,
UR10, UR3 without its robot name) against Pinocchio, an oracle nobody here wrote: FK, the world, space and body Jacobians and
every link pose agree to 1e-9 on arm chains and on chains through mimic followers; IK answers keep
every joint within its limits, followers' included.

Pinocchio (`buildModelFromUrdf` without `mimic=True`) makes a mimic follower an independent
joint, so the follower's value θ = m·q + c is set here by hand, and our Jacobian (columns of the
actuated variables) is compared with Pinocchio's columns of the moving joints times the mimic map:
J = J_θ G. The chain's base need not be Pinocchio's world (the URDF root): poses are compared as
T_base_link = (oMbase)⁻¹ oMlink, Jacobians in base axes.
"""

from __future__ import annotations

import numpy as np
import pytest
from kin_testing import PinocchioOracle, erd_path

from kinematics_node.core import IKOptions, RobotDescriptionError, SerialChain, se3
from kinematics_node.core.urdf import RobotDescription

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip 'pin') is the oracle for these tests")

PANDA = "panda_description/urdf/panda.urdf"
TIAGO = "tiago_description/robots/tiago.urdf"
PR2 = "pr2_description/urdf/pr2.urdf"
BAXTER = "baxter_description/urdf/baxter.urdf"
Z1 = "z1_description/urdf/z1.urdf"
UR5 = "ur_description/urdf/ur5_robot.urdf"
UR10 = "ur_description/urdf/ur10_robot.urdf"

#: (file, base link or None, tip link, mimic followers expected on the chain)
CHAINS = [
    (PANDA, None, "panda_hand", 0),
    (PANDA, None, "panda_hand_tcp", 0),
    (PANDA, None, "panda_leftfinger", 0),  # the leader finger_joint1 on the chain
    (PANDA, None, "panda_rightfinger", 1),  # the follower finger_joint2, its leader elsewhere
    (TIAGO, None, "arm_tool_link", 0),  # torso (prismatic) + 7 arm joints
    (TIAGO, "torso_lift_link", "hand_index_flex_3_link", 0),  # arm + three finger joints
    (TIAGO, None, "head_2_link", 0),
    (PR2, "base_link", "r_gripper_palm_link", 0),  # torso + 7 (two continuous)
    (PR2, "torso_lift_link", "l_wrist_roll_link", 0),
    (PR2, "base_link", "r_gripper_l_finger_tip_link", 1),  # leader and follower both on it
    (PR2, "base_link", "r_gripper_r_finger_tip_link", 2),  # two followers, leader elsewhere
    (PR2, "torso_lift_link", "l_gripper_r_parallel_link", 1),  # multiplier −1
    (BAXTER, None, "left_hand_link", 0),
    (BAXTER, "right_arm_mount", "r_gripper_r_finger", 1),  # prismatic follower, multiplier −1
    (BAXTER, None, "l_gripper_l_finger", 0),
    (Z1, None, None, 0),
    (UR5, None, "tool0", 0),
    (UR10, "base_link", "ee_link", 0),
]


def _id(param) -> str:
    path, base, tip, _ = param
    return f"{path.split('/')[-1][:-5]}:{base or ''}->{tip or ''}"


class MimicOracle:
    """Pinocchio's model of a whole description, its mimic joints independent, read in the
    chain's terms: q (n actuated values) → θ = G q + offset on the chain's moving joints."""

    def __init__(self, model, chain: SerialChain) -> None:
        self.model, self.data, self.chain = model, model.createData(), chain
        self.joints = [model.joints[model.getJointId(n)] for n in chain.moving_joint_names]
        self.cols = [j.idx_v for j in self.joints]
        self.base_id = model.getFrameId(chain.base_link, pin.BODY)

    @classmethod
    def of(cls, path_or_xml, chain: SerialChain) -> MimicOracle:
        text = path_or_xml.read_text() if hasattr(path_or_xml, "read_text") else path_or_xml
        return cls(pin.buildModelFromXML(text), chain)

    def configuration(self, q: np.ndarray) -> np.ndarray:
        theta = self.chain.G @ q + self.chain.offset  # the mimic, applied by hand
        out = pin.neutral(self.model)
        for joint, value in zip(self.joints, theta, strict=True):
            if joint.nq == 2:  # continuous: (cos θ, sin θ)
                out[joint.idx_q : joint.idx_q + 2] = (np.cos(value), np.sin(value))
            else:
                out[joint.idx_q] = value
        return out

    def poses(self, q: np.ndarray, links) -> list[np.ndarray]:
        """T_base_link for each link."""
        pin.framesForwardKinematics(self.model, self.data, self.configuration(q))
        base_inv = se3.inverse(self.data.oMf[self.base_id].homogeneous)
        return [
            base_inv @ self.data.oMf[self.model.getFrameId(link, pin.BODY)].homogeneous
            for link in links
        ]

    def jacobians(self, q: np.ndarray, link: str) -> dict[str, np.ndarray]:
        """{"world", "space", "body": (6, n)} of `link` in the chain's terms, rows (ω, v)."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, self.configuration(q))
        pin.updateFramePlacements(model, data)
        fid = model.getFrameId(link, pin.BODY)
        T_o_base = data.oMf[self.base_id].homogeneous
        R_t = T_o_base[:3, :3].T
        out = {}
        for frame, ref in (
            ("world", pin.LOCAL_WORLD_ALIGNED),
            ("space", pin.WORLD),
            ("body", pin.LOCAL),
        ):
            Jp = pin.getFrameJacobian(model, data, fid, ref)[:, self.cols]
            J = np.vstack((Jp[3:], Jp[:3])) @ self.chain.G  # (ω, v), actuated columns
            if frame == "world":  # Pinocchio's world axes → the chain base's axes
                J = np.vstack((R_t @ J[:3], R_t @ J[3:]))
            elif frame == "space":  # spatial twist about the world origin → about the base's
                J = se3.adjoint(se3.inverse(T_o_base)) @ J
            out[frame] = J
        return out


def random_q(chain: SerialChain, rng: np.random.Generator, n: int) -> np.ndarray:
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    return rng.uniform(lo, hi, size=(n, chain.dof))


@pytest.fixture(params=CHAINS, ids=[_id(p) for p in CHAINS])
def real_chain(request):
    rel, base, tip, n_followers = request.param
    path = erd_path(rel)
    chain = SerialChain.from_urdf(path, base, tip)
    assert len(chain.mimic_joints) == n_followers
    return chain, path


def test_fk_jacobians_and_link_poses_match_pinocchio(real_chain) -> None:
    chain, path = real_chain
    oracle = MimicOracle.of(path, chain)
    for q in random_q(chain, np.random.default_rng(22), 12):
        refs = oracle.poses(q, chain.link_names)
        np.testing.assert_allclose(chain.fk(q), refs[-1], atol=1e-9, rtol=0)
        for link, T, T_ref in zip(chain.link_names, chain.link_poses(q), refs, strict=True):
            np.testing.assert_allclose(T, T_ref, atol=1e-9, rtol=0, err_msg=link)
        J_ref = oracle.jacobians(q, chain.tip_link)
        for frame in ("world", "space", "body"):
            np.testing.assert_allclose(
                chain.jacobian(q, frame), J_ref[frame], atol=1e-9, rtol=0, err_msg=frame
            )
        np.testing.assert_allclose(chain.jacobian(q), J_ref["world"], atol=1e-9, rtol=0)


def test_batched_fk_and_jacobian_match_pinocchio(real_chain) -> None:
    chain, path = real_chain
    oracle = MimicOracle.of(path, chain)
    Q = random_q(chain, np.random.default_rng(23), 6).reshape(2, 3, chain.dof)
    T, J = chain.fk_jacobian(Q, "world")
    for idx in np.ndindex(2, 3):
        np.testing.assert_allclose(T[idx], oracle.poses(Q[idx], [chain.tip_link])[0], atol=1e-9)
        np.testing.assert_allclose(
            J[idx], oracle.jacobians(Q[idx], chain.tip_link)["world"], atol=1e-9
        )


def test_poe_model_reproduces_fk(real_chain) -> None:
    """T(q) = e^{[S₁]θ₁} ⋯ e^{[Sₘ]θₘ} M = M e^{[B₁]θ₁} ⋯ e^{[Bₘ]θₘ}, θ = G q + offset."""
    chain, _ = real_chain
    m = len(chain.moving_joint_names)
    assert chain.S.shape == chain.B.shape == (6, m) and chain.G.shape == (m, chain.dof)
    for q in random_q(chain, np.random.default_rng(24), 5):
        theta = chain.G @ q + chain.offset
        Ts, Tb = np.eye(4), np.asarray(chain.M)
        for k in range(m):
            Ts = Ts @ se3.exp(chain.S[:, k] * theta[k])
            Tb = Tb @ se3.exp(chain.B[:, k] * theta[k])
        np.testing.assert_allclose(Ts @ chain.M, chain.fk(q), atol=1e-12)
        np.testing.assert_allclose(Tb, chain.fk(q), atol=1e-12)


# ----------------------------------------------------------------------------- IK and limits
IK_CHAINS = [
    (PANDA, None, "panda_hand"),
    (PANDA, None, "panda_rightfinger"),
    (TIAGO, "torso_lift_link", "arm_tool_link"),
    (PR2, "torso_lift_link", "r_gripper_r_finger_tip_link"),
    (PR2, "torso_lift_link", "l_gripper_r_parallel_link"),  # the leader pinned at 0 by −1
    (BAXTER, "right_arm_mount", "r_gripper_r_finger"),
    (Z1, None, None),
    (UR5, None, "tool0"),
]


def assert_within_every_limit(chain: SerialChain, q: np.ndarray, what: str) -> None:
    """q within the chain's limits, and every moving joint (followers included) within its own."""
    tol = 1e-12
    assert np.all(q >= chain.lower - tol) and np.all(q <= chain.upper + tol), (what, q)
    assert np.all(q >= chain.own_lower - tol) and np.all(q <= chain.own_upper + tol), (what, q)
    theta = chain.G @ q + chain.offset
    low = theta < chain.moving_lower - tol
    high = theta > chain.moving_upper + tol
    bad = [chain.moving_joint_names[k] for k in np.flatnonzero(low | high)]
    assert not bad, f"{what}: {bad} outside their own limits at θ = {theta}"


@pytest.mark.parametrize("rel, base, tip", IK_CHAINS, ids=[_id((*p, 0)) for p in IK_CHAINS])
def test_ik_round_trips_within_every_joints_limits(rel, base, tip, batch_path) -> None:
    chain = SerialChain.from_urdf(erd_path(rel), base, tip)
    rng = np.random.default_rng(25)
    Q = random_q(chain, rng, 8)
    T = chain.fk(Q)
    seeds = random_q(chain, rng, 8)
    opts = IKOptions(position_tolerance=1e-8, orientation_tolerance=1e-8, timeout=0.5, rng_seed=3)
    batch = chain.ik_batch(T, seeds, options=opts)
    for k in range(len(T)):
        res = chain.ik(T[k], seeds[k], options=opts)
        for q, ok, how in ((res.q, res.success, "ik"), (batch.q[k], batch.success[k], "batch")):
            assert ok, f"{how}: target {k} not solved"
            assert_within_every_limit(chain, q, f"{how} target {k}")
            np.testing.assert_allclose(chain.fk(q), T[k], atol=1e-7)


# ----------------------------------------------------------------------------- edited descriptions
def _edit(rel: str, old: str, new: str) -> str:
    """The text of a real description with one exact edit (the edit must apply)."""
    text = erd_path(rel).read_text()
    assert text.count(old) == 1, old
    return text.replace(old, new)


def _pr2_tip_follows(multiplier: str, offset: str) -> str:
    return _edit(
        PR2,
        '<mimic joint="r_gripper_l_finger_joint" multiplier="1" offset="0"/>\n'
        '    <parent link="r_gripper_l_finger_link"/>',
        f'<mimic joint="r_gripper_l_finger_joint" multiplier="{multiplier}" offset="{offset}"/>\n'
        '    <parent link="r_gripper_l_finger_link"/>',
    )


def _panda_finger2(attrs: str, limit: str = 'lower="0.0" upper="0.04"') -> str:
    text = _edit(
        PANDA,
        '<mimic joint="panda_finger_joint1"/>',
        f'<mimic joint="panda_finger_joint1" {attrs}/>',
    )
    old = '<axis xyz="0 -1 0"/>\n        <limit effort="100" lower="0.0" upper="0.04"'
    assert text.count(old) == 1
    return text.replace(old, f'<axis xyz="0 -1 0"/>\n        <limit effort="100" {limit}')


EDITED = {
    # leader and follower on the chain, multiplier −0.5, offset 0.1 rad
    "pr2 tip -0.5x+0.1": (
        lambda: _pr2_tip_follows("-0.5", "0.1"),
        "base_link",
        "r_gripper_l_finger_tip_link",
    ),
    # a prismatic follower whose leader is off the chain, multiplier 0.5, offset 0.01 m
    "panda finger 0.5x+0.01": (
        lambda: _panda_finger2('multiplier="0.5" offset="0.01"'),
        None,
        "panda_rightfinger",
    ),
}


@pytest.mark.parametrize("name", EDITED)
def test_followers_with_multiplier_and_offset_match_pinocchio(name) -> None:
    make, base, tip = EDITED[name]
    text = make()
    chain = SerialChain.from_urdf(text, base, tip)
    (mimic,) = chain.mimic_joints
    assert mimic.multiplier != 1.0 and mimic.offset != 0.0
    assert chain.solver_model.G is not None  # the general path, θ = G q + offset
    oracle = MimicOracle.of(text, chain)
    for q in random_q(chain, np.random.default_rng(26), 10):
        refs = oracle.poses(q, chain.link_names)
        for link, T, T_ref in zip(chain.link_names, chain.link_poses(q), refs, strict=True):
            np.testing.assert_allclose(T, T_ref, atol=1e-9, rtol=0, err_msg=link)
        J_ref = oracle.jacobians(q, chain.tip_link)
        for frame in ("world", "space", "body"):
            np.testing.assert_allclose(chain.jacobian(q, frame), J_ref[frame], atol=1e-9, rtol=0)
        theta = chain.G @ q + chain.offset
        Ts, Tb = np.eye(4), np.asarray(chain.M)
        for k in range(len(theta)):
            Ts = Ts @ se3.exp(chain.S[:, k] * theta[k])
            Tb = Tb @ se3.exp(chain.B[:, k] * theta[k])
        np.testing.assert_allclose(Ts @ chain.M, chain.fk(q), atol=1e-12)
        np.testing.assert_allclose(Tb, chain.fk(q), atol=1e-12)


NON_UNIT_AXES = """<robot name="axes">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <origin xyz="0 0 0.3" rpy="0.1 0.2 0.3"/><axis xyz="0.707 0 0.707"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="a"/><child link="b"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 0 2"/>
    <limit lower="-0.3" upper="0.3" effort="1" velocity="1"/></joint>
  <joint name="j3" type="continuous"><parent link="b"/><child link="c"/>
    <origin xyz="0 0.1 0.2" rpy="-0.4 0 1.0"/><axis xyz="0 0.7071 0.7071"/></joint>
  <joint name="j4" type="revolute"><parent link="c"/><child link="tip"/>
    <origin xyz="0.1 0 0"/><axis xyz="-3 4 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>"""


def test_non_unit_axes_are_normalised_as_pinocchio_does() -> None:
    chain = SerialChain.from_urdf(NON_UNIT_AXES)
    oracle = MimicOracle.of(NON_UNIT_AXES, chain)
    for q in random_q(chain, np.random.default_rng(27), 10):
        np.testing.assert_allclose(chain.fk(q), oracle.poses(q, ["tip"])[0], atol=1e-9)
        J_ref = oracle.jacobians(q, "tip")
        for frame in ("world", "space", "body"):
            np.testing.assert_allclose(chain.jacobian(q, frame), J_ref[frame], atol=1e-9)
    noted = " ".join(chain.notes)
    for name in ("'j1'", "'j2'", "'j3'", "'j4'"):
        assert name in noted  # every adjusted axis is reported (j3's 0.7071 is off by 1e-5)
    assert "norm 5" in noted  # j4: (−3, 4, 0)


# ----------------------------------------------------------------------------- follower limits
def test_ik_keeps_a_follower_with_tighter_limits_inside_them(batch_path) -> None:
    """finger_joint2 (follower, on the chain) allows [0, 0.02] m, its leader [0, 0.04] m: IK must
    never move the leader beyond 0.02, though half the targets were made with it there."""
    text = _panda_finger2("", limit='lower="0.0" upper="0.02"')
    chain = SerialChain.from_urdf(text, None, "panda_rightfinger")
    i = chain.joint_index("panda_finger_joint1")
    assert (chain.own_lower[i], chain.own_upper[i]) == (0.0, 0.04)
    assert (chain.lower[i], chain.upper[i]) == (0.0, 0.02)
    assert any("narrowed to [0, 0.02]" in note for note in chain.notes)
    rng = np.random.default_rng(28)
    Q = rng.uniform(chain.own_lower, chain.own_upper, size=(10, chain.dof))
    Q[::2, i] = rng.uniform(0.03, 0.04, size=5)  # the follower beyond its limit
    T = chain.fk(Q)
    opts = IKOptions(position_tolerance=1e-8, orientation_tolerance=1e-8, timeout=0.3, rng_seed=5)
    batch = chain.ik_batch(T, options=opts)
    solved = 0
    for k in range(len(T)):
        res = chain.ik(T[k], options=opts)
        for q, ok in ((res.q, res.success), (batch.q[k], batch.success[k])):
            assert_within_every_limit(chain, q, f"target {k}")
            if ok:
                np.testing.assert_allclose(chain.fk(q), T[k], atol=1e-7)
            solved += bool(ok)
    assert solved >= 16  # the arm moves the hand to make up for the finger (7 joints)


def _ur5_pan_follows(multiplier: str) -> str:
    """UR5 whose shoulder_pan_joint mimics a leader on another branch, with tighter limits."""
    text = _edit(
        UR5,
        '<axis xyz="0 0 1"/>\n    <limit effort="150.0" lower="-6.28318530718" upper="6.28318530718" '
        'velocity="3.15"/>\n    <dynamics damping="0.0" friction="0.0"/>\n  </joint>\n'
        '  <link name="shoulder_link">',
        '<axis xyz="0 0 1"/>\n    <limit effort="150.0" lower="-1.0" upper="0.5" velocity="3.15"/>\n'
        f'    <mimic joint="pan_leader" multiplier="{multiplier}"/>\n  </joint>\n'
        '  <link name="pan_leader_link"/>\n'
        '  <joint name="pan_leader" type="revolute"><parent link="base_link"/>'
        '<child link="pan_leader_link"/><axis xyz="0 0 1"/>'
        '<limit effort="1" lower="-6.28" upper="6.28" velocity="1"/></joint>\n'
        '  <link name="shoulder_link">',
    )
    return text


@pytest.mark.parametrize("multiplier", ["1", "-1"])
def test_ik_and_closed_form_keep_a_mimic_driven_joint_within_its_limits(multiplier) -> None:
    chain = SerialChain.from_urdf(_ur5_pan_follows(multiplier), None, "tool0")
    assert chain.joint_names[0] == "pan_leader"
    m = float(multiplier)
    expected = (-1.0, 0.5) if m > 0 else (-0.5, 1.0)
    np.testing.assert_allclose((chain.lower[0], chain.upper[0]), expected)
    # multiplier 1: θ = q, the closed form applies (S is the arm's); −1: it declines
    assert (chain.ik_family is not None) == (m > 0)
    rng = np.random.default_rng(29)
    Q = rng.uniform(chain.own_lower, chain.own_upper, size=(8, chain.dof))
    Q[:, 1:] = np.clip(Q[:, 1:], -3.0, 3.0)
    T = chain.fk(Q)
    opts = IKOptions(position_tolerance=1e-8, orientation_tolerance=1e-8, timeout=0.3, rng_seed=6)
    solved = 0
    for k in range(len(T)):
        if chain.ik_family is not None:
            every = chain.ik_all(T[k])
            for q in every.solutions:
                assert_within_every_limit(chain, q, f"ik_all target {k}")
                np.testing.assert_allclose(chain.fk(q), T[k], atol=1e-8)
        res = chain.ik(T[k], options=opts)
        assert_within_every_limit(chain, res.q, f"ik target {k}")
        solved += bool(res.success)
    assert solved >= 3  # the shoulder can turn half a turn and flip the elbow for many targets


# =========================================================================== a <robot> without a name
UR3_EMPTY = "ur_description/urdf/ur3.urdf"  # a <robot> without a name, and nothing in it
UR3 = "ur_description/urdf/ur3_robot.urdf"


def test_example_robot_data_ur3_urdf_is_refused_for_what_it_lacks_not_for_its_name() -> None:
    """example-robot-data's ur3.urdf is a <robot> element without a name and without a link: what
    makes it unusable is the missing links (it was refused as yourdfpy's KeyError 'name')."""
    path = erd_path(UR3_EMPTY)
    with pytest.raises(RobotDescriptionError) as refused:
        SerialChain.from_urdf(path)
    assert str(refused.value) == "the robot description has no <link>"
    assert any("<robot> element has no name" in note for note in RobotDescription(path).notes)


def test_a_real_ur3_without_its_robot_name_loads_with_a_note_and_matches_pinocchio() -> None:
    """ur3_robot.urdf with `name="ur3"` removed from <robot> loads, says so in chain.notes, and its
    FK and world Jacobian equal Pinocchio's on the file as shipped (Pinocchio refuses the nameless
    one: "No name given for the robot")."""
    path = erd_path(UR3)
    text = path.read_text(encoding="utf-8")
    nameless = text.replace('<robot name="ur3"', "<robot", 1)
    assert nameless != text and 'name="ur3"' not in nameless.split("<link")[0]
    chain = SerialChain.from_urdf(nameless, None, "tool0")
    assert chain.notes[0].startswith("the <robot> element has no name attribute")
    oracle = PinocchioOracle.from_urdf(path, chain.joint_names)
    for q in random_q(chain, np.random.default_rng(32), 20):
        T_ref, J_ref = oracle.pose_and_jacobians(q, "tool0")
        np.testing.assert_allclose(chain.fk(q), T_ref, atol=1e-9, rtol=0)
        np.testing.assert_allclose(chain.jacobian(q, "world"), J_ref["world"], atol=1e-9, rtol=0)
