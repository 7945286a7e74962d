"""The mimic map of a chain (θ = G q + offset over its moving joints), the limits a follower
implies for its leader, and what the parser reports (`RobotDescription.notes`, `chain.notes`).
(Agreement with Pinocchio on real and edited descriptions: test_real_descriptions.py.)"""

from __future__ import annotations

import math

import numpy as np
import pytest
from kin_testing import erd_path

from kinematics_node.core import RobotDescriptionError, SerialChain, se3
from kinematics_node.core.urdf import RobotDescription


def _joint(name, parent, child, kind, xyz, axis, limit, mimic=""):
    lim = f"<limit {limit} effort='1' velocity='1'/>" if limit is not None else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>{lim}{mimic}</joint>'
    )


def two_joint_arm(follower_limit="lower='-1' upper='1'", mult="-2", offset="0.5", kind="revolute"):
    """leader j1 ∈ [−2, 2] rad, then follower j2 = mult·j1 + offset with its own limits."""
    return (
        '<robot name="m"><link name="base"/><link name="a"/><link name="b"/><link name="tip"/>'
        + _joint("j1", "base", "a", "revolute", "0 0 0.1", "0 0 1", "lower='-2' upper='2'")
        + _joint(
            "j2", "a", "b", kind, "0.3 0 0", "0 1 0", follower_limit,
            f'<mimic joint="j1" multiplier="{mult}" offset="{offset}"/>',
        )
        + _joint("j3", "b", "tip", "revolute", "0.2 0 0.1", "1 0 0", "lower='-2' upper='2'")
        + "</robot>"
    )  # fmt: skip


def poe(chain: SerialChain, q) -> np.ndarray:
    theta = chain.G @ np.asarray(q, dtype=float) + chain.offset
    T = np.eye(4)
    for k in range(len(theta)):
        T = T @ se3.exp(chain.S[:, k] * theta[k])
    return T @ chain.M


def test_without_mimic_joints_the_map_is_the_identity() -> None:
    chain = SerialChain.from_urdf(erd_path("ur_description/urdf/ur5_robot.urdf"), tip_link="tool0")
    assert chain.moving_joint_names == chain.joint_names
    np.testing.assert_array_equal(chain.G, np.eye(6))
    np.testing.assert_array_equal(chain.offset, np.zeros(6))
    assert chain.S.shape == (6, 6) and chain.mimic_joints == () and chain.notes == ()
    np.testing.assert_array_equal(chain.lower, chain.own_lower)
    np.testing.assert_array_equal(chain.moving_upper, chain.upper)
    for a in (chain.G, chain.offset, chain.own_lower, chain.moving_lower, chain.S, chain.B):
        assert not a.flags.writeable
    assert chain.solver_model.G is None  # the fast path: no map applied per call


def test_follower_on_the_chain_gets_its_own_column() -> None:
    chain = SerialChain.from_urdf(two_joint_arm(), tip_link="tip")
    assert chain.joint_names == ("j1", "j3") and chain.moving_joint_names == ("j1", "j2", "j3")
    np.testing.assert_array_equal(chain.G, [[1, 0], [-2, 0], [0, 1]])
    np.testing.assert_array_equal(chain.offset, [0, 0.5, 0])
    assert chain.mimic_joints == (("j2", "j1", -2.0, 0.5),)
    assert chain.S.shape == chain.B.shape == (6, 3)
    rng = np.random.default_rng(1)
    for q in rng.uniform(chain.lower, chain.upper, size=(10, 2)):
        np.testing.assert_allclose(poe(chain, q), chain.fk(q), atol=1e-12)
        # J = J_θ G, by finite differences of FK in the actuated variables
        J = chain.jacobian(q, "space")
        h = 1e-6
        for i in range(2):
            dq = np.zeros(2)
            dq[i] = h
            dT = (chain.fk(q + dq) - chain.fk(q - dq)) / (2 * h)
            twist = dT @ se3.inverse(chain.fk(q))  # [V_s] = Ṫ T⁻¹
            V = np.r_[twist[2, 1], twist[0, 2], twist[1, 0], twist[:3, 3]]
            np.testing.assert_allclose(J[:, i], V, atol=1e-7)


@pytest.mark.parametrize(
    ("mult", "offset", "limit", "expected"),
    [
        ("-2", "0.5", "lower='-1' upper='1'", (-0.25, 0.75)),  # −1 ≤ −2q + 0.5 ≤ 1
        ("2", "0", "lower='-1' upper='3'", (-0.5, 1.5)),
        ("0.5", "0", "lower='-5' upper='5'", (-2.0, 2.0)),  # looser than the leader: unchanged
        ("3", "1", "lower='-10' upper='2.5'", (-2.0, 0.5)),  # one side only
        ("0", "0.3", "lower='0' upper='1'", (-2.0, 2.0)),  # held at 0.3, within its limits
    ],
)
def test_leader_limits_are_narrowed_to_what_the_follower_allows(mult, offset, limit, expected):
    chain = SerialChain.from_urdf(two_joint_arm(limit, mult, offset), tip_link="tip")
    np.testing.assert_allclose((chain.lower[0], chain.upper[0]), expected, atol=1e-15)
    np.testing.assert_array_equal((chain.own_lower[0], chain.own_upper[0]), (-2, 2))
    lo, hi = (float(x) for x in limit.replace("'", "").replace("lower=", "").split(" upper="))
    assert (chain.moving_lower[1], chain.moving_upper[1]) == (lo, hi)
    narrowed = expected != (-2.0, 2.0)
    assert any("narrowed" in note and "'j2'" in note for note in chain.notes) == narrowed
    # every value of the leader within the chain's limits keeps the follower within its own
    for q0 in np.linspace(chain.lower[0], chain.upper[0], 7):
        theta = chain.G @ np.array([q0, 0.0]) + chain.offset
        assert lo - 1e-12 <= theta[1] <= hi + 1e-12
    np.testing.assert_allclose(poe(chain, [0.1, 0.2]), chain.fk([0.1, 0.2]), atol=1e-12)


def test_follower_held_outside_its_limits_is_refused_naming_it() -> None:
    with pytest.raises(RobotDescriptionError, match=r"'j2' is held at 1\.5.*'j1'.*\[0, 1\]"):
        SerialChain.from_urdf(two_joint_arm("lower='0' upper='1'", "0", "1.5"), tip_link="tip")


def test_leader_and_follower_without_common_range_are_refused_naming_both() -> None:
    text = two_joint_arm("lower='5' upper='6'", "1", "0")  # j1 ≤ 2 but j2 = j1 ≥ 5
    with pytest.raises(RobotDescriptionError, match=r"'j1'.*'j2'.*no value in common"):
        SerialChain.from_urdf(text, tip_link="tip")


def test_follower_without_position_limits_leaves_the_leader_alone() -> None:
    for limit, kind in ((None, "continuous"), ("", "revolute")):
        chain = SerialChain.from_urdf(two_joint_arm(limit, kind=kind), tip_link="tip")
        np.testing.assert_array_equal((chain.lower[0], chain.upper[0]), (-2, 2))
        assert (chain.moving_lower[1], chain.moving_upper[1]) == (-math.inf, math.inf)
        assert any("no lower/upper" in n for n in chain.notes) == (kind == "revolute")


def test_multiplier_zero_holds_the_follower_at_its_offset() -> None:
    chain = SerialChain.from_urdf(two_joint_arm("lower='0' upper='1'", "0", "0.3"), tip_link="tip")
    assert chain.mimic_joints == (("j2", "j1", 0.0, 0.3),)
    for q in ([0.0, 0.0], [1.3, -0.4]):
        np.testing.assert_allclose(poe(chain, q), chain.fk(q), atol=1e-12)


def test_prismatic_follower_bounds_the_reach_sphere() -> None:
    """Panda to the right finger: its prismatic follower's travel is bounded by the leader's
    limits through the map, so the reach is finite and bounds every tip position."""
    chain = SerialChain.from_urdf(
        erd_path("panda_description/urdf/panda.urdf"), None, "panda_rightfinger"
    )
    c, R = chain.reach_sphere
    assert math.isfinite(R)
    Q = np.random.default_rng(2).uniform(chain.lower, chain.upper, size=(2000, chain.dof))
    d = np.linalg.norm(chain.fk(Q)[:, :3, 3] - c, axis=1)
    assert d.max() <= R < 1.5  # Panda reaches about 1.2 m from its first joint


def test_description_notes_say_what_was_adjusted_or_taken_as_given() -> None:
    text = two_joint_arm().replace('axis xyz="1 0 0"', 'axis xyz="0 0 2"')
    text = text.replace(
        "</robot>",
        '<link name="cam"/><joint name="cam_joint" type="fixed"><parent link="tip"/>'
        '<child link="cam"/><mimic joint="j1"/></joint></robot>',
    )
    notes = RobotDescription(text).notes
    assert len(notes) == 3, notes
    assert "'j2' mimics 'j1'" in notes[0] and "-2·j1 + 0.5" in notes[0]
    assert "'j3'" in notes[1] and "normalised" in notes[1]
    assert "'cam_joint'" in notes[2] and "ignored" in notes[2]
    assert RobotDescription(erd_path("ur_description/urdf/ur5_robot.urdf")).notes == ()


def test_chain_cache_keeps_follower_limits_and_notes(tmp_path, monkeypatch) -> None:
    from kinematics_node.cli import chain_cache

    path = tmp_path / "arm.urdf"
    path.write_text(two_joint_arm().replace('axis xyz="1 0 0"', 'axis xyz="0 0 2"'))
    monkeypatch.setenv("KINEMATICS_CACHE_DIR", str(tmp_path / "cache"))
    fresh = chain_cache.chain_from_urdf_file(path, None, "tip")  # parsed, then written
    cached = chain_cache.chain_from_urdf_file(path, None, "tip")  # read back
    assert list((tmp_path / "cache").glob("*.json"))
    for chain in (fresh, cached):
        np.testing.assert_array_equal((chain.lower[0], chain.upper[0]), (-0.25, 0.75))
        np.testing.assert_array_equal(chain.moving_lower, [-2, -1, -2])
        assert chain.notes == SerialChain.from_urdf(path, None, "tip").notes and chain.notes
        assert chain.mimic_joints == (("j2", "j1", -2.0, 0.5),)
