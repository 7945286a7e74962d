"""URDF/xacro parsing and every refusal: the error must name the culprit."""

from pathlib import Path

import numpy as np
import pytest

from kinematics_node.core import (
    InvalidInputError,
    RobotDescriptionError,
    SerialChain,
    UnknownNameError,
    se3,
)
from kinematics_node.core.rotations import matrix_from_rpy
from kinematics_node.core.urdf import RobotDescription


def urdf(joints: str, links=("base", "l1", "l2", "tip"), extra_links=()) -> str:
    body = "".join(f'<link name="{n}"/>' for n in (*links, *extra_links))
    return f'<robot name="t">{body}{joints}</robot>'


def joint(
    name, parent, child, type_="revolute", axis="0 0 1", xyz="0 0 0.1", rpy="0 0 0", extra=""
):
    lim = (
        '<limit lower="-2" upper="2" effort="1" velocity="1"/>'
        if type_ in ("revolute", "prismatic")
        else ""
    )
    ax = f'<axis xyz="{axis}"/>' if axis is not None else ""
    return (
        f'<joint name="{name}" type="{type_}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/>{ax}{lim}{extra}</joint>'
    )


GOOD = urdf(
    joint("j1", "base", "l1", rpy="0.3 -0.2 0.5")
    + joint("j2", "l1", "l2", "prismatic", axis="1 0 0", xyz="0.2 0 0")
    + joint("j3", "l2", "tip", "continuous", axis="0 1 0", xyz="0 0.1 0.3", rpy="1.0 0.2 -0.4")
)


def test_hand_written_urdf_matches_hand_computed_poe():
    chain = SerialChain.from_urdf(GOOD)
    assert chain.joint_names == ("j1", "j2", "j3")
    assert chain.joint_types == ("revolute", "prismatic", "continuous")
    assert chain.link_names == ("base", "l1", "l2", "tip")
    np.testing.assert_array_equal(chain.lower, [-2, -2, -np.inf])
    q = np.array([0.4, 0.15, -1.3])

    def origin(xyz, rpy):  # URDF: Trans(xyz) · R_Z(y) R_Y(p) R_X(r)
        T = np.eye(4)
        T[:3, :3] = matrix_from_rpy(rpy)
        T[:3, 3] = xyz
        return T

    def rot(axis, a):
        T = np.eye(4)
        T[:3, :3] = se3.so3.exp(np.asarray(axis, float) * a)
        return T

    def trans(axis, d):
        T = np.eye(4)
        T[:3, 3] = np.asarray(axis, float) * d
        return T

    expected = (
        origin((0, 0, 0.1), (0.3, -0.2, 0.5))
        @ rot((0, 0, 1), q[0])
        @ origin((0.2, 0, 0), (0, 0, 0))
        @ trans((1, 0, 0), q[1])
        @ origin((0, 0.1, 0.3), (1.0, 0.2, -0.4))
        @ rot((0, 1, 0), q[2])
    )
    np.testing.assert_allclose(chain.fk(q), expected, atol=1e-14)


def test_file_path_and_xml_string_agree(tmp_path):
    f = tmp_path / "robot.urdf"
    f.write_text(GOOD)
    np.testing.assert_array_equal(SerialChain.from_urdf(f).M, SerialChain.from_urdf(GOOD).M)
    np.testing.assert_array_equal(SerialChain.from_urdf(str(f)).S, SerialChain.from_urdf(GOOD).S)


def test_xacro_file_and_string(tmp_path):
    pytest.importorskip("xacro", reason="xacro support is the optional [xacro] extra")
    text = """<robot name="x" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <xacro:property name="L" value="0.25"/>
      <xacro:macro name="seg" params="i parent">
        <link name="l${i}"/>
        <joint name="j${i}" type="revolute"><parent link="${parent}"/><child link="l${i}"/>
          <origin xyz="0 0 ${L}"/><axis xyz="0 1 0"/>
          <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      </xacro:macro>
      <link name="base"/>
      <xacro:seg i="1" parent="base"/><xacro:seg i="2" parent="l1"/>
    </robot>"""
    f = tmp_path / "arm.urdf.xacro"
    f.write_text(text)
    for src in (f, text):
        chain = SerialChain.from_urdf(src)
        assert chain.joint_names == ("j1", "j2")
        np.testing.assert_allclose(chain.M[:3, 3], (0, 0, 0.5), atol=1e-15)


def test_default_tip_is_the_single_leaf_and_ambiguity_lists_candidates():
    chain = SerialChain.from_urdf(GOOD)
    assert (chain.base_link, chain.tip_link) == ("base", "tip")
    branched = urdf(
        joint("j1", "base", "l1") + joint("j2", "l1", "l2") + joint("j3", "l1", "tip"),
    )
    with pytest.raises(RobotDescriptionError, match=r"several leaf links.*'l2'.*'tip'"):
        SerialChain.from_urdf(branched)
    assert SerialChain.from_urdf(branched, tip_link="l2").joint_names == ("j1", "j2")


def test_sub_chain_between_inner_links():
    chain = SerialChain.from_urdf(GOOD, base_link="l1", tip_link="tip")
    assert chain.joint_names == ("j2", "j3")


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_and_planar_joints_on_the_chain_are_refused(kind):
    text = urdf(
        joint("j1", "base", "l1") + joint("bad", "l1", "l2", kind) + joint("j3", "l2", "tip")
    )
    with pytest.raises(RobotDescriptionError, match=rf"'bad'.*{kind}"):
        SerialChain.from_urdf(text)


def test_floating_joint_off_the_chain_is_fine():
    text = urdf(
        joint("j1", "base", "l1")
        + joint("j2", "l1", "tip")
        + joint("free", "base", "obj", "floating"),
        links=("base", "l1", "tip", "obj"),
    )
    assert SerialChain.from_urdf(text, tip_link="tip").dof == 2


def test_loop_is_refused_naming_the_link():
    text = urdf(joint("j1", "base", "l1") + joint("j2", "l1", "l2") + joint("j3", "base", "l2"))
    with pytest.raises(RobotDescriptionError, match=r"'l2'.*two joints.*loop"):
        SerialChain.from_urdf(text)


def test_missing_link_is_refused_naming_it():
    text = urdf(joint("j1", "base", "l1") + joint("j2", "l1", "ghost"), links=("base", "l1"))
    with pytest.raises(RobotDescriptionError, match=r"'j2'.*'ghost'.*not defined"):
        SerialChain.from_urdf(text)


@pytest.mark.parametrize("axis, what", [("0 0 0", "zero"), ("1e300 1e300 0", "invalid")])
def test_zero_and_overflowing_axes_are_refused(axis, what):
    """(Non-unit axes are normalised, as Pinocchio does: test_real_descriptions.py.)"""
    text = urdf(
        joint("j1", "base", "l1")
        + joint("axisbad", "l1", "l2", axis=axis)
        + joint("j3", "l2", "tip")
    )
    with pytest.raises(RobotDescriptionError, match=rf"'axisbad'.*{what}"):
        SerialChain.from_urdf(text)


def test_slightly_unnormalised_printed_axis_is_accepted():
    text = urdf(
        joint("j1", "base", "l1", axis="0 0.7071 0.7071")
        + joint("j2", "l1", "l2")
        + joint("j3", "l2", "tip")
    )
    chain = SerialChain.from_urdf(text)
    np.testing.assert_allclose(np.linalg.norm(chain.S[:3, 0]), 1.0, atol=1e-15)


def test_revolute_without_limit_is_refused():
    text = GOOD.replace('<limit lower="-2" upper="2" effort="1" velocity="1"/>', "", 1)
    with pytest.raises(RobotDescriptionError, match=r"'j1'.*no <limit>"):
        SerialChain.from_urdf(text)


def test_unknown_links_list_valid_names():
    with pytest.raises(UnknownNameError, match=r"unknown link 'nope'.*'base'.*'tip'"):
        SerialChain.from_urdf(GOOD, tip_link="nope")
    with pytest.raises(UnknownNameError, match="unknown link 'nope'"):
        SerialChain.from_urdf(GOOD, base_link="nope")
    with pytest.raises(RobotDescriptionError, match="not below base link"):
        SerialChain.from_urdf(GOOD, base_link="l2", tip_link="l1")


def test_malformed_xml_and_missing_file():
    with pytest.raises(RobotDescriptionError, match="malformed XML"):
        SerialChain.from_urdf("<robot><link name='a'></robot>")
    with pytest.raises(RobotDescriptionError, match="cannot read.*no_such_file.urdf"):
        SerialChain.from_urdf("no_such_file.urdf")


def test_chain_without_moving_joint_is_refused():
    text = urdf(joint("f", "base", "l1", "fixed"), links=("base", "l1"))
    with pytest.raises(RobotDescriptionError, match="no moving joint"):
        SerialChain.from_urdf(text)


def test_bad_joint_values_are_refused_with_shape_and_position():
    chain = SerialChain.from_urdf(GOOD)
    with pytest.raises(InvalidInputError, match=r"3 values.*'j1', 'j2', 'j3'.*\(2,\)"):
        chain.fk([0.0, 1.0])
    with pytest.raises(InvalidInputError, match=r"non-finite.*nan.*index \(1,\)"):
        chain.fk([0.0, np.nan, 0.0])
    with pytest.raises(InvalidInputError, match=r"non-finite.*inf"):
        chain.jacobian(np.array([[0.0, 0.0, np.inf]]))
    with pytest.raises(InvalidInputError, match="numeric"):
        chain.fk(["a", "b", "c"])
    with pytest.raises(InvalidInputError, match="frame must be one of"):
        chain.jacobian([0, 0, 0], "tool")
    with pytest.raises(UnknownNameError, match="unknown joint 'x'"):
        chain.joint_index("x")


def test_dh_and_poe_refusals():
    with pytest.raises(RobotDescriptionError, match="row 2 has no 'alpha'"):
        SerialChain.from_dh([{"a": 0, "alpha": 0, "d": 0}, {"a": 0, "d": 0}])
    with pytest.raises(RobotDescriptionError, match="row 1.*type"):
        SerialChain.from_dh([{"a": 0, "alpha": 0, "d": 0, "type": "helical"}])
    with pytest.raises(RobotDescriptionError, match="row 1.*'d' must be finite"):
        SerialChain.from_dh([{"a": 0, "alpha": 0, "d": np.nan}])
    with pytest.raises(RobotDescriptionError, match="no rows"):
        SerialChain.from_dh([])
    with pytest.raises(RobotDescriptionError, match="'joint1' has pitch"):
        SerialChain.from_poe(np.array([[0, 0, 1, 0, 0, 0.5]]).T, np.eye(4))
    with pytest.raises(RobotDescriptionError, match="'joint1' is not normalised"):
        SerialChain.from_poe(np.array([[0, 0, 2, 0, 0, 0]]).T, np.eye(4))
    with pytest.raises(InvalidInputError, match="M rotation block"):
        SerialChain.from_poe(
            np.array([[0, 0, 1, 0, 0, 0]]).T, 2 * np.eye(4) - np.diag([0, 0, 0, 1])
        )


# ---------------------------------------------------------------- descriptions that bend the standard
EVERY_ELEMENT = Path(__file__).resolve().parents[1] / "fuzz" / "every_element.urdf"


@pytest.mark.parametrize(
    "old, new",
    [
        ('<cylinder radius="0.06" length="0.1"/>', '<cylinder length="0.1"/>'),  # KeyError 'radius'
        ('<box size="0.12 0.12 0.1"/>', "<box/>"),  # KeyError 'size'
        ('<sphere radius="0.05"/>', ""),  # an empty <geometry>: IndexError
        ('<mass value="2.0"/>', '<mass value="two"/>'),  # ValueError
        ('<origin xyz="0 0 0.05" rpy="0 0 0"/>\n      <mass', '<origin xyz="0 0"/><mass'),
        ('<color rgba="0.5 0.5 0.5 1"/>', '<color rgba="grey"/>'),
        ('rising="0.0"', 'rising="never"'),  # <calibration> of a joint
        ('k_position="15"', 'k_position=""'),  # <safety_controller> of a joint
    ],
)
def test_what_kinematics_does_not_read_is_not_refused(old, new):
    """Visual, collision, inertial, material, calibration and safety elements play no part in
    kinematics: a malformed one leaves the chain as it is (yourdfpy refused each with its own
    exception passed on, e.g. 'URDF could not be parsed: 'radius'')."""
    text = EVERY_ELEMENT.read_text(encoding="utf-8")
    assert old in text
    chain = SerialChain.from_urdf(text.replace(old, new, 1))
    clean = SerialChain.from_urdf(text)
    np.testing.assert_array_equal(chain.S, clean.S)
    np.testing.assert_array_equal(chain.M, clean.M)
    assert chain.notes == clean.notes


def test_a_robot_without_a_name_loads_and_says_so():
    nameless = GOOD.replace('<robot name="t">', "<robot>")
    chain = SerialChain.from_urdf(nameless)
    note = "the <robot> element has no name attribute, which URDF requires"
    assert chain.notes[0].startswith(note)
    assert RobotDescription(nameless).notes[0] == chain.notes[0]
    np.testing.assert_array_equal(chain.S, SerialChain.from_urdf(GOOD).S)
    empty = SerialChain.from_urdf(GOOD.replace('name="t"', 'name=""'))
    assert empty.notes[0].startswith("the <robot> element has an empty name")


def test_a_joint_without_a_type_is_refused_saying_so():
    text = GOOD.replace('<joint name="j2" type="prismatic">', '<joint name="j2">')
    with pytest.raises(RobotDescriptionError, match=r"^joint 'j2' has no type attribute; expected"):
        SerialChain.from_urdf(text)


def test_a_mimic_of_an_undefined_joint_names_the_follower():
    text = GOOD.replace("</joint>", '<mimic joint="jx"/></joint>', 2).replace(
        '<mimic joint="jx"/>', "", 1
    )  # j2 mimics jx
    with pytest.raises(
        RobotDescriptionError, match=r"^mimic joint 'j2' follows joint 'jx', which is not defined"
    ):
        SerialChain.from_urdf(text)


@pytest.mark.parametrize(
    "limit, missing, velocity",
    [
        ('<limit lower="-2" upper="2" effort="1"/>', "velocity", np.inf),
        ('<limit lower="-2" upper="2" velocity="1"/>', "effort", 1.0),
        ('<limit lower="-2" upper="2"/>', "effort and no velocity", np.inf),
    ],
)
def test_a_limit_without_effort_or_velocity_loads_with_a_note(limit, missing, velocity):
    """URDF requires both on a <limit> (urdfdom refuses the description); kinematics does not use
    the effort, and a missing velocity limit is unlimited, as before: now it says so."""
    text = GOOD.replace('<limit lower="-2" upper="2" effort="1" velocity="1"/>', limit, 1)
    chain = SerialChain.from_urdf(text)
    assert chain.velocity_limit[0] == velocity
    note = f"joint 'j1': <limit> has no {missing} attribute, which URDF requires"
    assert [n for n in chain.notes if "<limit>" in n] == [
        note + ("; its velocity is taken as unlimited" if "velocity" in missing else "")
    ]
    assert RobotDescription(text).notes == chain.notes
