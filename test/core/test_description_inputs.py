"""Descriptions as new users hand them in (issue 11): every refusal is one line naming the culprit,
and odd-but-valid files (other encodings, xmlns:xacro without xacro content) load."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from kin_testing import erd_path

from kinematics_node.core import InvalidInputError, RobotDescriptionError, SerialChain
from kinematics_node.core.rotations import matrix_from_quaternion
from kinematics_node.sim.robots import robot_path

PLANAR = robot_path("planar3r").read_text(encoding="utf-8")
Q3 = np.array([0.3, -0.4, 0.5])


def refused(description, match: str) -> str:
    with pytest.raises(RobotDescriptionError, match=match) as info:
        SerialChain.from_urdf(description)
    text = str(info.value)
    assert "\n" not in text and "np.float64" not in text
    return text


def with_origin(xyz: str = "0 0 0", rpy: str = "0 0 0") -> str:
    return (
        '<robot name="r"><link name="a"/><link name="b"/>'
        '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/></joint></robot>'
    )


@pytest.mark.parametrize(
    "xyz, rpy",
    [("0 nan 0", "0 0 0"), ("0 0 0", "inf 0 0"), ("0 0 0", "0 -inf 0"), ("1e999 0 0", "0 0 0")],
)
def test_non_finite_origin_is_refused_naming_the_joint(xyz, rpy):
    refused(with_origin(xyz, rpy), r"joint 'j': <origin .*> must be finite")


def test_non_finite_origin_via_xacro_is_refused():
    pytest.importorskip("xacro")
    xml = (
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:property name="h" value="${float(\'nan\')}"/><link name="a"/><link name="b"/>'
        '<joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
        '<origin xyz="0 0 ${h}"/><axis xyz="0 0 1"/></joint></robot>'
    )
    refused(xml, "joint 'j'.*finite")


def test_huge_but_finite_origin_is_refused_instead_of_overflowing():
    refused(with_origin("1e300 0 0"), "refused as unphysical")


def test_wrong_number_of_origin_values_names_the_joint_and_attribute():
    refused(with_origin("1 2"), r'joint \'j\': <origin xyz="1 2"> must hold 3 numbers, got 2')


def test_latin1_urdf_with_its_declaration_loads_like_the_utf8_one(tmp_path):
    text = PLANAR.replace("A planar 3R arm", "Un bras planaire à 3 axes, déclaré ISO-8859-1")
    text = text.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="ISO-8859-1"?>')
    assert 'encoding="ISO-8859-1"' in text and "é" in text
    path = tmp_path / "latin1.urdf"
    path.write_bytes(text.encode("latin-1"))
    reference = SerialChain.from_urdf(PLANAR)
    for source in (path, str(path), text.encode("latin-1"), text):
        np.testing.assert_array_equal(SerialChain.from_urdf(source).fk(Q3), reference.fk(Q3))


def test_utf16_with_byte_order_mark_loads(tmp_path):
    path = tmp_path / "utf16.urdf"
    path.write_bytes(PLANAR.encode("utf-16"))
    np.testing.assert_array_equal(
        SerialChain.from_urdf(path).fk(Q3), SerialChain.from_urdf(PLANAR).fk(Q3)
    )


def test_binary_and_undeclared_non_utf8_files_are_one_line_errors(tmp_path):
    binary = tmp_path / "mesh.stl"
    binary.write_bytes(bytes(range(256)) * 4)
    refused(binary, "is a binary file, not XML text")
    latin = tmp_path / "undeclared.urdf"
    latin.write_bytes(PLANAR.replace("A planar", "Un bras à").encode("latin-1"))
    refused(latin, "is not utf-8 text.*declare it")


def test_dh_tables_of_the_wrong_shape_are_refused():
    for table, match in [
        (5, "must be a list of rows"),
        ({"joints": 5}, "'joints' must be a list of rows"),
        ("a, alpha, d", "must be a list of rows"),
        ({"rows": []}, "needs a 'joints' list"),
        ([{"a": 0, "alpha": 0, "d": 0, "name": 3}], "'name' must be a non-empty string"),
        # a misspelt limit was silently absent (±inf), and true was read as 1 m
        ([{"a": 0, "alpha": 0, "d": 0, "lowr": -1}], "unknown key 'lowr'; the keys are a, alpha"),
        ([{"a": True, "alpha": 0, "d": 0}], "'a' must be a number, got True"),
    ]:
        with pytest.raises(RobotDescriptionError, match=match):
            SerialChain.from_dh(table)


def test_a_one_link_robot_says_so():
    text = refused('<robot name="r"><link name="base"/></robot>', "no link below 'base'")
    assert "single link" in text and "[]" not in text


def test_a_root_other_than_robot_is_named():
    refused(
        '<model name="m"><link name="a"/></model>', r"expected a <robot> root element, got <model>"
    )


def test_duplicated_links_and_joints_are_refused():
    refused(
        with_origin().replace('<link name="b"/>', '<link name="b"/><link name="b"/>'),
        "link 'b' is defined twice",
    )
    second_joint = (
        '<link name="c"/><joint name="j" type="fixed"><parent link="b"/><child link="c"/></joint>'
    )
    refused(
        with_origin().replace("</robot>", second_joint + "</robot>"), "joint 'j' is defined twice"
    )


def test_xmlns_xacro_alone_does_not_need_xacro(monkeypatch):
    path = erd_path("ur_description/urdf/ur5_robot.urdf")
    text = path.read_text(encoding="utf-8")
    assert "xmlns:xacro" in text
    reference = SerialChain.from_urdf(path, tip_link="tool0")
    monkeypatch.setitem(sys.modules, "xacro", None)  # as after a plain `pip install .`
    chain = SerialChain.from_urdf(text, tip_link="tool0")
    np.testing.assert_array_equal(chain.fk(np.ones(6)), reference.fk(np.ones(6)))
    real_xacro = text.replace('name="ur5"', "name=\"${'ur5'}\"", 1)
    refused(real_xacro, "uses xacro, but the 'xacro' package is not installed")


def test_xacro_errors_are_one_line():
    pytest.importorskip("xacro")
    refused(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="${nope}"/></robot>',
        "xacro processing failed: name 'nope' is not defined",
    )


def test_quaternion_rule_normalise_any_non_zero_refuse_zero():
    np.testing.assert_allclose(matrix_from_quaternion([0, 0, 0, 2]), np.eye(3))
    np.testing.assert_allclose(
        matrix_from_quaternion([2, 0, 0, 0]), matrix_from_quaternion([1, 0, 0, 0])
    )
    with pytest.raises(InvalidInputError, match="give any non-zero quaternion"):
        matrix_from_quaternion([0, 0, 0, 0])


def test_non_finite_values_are_printed_as_plain_floats():
    chain = SerialChain.from_urdf(PLANAR)
    with pytest.raises(InvalidInputError) as info:
        chain.check_q([0.0, np.nan, 0.0])
    assert "np.float64" not in str(info.value) and "nan" in str(info.value)


def test_huge_finite_limits_are_refused_before_ik_overflows():
    # found by the fuzz run: IK's random restarts overflowed (inf error, OverflowError)
    row = {"a": 0, "alpha": 0, "d": 0, "theta": 0, "type": "P", "lower": -1e308, "upper": 1e308}
    with pytest.raises(RobotDescriptionError, match="refused as unphysical"):
        SerialChain.from_dh([row])
    chain = SerialChain.from_dh([{**row, "lower": -0.5, "upper": 0.5}])
    assert chain.ik(chain.fk([0.2])).success
