"""`kinematics info` shows the model as the library built it (issue 22): mimic joints (which
joint follows which leader, with multiplier, offset and the follower's own limits), leaders'
limits narrowed by their followers, S and B columns per moving joint, and the notes of what was
normalised, accepted or ignored. And the CLI's defaults (base, tip, Jacobian frame) are the
library's.

Oracles: the URDF files themselves (read here with ElementTree), and Pinocchio for the pose that
the printed PoE model (S, G, offset, M) must reproduce.
"""

from __future__ import annotations

import inspect
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from kin_testing import PinocchioOracle, erd_path
from scipy.linalg import expm

from kinematics_node.cli.main import build_parser, main
from kinematics_node.core import SerialChain

# A small arm with a two-finger gripper: finger_b follows finger_a with multiplier −0.5 and
# offset 0.01, and its own limits [-0.02, 0.05] narrow finger_a's [0, 0.08] to [0, 0.06]; the
# shoulder's axis is unit to three digits (normalised); a fixed joint carries a <mimic>
# (ignored).
GRIPPER_ARM = """<robot name="gripper_arm">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="finger_a"/>
  <link name="finger_b"/><link name="cam"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0.707 0 0.707"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1.5"/></joint>
  <joint name="finger_a_joint" type="prismatic"><parent link="l2"/><child link="finger_a"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.08" effort="1" velocity="0.1"/></joint>
  <joint name="finger_b_joint" type="prismatic"><parent link="finger_a"/><child link="finger_b"/>
    <axis xyz="0 1 0"/><limit lower="-0.02" upper="0.05" effort="1" velocity="0.1"/>
    <mimic joint="finger_a_joint" multiplier="-0.5" offset="0.01"/></joint>
  <joint name="cam_joint" type="fixed"><parent link="l2"/><child link="cam"/>
    <mimic joint="elbow"/></joint>
</robot>
"""


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def info_json(capsys, *argv) -> dict:
    code, out, err = run(capsys, "info", *argv, "--json")
    assert code == 0, err
    return json.loads(out)


def urdf_mimics(path) -> dict[str, dict]:
    """{follower: {leader, multiplier, offset, lower, upper}} as the URDF file writes them."""
    out = {}
    for joint in ET.parse(path).getroot().iter("joint"):
        mimic = joint.find("mimic")
        limit = joint.find("limit")
        if mimic is None or joint.get("type") == "fixed":
            continue
        out[joint.get("name")] = {
            "leader": mimic.get("joint"),
            "multiplier": float(mimic.get("multiplier", "1")),
            "offset": float(mimic.get("offset", "0")),
            "lower": float(limit.get("lower", "0")),
            "upper": float(limit.get("upper", "0")),
        }
    return out


def poe_pose(data: dict, q) -> np.ndarray:
    """T(q) = e^{[S₁]θ₁} ⋯ e^{[Sₘ]θₘ} M with θ = G q + offset, from `info --json` alone."""
    S, G, M = np.array(data["S"]), np.array(data["G"]), np.array(data["M"])
    theta = G @ np.asarray(q, dtype=float) + np.array(data["offset"])
    T = np.eye(4)
    for k in range(S.shape[1]):
        w, v = S[:3, k], S[3:, k]
        se3 = np.zeros((4, 4))
        se3[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
        se3[:3, 3] = v
        T = T @ expm(se3 * theta[k])
    return T @ M


# =========================================================================== info: mimic joints
def test_info_shows_the_panda_fingers_mimic_joint_as_its_urdf_writes_it(capsys):
    path = erd_path("panda_description/urdf/panda.urdf")
    data = info_json(capsys, "--urdf", str(path), "--tip", "panda_rightfinger")
    written = urdf_mimics(path)
    assert list(written) == ["panda_finger_joint2"]
    (mimic,) = data["mimic_joints"]
    assert mimic == {"name": "panda_finger_joint2", **written["panda_finger_joint2"]}
    # the leader is the chain's variable (off the chain itself), the follower has S's column
    assert data["joints"][-1]["name"] == "panda_finger_joint1"
    assert data["moving_joint_names"][-1] == "panda_finger_joint2"
    assert np.array(data["S"]).shape == (6, len(data["moving_joint_names"]))
    assert any("panda_finger_joint2" in note for note in data["notes"])
    # the printed model reproduces Pinocchio's pose of the finger (follower set by hand)
    oracle = PinocchioOracle.from_urdf(path, data["moving_joint_names"])
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = [rng.uniform(j["lower"], j["upper"]) for j in data["joints"]]
        q_moving = q[:-1] + [mimic["multiplier"] * q[-1] + mimic["offset"]]
        np.testing.assert_allclose(
            poe_pose(data, q), oracle.pose(q_moving, "panda_rightfinger"), atol=1e-12
        )
    # as text: the follower, its leader's rule and its own limits, and S's columns named
    code, out, _ = run(capsys, "info", "--urdf", str(path), "--tip", "panda_rightfinger")
    assert code == 0
    row = next(line for line in out.splitlines() if line.strip().startswith("panda_finger_joint2"))
    assert row.split() == ["panda_finger_joint2", "1·panda_finger_joint1", "+", "0", "0", "0.04"]
    assert f"columns: {', '.join(data['moving_joint_names'])};" in out


def test_info_shows_multiplier_offset_narrowed_limits_and_every_note(capsys, tmp_path):
    path = tmp_path / "gripper_arm.urdf"
    path.write_text(GRIPPER_ARM)
    data = info_json(capsys, "--urdf", str(path), "--tip", "finger_b")
    written = urdf_mimics(path)
    assert data["mimic_joints"] == [{"name": "finger_b_joint", **written["finger_b_joint"]}]
    finger_a = data["joints"][2]
    assert finger_a["name"] == "finger_a_joint"
    assert (finger_a["own_lower"], finger_a["own_upper"]) == (0.0, 0.08)  # as written
    # narrowed: −0.5·a + 0.01 ≥ −0.02 ⇔ a ≤ 0.06
    assert finger_a["lower"] == 0.0 and finger_a["upper"] == pytest.approx(0.06, abs=1e-15)
    notes = " | ".join(data["notes"])
    assert "'shoulder'" in notes and "normalised" in notes
    assert "'finger_b_joint'" in notes and "narrowed" in notes
    assert any("'cam_joint'" in n and "ignored" in n for n in data["description_notes"])
    # the printed model reproduces Pinocchio's pose of finger_b (which normalises axes too)
    oracle = PinocchioOracle.from_xml(GRIPPER_ARM, data["moving_joint_names"])
    for q in ([0.3, -0.4, 0.05], [-1.0, 1.2, 0.0], [0.5, 0.5, 0.06]):
        q_moving = [*q, -0.5 * q[2] + 0.01]
        np.testing.assert_allclose(poe_pose(data, q), oracle.pose(q_moving, "finger_b"), atol=1e-12)

    code, out, _ = run(capsys, "info", "--urdf", str(path), "--tip", "finger_b")
    assert code == 0
    lines = out.splitlines()
    row = next(line for line in lines if line.strip().startswith("3 finger_a_joint"))
    assert row.split()[3:6] == ["0", "0.06", "0.1*"]  # narrowed, and marked
    assert any(line.startswith("  * limits narrowed") for line in lines)
    mimic_row = next(line for line in lines if line.strip().startswith("finger_b_joint"))
    assert mimic_row.split() == [
        "finger_b_joint",
        "-0.5·finger_a_joint",
        "+",
        "0.01",
        "-0.02",
        "0.05",
    ]
    chain_notes = lines.index("notes on this chain:")
    rest = lines.index("notes on the rest of the description:")
    assert chain_notes < rest
    assert "'cam_joint'" in lines[rest + 1] and len(lines) == rest + 2  # off-chain notes only


def test_info_of_a_chain_without_mimic_joints_is_as_before(capsys):
    data = info_json(capsys, "--robot", "ur5e")
    assert data["mimic_joints"] == [] and data["notes"] == [] and data["description_notes"] == []
    assert data["moving_joint_names"] == [j["name"] for j in data["joints"]]
    np.testing.assert_array_equal(data["G"], np.eye(6))
    code, out, _ = run(capsys, "info", "--robot", "ur5e")
    assert code == 0 and "mimic" not in out and "notes" not in out and "columns S1..Sn" in out


# =========================================================================== defaults
def test_the_jacobian_frame_default_is_the_library_s(capsys):
    library = inspect.signature(SerialChain.jacobian).parameters["frame"].default
    cli = build_parser().parse_args(["jacobian", "--robot", "ur5e", "--q", "0"]).frame
    assert cli == library
    # and what it computes: `jacobian` without --frame is chain.jacobian(q) without a frame
    q = [0.3, -1.1, 1.4, -0.6, 0.8, 0.2]
    code, out, _ = run(
        capsys, "jacobian", "--robot", "ur5e", "--q", ",".join(map(str, q)), "--json"
    )
    assert code == 0
    from kinematics_node.sim.robots import load_robot

    data = json.loads(out)
    assert data["frame"] == library
    np.testing.assert_allclose(data["J"], load_robot("ur5e").jacobian(q), atol=1e-15)


def test_no_base_or_tip_and_empty_ones_mean_the_library_s_defaults(capsys):
    from kinematics_node.sim.robots import robot_path

    path = str(robot_path("iiwa14"))  # one root, one leaf: the library's defaults
    chain = SerialChain.from_urdf(path)
    for extra in ([], ["--base", "", "--tip", ""]):
        data = info_json(capsys, "--urdf", path, *extra)
        assert (data["base_link"], data["tip_link"]) == (chain.base_link, chain.tip_link)
        np.testing.assert_array_equal(data["S"], chain.S)
    assert SerialChain.from_urdf(path, "", "").tip_link == chain.tip_link
