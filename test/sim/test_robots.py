"""Bundled robots: lookup in the three install layouts, agreement with Pinocchio, and with the
published kinematic tables (re-implemented here from the cited numbers, independently of the core).
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from kin_testing import PinocchioOracle

from kinematics_node.core import RobotDescriptionError, SerialChain, UnknownNameError
from kinematics_node.sim import robots

REPO = Path(__file__).resolve().parents[2]
BUNDLED = ("iiwa14", "panda", "planar3r", "scara", "ur5e")
N_CONFIGS = 25


def random_q(chain: SerialChain, rng: np.random.Generator, n: int) -> np.ndarray:
    """Uniform samples inside the limits; continuous joints in [-2π, 2π]."""
    lo = np.where(np.isfinite(chain.lower), chain.lower, -2 * np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, 2 * np.pi)
    return rng.uniform(lo, hi, size=(n, chain.dof))


# ----------------------------------------------------------------------------- independent DH
def dh_standard(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Rot_z(θ) Trans_z(d) Trans_x(a) Rot_x(α), written out element by element."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def dh_modified(a: float, d: float, alpha: float, theta: float) -> np.ndarray:
    """Craig's Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(d), written out element by element."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st, 0.0, a],
            [st * ca, ct * ca, -sa, -d * sa],
            [st * sa, ct * sa, ca, d * ca],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def rot_z(t: float) -> np.ndarray:
    return dh_standard(t, 0.0, 0.0, 0.0)


def trans_z(d: float) -> np.ndarray:
    return dh_standard(0.0, d, 0.0, 0.0)


def ur5e_dh(q: np.ndarray) -> np.ndarray:
    # Universal Robots' published UR5e DH table: d, a, alpha per joint.
    d = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
    a = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
    alpha = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
    T = np.eye(4)
    for i in range(6):
        T = T @ dh_standard(q[i], d[i], a[i], alpha[i])
    return T


def panda_flange_mdh(q: np.ndarray) -> np.ndarray:
    # Franka's published modified-DH table (a, d, alpha), joints 1..7, then the flange.
    a = (0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088)
    d = (0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0)
    alpha = (0.0, -math.pi / 2, math.pi / 2, math.pi / 2, -math.pi / 2, math.pi / 2, math.pi / 2)
    T = np.eye(4)
    for i in range(7):
        T = T @ dh_modified(a[i], d[i], alpha[i], q[i])
    return T @ dh_modified(0.0, 0.107, 0.0, 0.0)


def iiwa14_dh(q: np.ndarray) -> np.ndarray:
    # KUKA LBR iiwa 14 R820: 360 / 420 / 400 / 126 mm, all a = 0.
    d = (0.36, 0.0, 0.42, 0.0, 0.40, 0.0, 0.126)
    alpha = (-math.pi / 2, math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, math.pi / 2, 0.0)
    T = np.eye(4)
    for i in range(7):
        T = T @ dh_standard(q[i], d[i], 0.0, alpha[i])
    return T


def scara_0A4(q: np.ndarray) -> np.ndarray:
    # De Luca's SCARA slide, "Step 6", with the values stated in scara.urdf.
    a1, a2, d1, d4 = 0.325, 0.275, 0.35, -0.15
    c1, s1 = math.cos(q[0]), math.sin(q[0])
    c12, s12 = math.cos(q[0] + q[1]), math.sin(q[0] + q[1])
    c124, s124 = math.cos(q[0] + q[1] + q[3]), math.sin(q[0] + q[1] + q[3])
    return np.array(
        [
            [c124, s124, 0.0, a1 * c1 + a2 * c12],
            [s124, -c124, 0.0, a1 * s1 + a2 * s12],
            [0.0, 0.0, -1.0, d1 + q[2] + d4],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def planar3r_closed_form(q: np.ndarray) -> np.ndarray:
    a1, a2, a3 = 0.5, 0.4, 0.2
    t1, t12, t123 = q[0], q[0] + q[1], q[0] + q[1] + q[2]
    T = rot_z(t123)
    T[0, 3] = a1 * math.cos(t1) + a2 * math.cos(t12) + a3 * math.cos(t123)
    T[1, 3] = a1 * math.sin(t1) + a2 * math.sin(t12) + a3 * math.sin(t123)
    return T


# ----------------------------------------------------------------------------- lookup
def test_available_robots_are_the_five_bundled_files():
    assert robots.available_robots() == BUNDLED
    assert robots.robots_directory() == REPO / "config" / "robots"


@pytest.mark.parametrize("name", BUNDLED)
def test_every_bundled_robot_loads_with_its_default_chain(name):
    base, tip = robots.default_chain_links(name)
    chain = robots.load_robot(name)
    assert (chain.base_link, chain.tip_link) == (base, tip)
    assert robots.robot_path(name) == REPO / "config" / "robots" / f"{name}.urdf"
    # the same chain straight from the file, with the documented links
    direct = SerialChain.from_urdf(robots.robot_path(name), base_link=base, tip_link=tip)
    assert direct.joint_names == chain.joint_names
    assert np.all(chain.velocity_limit > 0) and np.all(np.isfinite(chain.velocity_limit))


def test_unknown_robot_names_are_refused_with_the_valid_names():
    for bad in ("ur10", "../robots/ur5e", ""):
        with pytest.raises(UnknownNameError) as info:
            robots.robot_path(bad)
        assert "ur5e" in str(info.value) and "planar3r" in str(info.value)
    with pytest.raises(UnknownNameError, match="panda"):
        robots.default_chain_links("ur10")
    with pytest.raises(UnknownNameError):
        robots.load_robot("kr6")


def _install_copy(share_root: Path) -> Path:
    d = share_root / "share" / "kinematics_service" / "config" / "robots"
    d.mkdir(parents=True)
    for f in (REPO / "config" / "robots").glob("*.urdf"):
        shutil.copy(f, d)
    return d


def test_lookup_non_editable_pip_install_uses_sys_prefix_share(tmp_path):
    # package in some site-packages, data_files under <sys.prefix>/share/kinematics_service
    pkg = tmp_path / "site" / "site-packages" / "kinematics_node" / "sim" / "robots.py"
    d = _install_copy(tmp_path / "venv")
    found = robots.robots_directory(pkg, prefix=str(tmp_path / "venv"), environ={})
    assert found == d
    chain = SerialChain.from_urdf(found / "ur5e.urdf")
    assert chain.tip_link == "tool0"


def test_lookup_colcon_install_via_ament_prefix_path(tmp_path):
    pkg = tmp_path / "elsewhere" / "kinematics_node" / "sim" / "robots.py"
    d = _install_copy(tmp_path / "install" / "kinematics_service")
    env = {"AMENT_PREFIX_PATH": f"{tmp_path / 'install' / 'other'}:{d.parents[3]}"}
    assert robots.robots_directory(pkg, prefix=str(tmp_path / "none"), environ=env) == d


def test_lookup_colcon_install_from_the_package_location_alone(tmp_path):
    prefix = tmp_path / "install" / "kinematics_service"
    pkg = prefix / "lib" / "python3.10" / "site-packages" / "kinematics_node" / "sim" / "robots.py"
    d = _install_copy(prefix)
    assert robots.robots_directory(pkg, prefix=str(tmp_path / "none"), environ={}) == d


def test_lookup_prefers_the_source_tree_and_reports_where_it_searched(tmp_path):
    pkg = tmp_path / "repo" / "kinematics_node" / "sim" / "robots.py"
    src = tmp_path / "repo" / "config" / "robots"
    src.mkdir(parents=True)
    shutil.copy(REPO / "config" / "robots" / "scara.urdf", src)
    _install_copy(tmp_path / "venv")
    assert robots.robots_directory(pkg, prefix=str(tmp_path / "venv"), environ={}) == src

    empty = tmp_path / "empty" / "kinematics_node" / "sim" / "robots.py"
    with pytest.raises(RobotDescriptionError, match="not found") as info:
        robots.robots_directory(empty, prefix=str(tmp_path / "nowhere"), environ={})
    assert str(tmp_path / "nowhere" / "share" / "kinematics_service") in str(info.value)


# ----------------------------------------------------------------------------- Pinocchio
pin = pytest.importorskip("pinocchio")


@pytest.mark.parametrize("name", BUNDLED)
def test_fk_and_jacobians_agree_with_pinocchio(name):
    chain = robots.load_robot(name)
    oracle = PinocchioOracle.from_urdf(robots.robot_path(name), chain.joint_names)
    rng = np.random.default_rng(7)
    for q in random_q(chain, rng, N_CONFIGS):
        T_pin, J_pin = oracle.pose_and_jacobians(q, chain.tip_link)
        np.testing.assert_allclose(chain.fk(q), T_pin, atol=1e-9)
        np.testing.assert_allclose(chain.jacobian(q, frame="world"), J_pin["world"], atol=1e-9)
        np.testing.assert_allclose(chain.jacobian(q, frame="body"), J_pin["body"], atol=1e-9)


def test_panda_mimic_finger_agrees_with_pinocchio_mimic_model():
    # Chain to the right finger: its joint mimics panda_finger_joint1, which becomes the actuated
    # variable even though the leader is on another branch.
    path = robots.robot_path("panda")
    chain = SerialChain.from_urdf(path, "panda_link0", "panda_rightfinger")
    assert chain.joint_names[-1] == "panda_finger_joint1" and chain.dof == 8
    left = SerialChain.from_urdf(path, "panda_link0", "panda_leftfinger")
    rng = np.random.default_rng(3)
    for q in random_q(chain, rng, 10):
        gap = left.fk(q)[:3, 3] - chain.fk(q)[:3, 3]
        assert np.linalg.norm(gap) == pytest.approx(2 * q[-1], abs=1e-12)
    try:
        oracle = PinocchioOracle.from_urdf(path, chain.joint_names, mimic=True)
    except Exception as exc:  # older Pinocchio without mimic support
        pytest.skip(f"this Pinocchio cannot build mimic joints: {exc}")
    for q in random_q(chain, rng, 10):
        np.testing.assert_allclose(chain.fk(q), oracle.pose(q, "panda_rightfinger"), atol=1e-9)


def test_panda_has_several_leaves_so_the_tip_must_be_named():
    with pytest.raises(RobotDescriptionError, match="panda_hand_tcp"):
        SerialChain.from_urdf(robots.robot_path("panda"))


# ----------------------------------------------------------------------------- published tables
@pytest.mark.parametrize(
    ("name", "tip", "oracle"),
    [
        ("ur5e", "tool0", ur5e_dh),
        ("panda", "panda_link8", panda_flange_mdh),
        ("iiwa14", "iiwa_link_ee", iiwa14_dh),
        ("scara", "tool0", scara_0A4),
        ("planar3r", "tool0", planar3r_closed_form),
    ],
)
def test_fk_matches_the_published_kinematic_table(name, tip, oracle):
    chain = robots.load_robot(name, tip_link=tip)
    rng = np.random.default_rng(11)
    for q in random_q(chain, rng, N_CONFIGS):
        np.testing.assert_allclose(chain.fk(q), oracle(q), atol=1e-12)


def test_panda_tcp_is_the_flange_times_the_hand_offsets():
    chain = robots.load_robot("panda")
    rng = np.random.default_rng(5)
    for q in random_q(chain, rng, 10):
        expected = panda_flange_mdh(q) @ rot_z(-math.pi / 4) @ trans_z(0.1034)
        np.testing.assert_allclose(chain.fk(q), expected, atol=1e-12)


def test_joint_limits_are_the_published_ones():
    deg = np.radians
    iiwa = robots.load_robot("iiwa14")
    np.testing.assert_allclose(iiwa.upper, deg([170, 120, 170, 120, 170, 120, 175]), rtol=1e-12)
    np.testing.assert_allclose(iiwa.lower, -iiwa.upper)
    np.testing.assert_allclose(iiwa.velocity_limit, deg([85, 85, 100, 75, 130, 135, 135]))

    panda = robots.load_robot("panda")
    np.testing.assert_allclose(
        panda.upper, [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973]
    )
    np.testing.assert_allclose(
        panda.lower, [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973]
    )
    np.testing.assert_allclose(panda.velocity_limit, [2.175] * 4 + [2.61] * 3)

    ur = robots.load_robot("ur5e")  # datasheet: ±360°, 180°/s on every joint
    np.testing.assert_allclose(ur.upper, [deg(360)] * 6)
    np.testing.assert_allclose(ur.lower, [-deg(360)] * 6)
    np.testing.assert_allclose(ur.velocity_limit, [deg(180)] * 6)

    planar = robots.load_robot("planar3r")  # the one continuous joint among the bundled robots
    assert planar.joint_types[0] == "continuous" and np.isinf(planar.upper[0])
