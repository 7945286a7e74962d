"""KinematicsService and robot descriptions as real robots ship them: a Panda with its hand (several
leaves) held until a tip is chosen, a second robot replacing the first, base_link/tip_link checked
against the description held, robot_description_file with xacro arguments, the precedence of the
three sources, FK of several links in one request, and what /diagnostics says in each state.

Oracles: Pinocchio on the same URDFs (poses), and the URDF's own <joint> elements read here with
ElementTree (which links are leaves).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from kin_testing import PinocchioOracle
from service_testing import check_message, js

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError, KinematicsError
from kinematics_node.service.kinematics import NO_DESCRIPTION, KinematicsService

ROBOTS = Path(__file__).resolve().parents[2] / "config" / "robots"
UR5E = ROBOTS / "ur5e.urdf"
PANDA_ARM = [f"panda_joint{k}" for k in range(1, 8)]
Q_PANDA = np.array([0.1, -0.4, 0.3, -2.0, 0.2, 1.7, 0.6])
Q_UR5E = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
UR5E_JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]
SET_TIP = "ros2 param set /kinematics_node tip_link <link>"


def leaves(urdf_text: str) -> list[str]:
    """Links that are no joint's parent (the oracle of the candidate tips: every leaf of these
    robots is moved by some joint)."""
    root = ET.fromstring(urdf_text)
    parents = {j.find("parent").get("link") for j in root.iter("joint")}
    return [link.get("name") for link in root.iter("link") if link.get("name") not in parents]


def values(svc: KinematicsService) -> dict[str, str]:
    return {kv.key: kv.value for kv in svc.diagnostics().status[0].values}


def level(ros, svc: KinematicsService) -> str:
    S = ros.cls("diagnostic_msgs/msg/DiagnosticStatus")
    code = svc.diagnostics().status[0].level
    return {S.OK: "OK", S.WARN: "WARN", S.ERROR: "ERROR"}[code]


def answers(ros, svc: KinematicsService) -> list:
    """One answer of each service, with an empty request (the current state)."""
    out = [
        svc.compute_fk(ros.request("ComputeFK"), ros.response("ComputeFK")),
        svc.compute_jacobian(ros.request("ComputeJacobian"), ros.response("ComputeJacobian")),
    ]
    ik = ros.request("ComputeIK")
    ik.target.pose.orientation.w = 1.0
    out.append(svc.compute_ik(ik, ros.response("ComputeIK")))
    return out


def fk(ros, svc, names, positions, tip_link="", link_names=()):
    req = ros.request(
        "ComputeFK",
        joint_state=js(ros, names, positions, t=2.5),
        tip_link=tip_link,
        link_names=list(link_names),
    )
    return svc.compute_fk(req, ros.response("ComputeFK"))


@pytest.fixture
def panda_text(panda_path) -> str:
    return panda_path.read_text(encoding="utf-8")


@pytest.fixture
def panda_pin(panda_path) -> PinocchioOracle:
    """Pinocchio's Panda with both finger joints as variables (the service gets only the first:
    the second mimics it with multiplier 1)."""
    return PinocchioOracle.from_urdf(
        panda_path, PANDA_ARM + ["panda_finger_joint1", "panda_finger_joint2"]
    )


# =========================================================================== a tip to choose
def test_a_panda_with_its_hand_is_held_waiting_and_says_which_tips_there_are(
    ros, clock, panda_text
):
    svc = KinematicsService(ros.types, {}, clock=clock)
    assert svc.status.state == "none" and level(ros, svc) == "ERROR"
    status = svc.load_description(panda_text)  # as the topic delivers it
    tips = leaves(panda_text)
    assert len(tips) == 3  # hand_tcp and the two fingers
    assert status.state == "waiting" and list(status.candidates) == tips
    assert svc.model is None
    # every service answer says so, with the tips and how to choose one
    for resp in answers(ros, svc):
        assert resp.success is False
        assert "no robot description loaded" not in resp.message
        assert "'panda'" in resp.message and SET_TIP in resp.message
        # ros2cli is not on PyPI: the restart that works without it is named too
        assert "--ros-args -p tip_link:=<link>" in resp.message
        for tip in tips:
            assert tip in resp.message
        check_message(ros, resp)
    # joint_states say it too (the node logs it), and /diagnostics
    out = svc.on_joint_state(js(ros, PANDA_ARM, Q_PANDA, t=1.0))
    assert out.pose is None and SET_TIP in out.problem
    v = values(svc)
    assert v["description"] == "waiting" and v["robot_name"] == "panda"
    assert v["candidate_tips"].split(", ") == tips
    assert v["description_source"] == "the robot_description topic"
    assert level(ros, svc) == "WARN" and SET_TIP in svc.diagnostics().status[0].message
    assert any(SET_TIP in text for lvl, text in svc.take_log() if lvl == "warn")


def test_setting_tip_link_builds_the_chain_from_the_held_description(
    ros, clock, panda_text, panda_pin
):
    svc = KinematicsService(ros.types, {}, clock=clock)
    svc.load_description(panda_text)
    with pytest.raises(InvalidInputError, match="'panda_hnd'.*'panda_hand_tcp'"):
        svc.configure({"tip_link": "panda_hnd"})  # a typo: refused, listing the links
    assert svc.status.state == "waiting" and svc.params["tip_link"] == ""
    svc.configure({"tip_link": "panda_hand"})
    assert svc.status.state == "loaded" and svc.model.chain.tip_link == "panda_hand"
    out = svc.on_joint_state(js(ros, PANDA_ARM, Q_PANDA, t=1.0))
    T_pin = panda_pin.pose(np.r_[Q_PANDA, 0.0, 0.0], "panda_hand")
    np.testing.assert_allclose(ma.matrix_from_pose(out.pose.pose), T_pin, atol=1e-9)
    v = values(svc)
    assert v["description"] == "loaded" and v["tip_link"] == "panda_hand" and v["dof"] == "7"
    assert "panda_finger_joint2" in v["description_notes"]  # the mimic joint, from the core
    assert "candidate_tips" not in v


def test_tip_link_given_before_the_description_is_used_when_it_arrives(ros, clock, panda_text):
    svc = KinematicsService(ros.types, {"tip_link": "panda_hand_tcp"}, clock=clock)
    assert svc.status.state == "none"
    svc.load_description(panda_text)
    assert svc.status.state == "loaded" and svc.model.chain.tip_link == "panda_hand_tcp"


def test_a_tip_link_the_description_lacks_at_start_up_holds_it_waiting(ros, clock, panda_text):
    params = {"robot_description": panda_text, "tip_link": "tool0"}
    svc = KinematicsService(ros.types, params, clock=clock)  # not refused, not raised
    assert svc.status.state == "waiting"
    assert "tip_link 'tool0' is not a link of 'panda'" in svc.status.message
    assert list(svc.status.candidates) == leaves(panda_text)
    svc.configure({"tip_link": "panda_hand_tcp"})
    assert svc.status.state == "loaded"


def test_clearing_tip_link_of_a_working_model_is_refused_when_the_tip_would_be_ambiguous(
    ros, clock, panda_text
):
    svc = KinematicsService(
        ros.types, {"robot_description": panda_text, "tip_link": "panda_hand"}, clock=clock
    )
    with pytest.raises(KinematicsError, match="several leaf links"):
        svc.configure({"tip_link": ""})
    assert svc.model.chain.tip_link == "panda_hand" and svc.params["tip_link"] == "panda_hand"
    with pytest.raises(KinematicsError, match="no moving joint"):
        svc.configure({"tip_link": "panda_link0"})  # a link, but no chain to it
    assert svc.model.chain.tip_link == "panda_hand"


def test_base_link_changed_while_waiting_keeps_waiting_with_the_tips_below_it(
    ros, clock, panda_text
):
    svc = KinematicsService(ros.types, {}, clock=clock)
    svc.load_description(panda_text)
    svc.configure({"base_link": "panda_link2"})  # accepted: the tip is still to be chosen
    assert svc.status.state == "waiting" and "'panda_link2'" in svc.status.message
    assert list(svc.status.candidates) == leaves(panda_text)  # all below panda_link2 too
    svc.configure({"tip_link": "panda_leftfinger"})
    chain = svc.model.chain
    assert (chain.base_link, chain.tip_link) == ("panda_link2", "panda_leftfinger")
    assert chain.joint_names == (*PANDA_ARM[2:], "panda_finger_joint1")


# =========================================================================== another robot
def test_a_second_robot_replaces_the_first_and_waits_for_a_tip_of_its_own(ros, clock, panda_text):
    svc = KinematicsService(
        ros.types, {"robot_description": panda_text, "tip_link": "panda_hand"}, clock=clock
    )
    assert svc.status.state == "loaded"
    ur5e = UR5E.read_text(encoding="utf-8")
    status = svc.load_description(ur5e, "the robot_description topic")
    # the UR5e is not refused for the Panda's tip: held, waiting, the Panda's model dropped
    assert status.state == "waiting" and svc.model is None
    assert "tip_link 'panda_hand' is not a link of 'ur5e'" in status.message
    assert list(status.candidates) == leaves(ur5e) == ["tool0"]
    out = svc.on_joint_state(js(ros, PANDA_ARM, Q_PANDA, t=1.0))
    assert out.pose is None  # no Panda pose published for the UR5e
    # a new tip_link is checked against the UR5e, not the Panda
    with pytest.raises(InvalidInputError, match="'panda_hand_tcp' is not a link of 'ur5e'"):
        svc.configure({"tip_link": "panda_hand_tcp"})
    svc.configure({"tip_link": "tool0"})
    resp = fk(ros, svc, UR5E_JOINTS, Q_UR5E)
    assert resp.success, resp.message
    T_pin = PinocchioOracle.from_xml(ur5e, UR5E_JOINTS).pose(Q_UR5E, "tool0")
    np.testing.assert_allclose(ma.matrix_from_pose(resp.pose.pose), T_pin, atol=1e-9)


def test_without_links_set_a_second_robot_uses_its_own_default_chain(ros, clock, panda_text):
    svc = KinematicsService(ros.types, {}, clock=clock)
    svc.load_description(panda_text)
    assert svc.status.state == "waiting"
    svc.load_description(UR5E.read_text(encoding="utf-8"))
    assert svc.status.state == "loaded"
    assert (svc.model.base_link, svc.model.chain.tip_link) == ("base_link", "tool0")
    svc.load_description(panda_text)  # and back: waiting again, for a tip of the Panda
    assert svc.status.state == "waiting" and svc.status.robot_name == "panda"


def test_a_stale_base_link_makes_the_new_robot_wait_for_a_base(ros, clock, panda_text):
    svc = KinematicsService(
        ros.types,
        {"robot_description": panda_text, "base_link": "panda_link0", "tip_link": "panda_hand"},
        clock=clock,
    )
    svc.configure({"robot_description": UR5E.read_text(encoding="utf-8")})
    assert svc.status.state == "waiting"
    assert "base_link 'panda_link0' is not a link of 'ur5e'" in svc.status.message
    assert "ros2 param set /kinematics_node base_link" in svc.status.message
    assert "--ros-args -p base_link:=<link> -p tip_link:=<link>" in svc.status.message
    svc.configure({"tip_link": "tool0"})  # accepted (a UR5e link), still waiting for the base
    assert svc.status.state == "waiting" and "base_link 'panda_link0'" in svc.status.message
    svc.configure({"base_link": ""})
    assert svc.status.state == "loaded" and svc.model.chain.tip_link == "tool0"


def test_the_same_description_again_keeps_the_model(ros, clock):
    text = UR5E.read_text(encoding="utf-8")
    svc = KinematicsService(ros.types, {}, clock=clock)
    svc.load_description(text)
    model = svc.model
    svc.on_joint_state(js(ros, UR5E_JOINTS, Q_UR5E, t=1.0))
    svc.load_description(text)  # robot_state_publisher restarted
    assert svc.model is model
    resp = fk(ros, svc, [], [])  # the current joint state is still known
    assert resp.success, resp.message


# =========================================================================== refusals
def test_a_malformed_description_is_refused_and_the_held_one_stays(ros, clock, panda_text):
    svc = KinematicsService(ros.types, {}, clock=clock)
    svc.load_description(panda_text)
    with pytest.raises(KinematicsError, match="malformed XML"):
        svc.load_description("<robot name='broken'><link name='a'/>")
    assert svc.status.state == "waiting" and svc.status.robot_name == "panda"
    v = values(svc)
    assert v["last_refusal"].startswith("the robot_description topic: malformed XML")
    assert "was refused" in svc.diagnostics().status[0].message
    assert any(lvl == "error" and "malformed XML" in text for lvl, text in svc.take_log())


def test_a_refusal_with_nothing_held_is_what_services_say(ros, clock):
    svc = KinematicsService(ros.types, {}, clock=clock)
    assert not svc.on_description_message(
        "<robot name='r'><link name='a'/><link name='a'/></robot>"
    )
    assert svc.status.state == "refused"
    for resp in answers(ros, svc):
        assert not resp.success
        assert "the robot_description topic was refused" in resp.message
        assert "link 'a' is defined twice" in resp.message
    assert level(ros, svc) == "ERROR"
    assert values(svc)["description"] == "refused"


# =========================================================================== robot_description_file
def test_robot_description_file_loads_the_file_and_says_so(ros, clock):
    svc = KinematicsService(ros.types, {"robot_description_file": str(UR5E)}, clock=clock)
    assert svc.status.state == "loaded" and svc.model.robot_name == "ur5e"
    assert str(UR5E) in values(svc)["description_source"]
    assert not svc.takes_topic


def test_naming_the_file_again_reads_it_again(ros, clock, tmp_path):
    path = tmp_path / "arm.urdf"
    text = UR5E.read_text(encoding="utf-8")
    path.write_text(text, encoding="utf-8")
    svc = KinematicsService(ros.types, {"robot_description_file": str(path)}, clock=clock)
    before = svc.model.chain.fk(Q_UR5E)
    longer = text.replace(
        '<origin xyz="0 0 0.0996" rpy="0 0 0"/>', '<origin xyz="0 0 0.3" rpy="0 0 0"/>'
    )
    assert longer != text
    path.write_text(longer, encoding="utf-8")  # the user edits the file, then sets it again
    svc.configure({"robot_description_file": str(path)})
    after = svc.model.chain.fk(Q_UR5E)
    assert np.linalg.norm(after[:3, 3] - before[:3, 3]) == pytest.approx(0.3 - 0.0996, abs=1e-9)


@pytest.mark.parametrize(
    ("path", "needle"),
    [
        ("/no/such/robot.urdf", "'/no/such/robot.urdf': no such file"),
        (str(ROBOTS), "is a directory"),
    ],
)
def test_a_bad_robot_description_file_is_reported_naming_it(ros, clock, path, needle):
    svc = KinematicsService(ros.types, {"robot_description_file": path}, clock=clock)  # no raise
    assert svc.status.state == "refused" and needle in svc.status.message
    assert "robot_description_file" in svc.status.message
    resp = svc.compute_fk(ros.request("ComputeFK"), ros.response("ComputeFK"))
    assert not resp.success and needle in resp.message
    # set at run time: refused, naming it, nothing changes
    ok = KinematicsService(ros.types, {"robot_description_file": str(UR5E)}, clock=clock)
    with pytest.raises(KinematicsError, match=re.escape(needle)):
        ok.configure({"robot_description_file": path})
    assert ok.params["robot_description_file"] == str(UR5E) and ok.status.state == "loaded"


@pytest.fixture
def prefixed_xacro(tmp_path) -> Path:
    """The UR5e as a xacro file whose link and joint names take a `prefix` argument (without a
    default: the file cannot be expanded without it)."""
    text = UR5E.read_text(encoding="utf-8")
    text = re.sub(r'(<(?:link|joint) name="|<(?:parent|child) link=")', r"\1$(arg prefix)", text)
    # an argument it declares but does not use (as files do for options of other parts)
    text = re.sub(
        r"(<robot [^>]*>)",
        r'<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="ur5e">'
        r'<xacro:arg name="with_gripper" default="false"/>',
        text,
        count=1,
    )
    assert "with_gripper" in text
    path = tmp_path / "ur5e_prefixed.urdf.xacro"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_xacro_file_takes_its_arguments_from_xacro_args(ros, clock, prefixed_xacro):
    pytest.importorskip("xacro", reason="xacro (pip install xacro) expands the file")
    params = {"robot_description_file": str(prefixed_xacro), "xacro_args": "prefix:=left_"}
    svc = KinematicsService(ros.types, params, clock=clock)
    assert svc.status.state == "loaded", svc.status.message
    chain = svc.model.chain
    assert (chain.base_link, chain.tip_link) == ("left_base_link", "left_tool0")
    names = ["left_" + n for n in UR5E_JOINTS]
    resp = fk(ros, svc, names, Q_UR5E)
    assert resp.success, resp.message
    T_pin = PinocchioOracle.from_urdf(UR5E, UR5E_JOINTS).pose(Q_UR5E, "tool0")
    np.testing.assert_allclose(ma.matrix_from_pose(resp.pose.pose), T_pin, atol=1e-9)
    # new arguments at run time (one declared and unused is fine): the file is expanded again
    svc.configure({"xacro_args": "prefix:=right_ with_gripper:=true"})
    chain = svc.model.chain  # no link was set: the new robot's own default chain
    assert (chain.base_link, chain.tip_link) == ("right_base_link", "right_tool0")


@pytest.mark.parametrize(
    ("xacro_args", "needle"),
    [
        ("", "Undefined substitution argument prefix"),  # the file needs it
        ("prefix:=left_ prefx:=a", "xacro_args: 'prefx' is not an argument of"),
        ("prefix", "xacro_args: 'prefix' is not name:=value"),
        ("prefix:='left_", "xacro_args"),  # an unclosed quote
        ("prefix:=a prefix:=b", "'prefix' is given twice"),
    ],
)
def test_bad_xacro_args_are_refused_naming_the_argument(
    ros, clock, prefixed_xacro, xacro_args, needle
):
    pytest.importorskip("xacro", reason="xacro (pip install xacro) expands the file")
    params = {"robot_description_file": str(prefixed_xacro), "xacro_args": xacro_args}
    svc = KinematicsService(ros.types, params, clock=clock)
    assert svc.status.state == "refused"
    assert needle in svc.status.message, svc.status.message


def test_xacro_args_given_to_a_plain_urdf_are_refused_as_unused(ros, clock):
    svc = KinematicsService(
        ros.types, {"robot_description_file": str(UR5E), "xacro_args": "a:=1"}, clock=clock
    )
    assert svc.status.state == "refused"
    assert (
        "'a' is not an argument of" in svc.status.message and "declares none" in svc.status.message
    )


# =========================================================================== precedence
def test_robot_description_wins_over_the_file_which_wins_over_the_topic(ros, clock, panda_text):
    ur5e = UR5E.read_text(encoding="utf-8")
    params = {
        "robot_description": panda_text,
        "tip_link": "panda_hand",
        "robot_description_file": str(UR5E),
    }
    svc = KinematicsService(ros.types, params, clock=clock)
    assert svc.model.robot_name == "panda"
    assert any("is not used" in text for lvl, text in svc.take_log() if lvl == "warn")
    # the topic is kept, not used, while a parameter gives the description
    assert not svc.on_description_message(ur5e.replace('name="ur5e"', 'name="from_topic"'))
    assert svc.model.robot_name == "panda"
    # setting the file at run time while robot_description is set: refused, saying why
    with pytest.raises(InvalidInputError, match="robot_description takes precedence|clear it"):
        svc.configure({"robot_description_file": str(ROBOTS / "iiwa14.urdf")})
    # robot_description cleared: the file (the UR5e) is used, checked against tip_link
    svc.configure({"robot_description": ""})
    assert svc.status.robot_name == "ur5e" and svc.status.state == "waiting"
    svc.configure({"tip_link": "tool0"})
    assert svc.model.robot_name == "ur5e"
    # the file cleared too: the topic's description
    svc.configure({"robot_description_file": ""})
    assert svc.takes_topic and svc.model.robot_name == "from_topic"
    assert svc.status.source == "the robot_description topic"


# =========================================================================== FK of several links
def test_fk_of_several_links_matches_pinocchio_in_the_order_asked(
    ros, clock, panda_text, panda_pin
):
    svc = KinematicsService(
        ros.types, {"robot_description": panda_text, "tip_link": "panda_hand"}, clock=clock
    )
    finger = 0.03  # [m]
    svc.on_joint_state(js(ros, [*PANDA_ARM, "panda_finger_joint1"], [*Q_PANDA, finger], t=1.0))
    links = [
        "panda_rightfinger",  # off the default chain, moved by a mimic joint
        "panda_leftfinger",
        "panda_hand_tcp",  # fixed below the hand
        "panda_link0",  # the base itself
        "panda_link3",  # on the default chain
        "panda_hand",
        "panda_link3",  # asked twice: answered twice
    ]
    q = Q_PANDA + 0.05
    resp = fk(ros, svc, PANDA_ARM, q, link_names=links)
    assert resp.success, resp.message
    check_message(ros, resp)
    assert len(resp.poses) == len(links)
    q_pin = np.r_[q, finger, finger]  # the finger from the node's joint_states
    for link, pose in zip(links, resp.poses, strict=True):
        assert pose.header.frame_id == "panda_link0" and pose.header.stamp.sec == 2
        T = ma.matrix_from_pose(pose.pose)
        np.testing.assert_allclose(T, panda_pin.pose(q_pin, link), atol=1e-9, err_msg=link)
    np.testing.assert_allclose(
        ma.matrix_from_pose(resp.pose.pose), panda_pin.pose(q_pin, "panda_hand"), atol=1e-9
    )
    assert fk(ros, svc, PANDA_ARM, q).poses == []  # no link_names: only `pose`, as before


def test_fk_of_a_fixed_link_on_the_base_needs_no_joint(ros, clock, tmp_path):
    """A camera fixed to the base of a UR5e: its constant pose, even before any joint_states."""
    text = UR5E.read_text(encoding="utf-8").replace(
        "</robot>",
        '<link name="camera"/><joint name="camera_mount" type="fixed"><parent link="base_link"/>'
        '<child link="camera"/><origin xyz="0.1 -0.2 0.8" rpy="0.3 -0.5 1.2"/></joint></robot>',
    )
    svc = KinematicsService(ros.types, {"robot_description": text}, clock=clock)
    # two leaves, so a tip to choose; but the camera cannot be one (no joint moves it)
    assert set(leaves(text)) == {"tool0", "camera"}
    assert svc.status.state == "waiting" and svc.status.candidates == ("tool0",)
    svc.configure({"tip_link": "tool0"})
    req = ros.request("ComputeFK", link_names=["camera"], joint_state=js(ros, UR5E_JOINTS, Q_UR5E))
    resp = svc.compute_fk(req, ros.response("ComputeFK"))
    assert resp.success, resp.message
    T_pin = PinocchioOracle.from_xml(text, UR5E_JOINTS).pose(Q_UR5E, "camera")
    np.testing.assert_allclose(ma.matrix_from_pose(resp.poses[0].pose), T_pin, atol=1e-12)


@pytest.mark.parametrize(
    ("links", "base_link", "needle"),
    [
        (["panda_hand", "nope"], "", "link_names[1]: unknown link 'nope'"),
        (["panda_link0"], "panda_link2", "link_names[0]: link 'panda_link0' is not below"),
    ],
)
def test_fk_of_links_that_cannot_be_given_names_them(
    ros, clock, panda_text, links, base_link, needle
):
    params = {"robot_description": panda_text, "tip_link": "panda_hand", "base_link": base_link}
    svc = KinematicsService(ros.types, params, clock=clock)
    names = PANDA_ARM[2:] if base_link else PANDA_ARM
    resp = fk(ros, svc, names, Q_PANDA[-len(names) :], link_names=links)
    assert not resp.success and needle in resp.message, resp.message
    assert list(resp.poses) == []


def test_fk_of_a_link_whose_joints_are_unknown_names_them(ros, clock, panda_text):
    svc = KinematicsService(
        ros.types, {"robot_description": panda_text, "tip_link": "panda_hand"}, clock=clock
    )
    resp = fk(ros, svc, PANDA_ARM, Q_PANDA, link_names=["panda_leftfinger"])
    assert not resp.success and "panda_finger_joint1" in resp.message, resp.message


def test_no_description_message_names_every_way_to_give_one(ros, clock):
    svc = KinematicsService(ros.types, {}, clock=clock)
    resp = svc.compute_fk(ros.request("ComputeFK"), ros.response("ComputeFK"))
    assert resp.message == NO_DESCRIPTION
    for way in ("robot_description parameter", "robot_description_file", "robot_description topic"):
        assert way in resp.message


# =========================================================================== descriptions that bend the standard
def test_a_robot_without_a_name_is_loaded_and_the_note_logged(ros, clock):
    """A <robot> without a name (it was refused: "URDF could not be parsed: 'name'")."""
    svc = KinematicsService(ros.types, {}, clock=clock)
    assert svc.on_description_message(UR5E.read_text().replace('<robot name="ur5e"', "<robot", 1))
    assert svc.status.state == "loaded" and svc.model.robot_name == ""
    log = svc.take_log()
    assert any("the <robot> element has no name attribute" in text for _, text in log), log
    named = KinematicsService(ros.types, {}, clock=clock)
    named.on_description_message(UR5E.read_text())
    assert level(ros, svc) == level(ros, named)


def test_a_malformed_element_is_what_services_and_diagnostics_say(ros, clock):
    """A joint without a type: the refusal names the joint and what it lacks in the services'
    answers and in /diagnostics' last_refusal (it read "has type 'None'")."""
    text = UR5E.read_text()
    bent = text.replace('<joint name="elbow_joint" type="revolute">', '<joint name="elbow_joint">')
    assert bent != text
    svc = KinematicsService(ros.types, {}, clock=clock)
    assert not svc.on_description_message(bent)
    expected = "joint 'elbow_joint' has no type attribute; expected one of revolute, continuous"
    for resp in answers(ros, svc):
        assert not resp.success and expected in resp.message, resp.message
    assert expected in values(svc)["last_refusal"]
    assert level(ros, svc) == "ERROR"
