"""Closed-form IK (`chain.ik_all`): families detected from geometry, every solution, none missed.

Oracles: forward kinematics (every returned solution must reproduce the target to 1e-9, and the
configuration a target came from must be among its solutions), Pinocchio's FK on a real UR5, and
hand-built arms whose family is known by construction.
"""

from __future__ import annotations

import numpy as np
import pytest
from kin_testing import erd_path, random_q, reversed_arm

from kinematics_node.core import (
    InvalidInputError,
    KinematicsError,
    NoClosedFormError,
    SerialChain,
    se3,
)
from kinematics_node.core.ik.closed_form import family_of
from kinematics_node.sim.robots import load_robot

PI = np.pi
FK_TOL = 1e-9


# ---------------------------------------------------------------------- hand-built arms
def dh_arm(rows, lower=-PI, upper=PI):
    """6R arm from standard DH rows (a, alpha, d, theta), limits ±π unless given."""
    return SerialChain.from_dh(
        [
            {"a": a, "alpha": al, "d": d, "theta": th, "type": "R", "lower": lower, "upper": upper}
            for a, al, d, th in rows
        ]
    )


# Puma 560 (Corke's standard DH): axes 1 ∩ 2 and 2 ∥ 3, spherical wrist.
PUMA = [
    (0.0, PI / 2, 0.0, 0.0),
    (0.4318, 0.0, 0.0, 0.0),
    (0.0203, -PI / 2, 0.15005, 0.0),
    (0.0, PI / 2, 0.4318, 0.0),
    (0.0, -PI / 2, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0),
]
# KUKA KR-like OPW arm: shoulder offset a1 (axes 1, 2 do not meet), 2 ∥ 3, spherical wrist.
KUKA = [
    (0.35, -PI / 2, 0.815, 0.0),
    (0.85, 0.0, 0.0, -PI / 2),
    (0.145, -PI / 2, 0.0, 0.0),
    (0.0, PI / 2, 0.82, 0.0),
    (0.0, -PI / 2, 0.0, 0.0),
    (0.0, 0.0, 0.17, 0.0),
]
# Axes 2 ∩ 3 (not parallel), 1 and 2 skew, spherical wrist.
MEET23 = [
    (0.3, PI / 2, 0.4, 0.0),
    (0.0, -PI / 2, 0.1, 0.0),
    (0.05, PI / 2, 0.0, 0.0),
    (0.0, -PI / 2, 0.4, 0.0),
    (0.0, PI / 2, 0.0, 0.0),
    (0.0, 0.0, 0.1, 0.0),
]
# Axes 1 ∥ 2, spherical wrist.
PAR12 = [
    (0.4, 0.0, 0.3, 0.0),
    (0.3, PI / 2, 0.0, 0.0),
    (0.05, -PI / 2, 0.1, 0.0),
    (0.0, PI / 2, 0.4, 0.0),
    (0.0, -PI / 2, 0.0, 0.0),
    (0.0, 0.0, 0.1, 0.0),
]


def ur5_erd(limited=True):
    name = "ur5_joint_limited_robot.urdf" if limited else "ur5_robot.urdf"
    return SerialChain.from_urdf(erd_path(f"ur_description/urdf/{name}"), None, "tool0")


# ---------------------------------------------------------------------- helpers
def seeded_batch_no_miss(chain, q, held=None, held_joint=None):
    """ik_all_batch(fk(q)) from the middle-of-limits seed.

    Returns (missed, res): missed[i] is True when no solution of target i lies within
    tol_i = 1e-6 + 1e-13 / σ_min(J(q_i)) [rad] of q_i. Near a singularity at distance s the pose
    fixes some joint combinations only to ~ε/σ_min (σ_min ~ s or s²): there a different q′ with
    ‖fk(q′) − fk(q)‖ ~ 1e-16 is as much a solution as q itself, so the tolerance follows the
    conditioning (1e-13 = 1000 × the FK round-off).
    """
    res = chain.ik_all_batch(chain.fk(q), held=held)
    owner = np.repeat(np.arange(len(q)), res.count)
    d = np.abs(res.solutions - q[owner]).max(axis=1)
    best = np.full(len(q), np.inf)
    np.minimum.at(best, owner, d)
    J = chain.jacobian(q, "body")
    if held_joint is not None:
        J = np.delete(J, held_joint, axis=2)
    sigma_min = np.linalg.svd(J, compute_uv=False)[:, -1]
    return best > 1e-6 + 1e-13 / sigma_min, res


def assert_reproduces(chain, sols, T, tol=FK_TOL):
    """Every solution reproduces its target by FK: ‖Δp‖ ≤ tol [m], ‖ΔR‖_F/√2 ≤ tol [rad]."""
    Tq = chain.fk(sols)
    assert np.all(np.linalg.norm(Tq[..., :3, 3] - T[..., :3, 3], axis=-1) <= tol)
    assert np.all(
        np.linalg.norm(Tq[..., :3, :3] - T[..., :3, :3], axis=(-2, -1)) / np.sqrt(2) <= tol
    )


def near_singular(q, rng, joint, value=0.0, fraction=0.25):
    """Put `fraction` of the rows within 1e-7..1e-3 rad of a singular value of one joint."""
    q = q.copy()
    m = rng.random(len(q)) < fraction
    q[m, joint] = value + rng.choice((-1.0, 1.0), m.sum()) * 10.0 ** rng.uniform(-7, -3, m.sum())
    return q


# ---------------------------------------------------------------------- detection
@pytest.mark.parametrize(
    ("robot", "family", "held"),
    [
        ("ur5e", "three_parallel", None),
        ("panda", "7r_spherical_wrist", "panda_joint7"),
        ("iiwa14", "7r_spherical_wrist", "iiwa_joint_3"),
        ("planar3r", None, None),
        ("scara", None, None),
    ],
)
def test_bundled_arms_family(robot, family, held):
    chain = load_robot(robot)
    assert chain.ik_family == family
    info = family_of(chain)
    if family is None:
        assert info is None
        with pytest.raises(NoClosedFormError, match="no closed-form IK.*use chain.ik"):
            chain.ik_all(chain.fk(np.zeros(chain.dof)))
    else:
        assert info.name == family and info.held_joint == held


@pytest.mark.parametrize(
    ("rel", "tip", "family", "held"),
    [
        ("ur_description/urdf/ur3_robot.urdf", "tool0", "three_parallel", None),
        ("ur_description/urdf/ur5_robot.urdf", "tool0", "three_parallel", None),
        ("ur_description/urdf/ur10_robot.urdf", "tool0", "three_parallel", None),
        ("z1_description/urdf/z1.urdf", "link06", "three_parallel", None),
        ("kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", "spherical_wrist", None),
        ("panda_description/urdf/panda.urdf", "panda_hand", "7r_spherical_wrist", "panda_joint7"),
        ("xarm_description/urdf/xarm7.urdf", "link_eef", "7r_spherical_wrist", "joint7"),
        ("baxter_description/urdf/baxter.urdf", "left_gripper", "7r_general_6r", "left_e0"),
    ],
)
def test_example_robot_data_arms_family(rel, tip, family, held):
    chain = SerialChain.from_urdf(erd_path(rel), "torso" if "baxter" in rel else None, tip)
    assert chain.ik_family == family
    if family is not None:
        assert family_of(chain).held_joint == held


def test_hand_built_arms_family():
    assert family_of(dh_arm(PUMA)).name == "spherical_wrist"
    kuka = family_of(dh_arm(KUKA))
    assert (kuka.name, kuka.position_case, kuka.reversed) == ("spherical_wrist", "2∥3", False)
    assert family_of(dh_arm(MEET23)).position_case == "2∩3"
    assert family_of(dh_arm(PAR12)).position_case == "1∥2"
    rev = family_of(reversed_arm(dh_arm(KUKA)))
    assert (rev.name, rev.reversed) == ("spherical_wrist", True)


@pytest.mark.parametrize("offset", [1e-3, 1e-4])
def test_arms_just_outside_a_family_go_to_the_general_solver(offset):
    """Not detected as the named family they miss; the general 6R solver takes them, and its set
    contains the configuration the target came from."""
    # Puma and KUKA with an offset wrist (a5 ≠ 0: axes 5 and 6 miss each other).
    q = np.array([0.3, -0.4, 0.5, 0.6, -0.7, 0.8])
    for rows in (PUMA, KUKA):
        bad = [list(r) for r in rows]
        bad[4][0] = offset
        chain = dh_arm(bad)
        assert chain.ik_family == "general_6r"
        sols = chain.ik_all(chain.fk(q)).solutions
        assert np.abs(np.asarray(sols) - q).max(axis=1).min() < 1e-9
    # KUKA with joint 3 tilted (axes 2 and 3 no longer parallel, and they do not meet).
    bad = [list(r) for r in KUKA]
    bad[1][1] = offset
    assert dh_arm(bad).ik_family == "general_6r"
    # UR5 with its wrist (axes 4-6) tilted about the base x axis: axis 4 is no longer parallel
    # to axes 2 and 3 (and the wrist axes still do not meet at a point).
    ur = ur5_erd()
    S = np.asarray(ur.S).copy()
    S[:, 3:] = se3.adjoint(se3.make_transform(_rot_x(offset), np.zeros(3))) @ S[:, 3:]
    assert ur.ik_family == "three_parallel"
    assert SerialChain.from_poe(S, ur.M, lower=ur.lower, upper=ur.upper).ik_family == "general_6r"


def _rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array(((1, 0, 0), (0, c, -s), (0, s, c)))


def test_prismatic_and_wrong_size_chains_have_no_closed_form():
    for robot in ("scara", "planar3r"):
        chain = load_robot(robot)
        with pytest.raises(NoClosedFormError) as exc:
            chain.ik_all(chain.fk(np.zeros(chain.dof)))
        assert isinstance(exc.value, KinematicsError)
        assert "prismatic" in str(exc.value) or "joints" in str(exc.value)


# ---------------------------------------------------------------------- no solution missed
NO_MISS = [
    ("ur5 (three_parallel)", lambda: ur5_erd(), (4, 0.0), 10_000),
    ("puma (spherical_wrist)", lambda: dh_arm(PUMA), (4, 0.0), 10_000),
    ("kuka (spherical_wrist 2∥3)", lambda: dh_arm(KUKA), (4, 0.0), 10_000),
    ("meet23 (spherical_wrist 2∩3)", lambda: dh_arm(MEET23), (4, 0.0), 3_000),
    ("par12 (spherical_wrist 1∥2)", lambda: dh_arm(PAR12), (4, 0.0), 3_000),
    ("reversed kuka (spherical shoulder)", lambda: reversed_arm(dh_arm(KUKA)), (1, 0.0), 3_000),
]


@pytest.mark.parametrize(
    ("label", "make", "singular_joint", "n"), NO_MISS, ids=[c[0] for c in NO_MISS]
)
def test_no_solution_missed_6r(label, make, singular_joint, n):
    chain = make()
    rng = np.random.default_rng(2024)
    q = near_singular(random_q(chain, rng, n), rng, *singular_joint)
    missed, res = seeded_batch_no_miss(chain, q)
    assert not missed.any(), f"{label}: {missed.sum()} of {n} configurations missed"
    owner = np.repeat(np.arange(n), res.count)
    assert_reproduces(chain, res.solutions, chain.fk(q)[owner])
    assert chain.within_limits(res.solutions).all()
    assert res.count.max() <= 8


@pytest.mark.parametrize(
    ("robot", "singular_joint"), [("panda", 1), ("iiwa14", 5)], ids=["panda", "iiwa14"]
)
def test_no_solution_missed_7r_with_the_held_value(robot, singular_joint):
    chain = load_robot(robot)
    j = chain.joint_index(family_of(chain).held_joint)
    rng = np.random.default_rng(7)
    q = near_singular(random_q(chain, rng, 10_000), rng, singular_joint)
    missed, res = seeded_batch_no_miss(chain, q, q[:, j : j + 1], j)
    assert not missed.any(), f"{missed.sum()} missed"
    owner = np.repeat(np.arange(len(q)), res.count)
    assert_reproduces(chain, res.solutions, chain.fk(q)[owner])
    np.testing.assert_allclose(res.solutions[:, j], q[owner, j], atol=1e-12)


def test_no_solution_missed_7r_three_parallel():
    chain = SerialChain.from_urdf(erd_path("z1_description/urdf/z1.urdf"), None, "gripperMover")
    assert chain.ik_family == "7r_three_parallel"
    j = chain.joint_index(family_of(chain).held_joint)
    rng = np.random.default_rng(8)
    q = near_singular(random_q(chain, rng, 10_000), rng, 4)
    missed, _ = seeded_batch_no_miss(chain, q, q[:, j : j + 1], j)
    assert not missed.any()


# ---------------------------------------------------------------------- single calls
def test_single_call_equals_batch_and_sorts_by_distance_to_the_seed():
    for chain in (ur5_erd(), dh_arm(PUMA), reversed_arm(dh_arm(KUKA))):
        rng = np.random.default_rng(3)
        q = random_q(chain, rng, 60)
        seeds = random_q(chain, rng, 60)
        T = chain.fk(q)
        batch = chain.ik_all_batch(T, seeds)
        for i in range(len(q)):
            res = chain.ik_all(T[i], seeds[i])
            sols = np.array(res.solutions)
            assert res.success and sols.shape == batch.solutions_of(i).shape
            np.testing.assert_allclose(sols, batch.solutions_of(i), atol=1e-9)
            d = np.linalg.norm(sols - seeds[i], axis=1)
            assert np.all(np.diff(d) >= -1e-12)
            np.testing.assert_array_equal(res.q, sols[0])
            assert res.position_error <= FK_TOL and res.orientation_error <= FK_TOL
            assert not res.singular and "solution" in res.message


def test_angles_on_a_limit_of_pi_give_both_equivalents_in_a_single_call_as_in_a_batch():
    """With limits of ±π an angle of exactly ±π has two equivalents within the limits (the
    single call's float path hands these to the vectorised one); angles just inside have one."""
    chain = ur5_erd()
    rng = np.random.default_rng(8)
    q = random_q(chain, rng, 12)
    q[0:4, 0] = np.pi
    q[4:8, 5] = -np.pi
    q[8:12, 3] = np.pi - 1e-7
    T = chain.fk(q)
    batch = chain.ik_all_batch(T)
    for i in range(len(q)):
        sols = np.array(chain.ik_all(T[i]).solutions)
        other = batch.solutions_of(i)

        def rows(a: np.ndarray) -> np.ndarray:  # ±π twins lie equally far from the seed: any order
            return a[np.lexsort(np.round(a, 9).T[::-1])]

        np.testing.assert_allclose(rows(sols), rows(other), atol=1e-9)
        d = np.linalg.norm(sols - (chain.lower + chain.upper) / 2, axis=1)  # the default seed
        assert np.all(np.diff(d) >= -1e-12)
        assert np.abs(sols - q[i]).max(axis=1).min() < 1e-9  # q itself is among them
        if i < 8:  # ±π and its equivalent ∓π: at least two solutions share the other joints
            j = 0 if i < 4 else 5
            twin = q[i].copy()
            twin[j] = -twin[j]
            assert np.abs(sols - twin).max(axis=1).min() < 1e-9


def test_solutions_match_pinocchio_fk_on_a_real_ur5():
    pin = pytest.importorskip("pinocchio")
    path = erd_path("ur_description/urdf/ur5_robot.urdf")
    chain = SerialChain.from_urdf(path, None, "tool0")
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    tip = model.getFrameId("tool0")
    rng = np.random.default_rng(5)
    for q in random_q(chain, rng, 10):
        T = chain.fk(q)
        res = chain.ik_all(T)
        assert len(res.solutions) > 8  # ±2π limits: whole-turn equivalents too
        for s in res.solutions[::7]:
            pin.framesForwardKinematics(model, data, s)
            np.testing.assert_allclose(data.oMf[tip].homogeneous, T, atol=1e-9)


def test_limits_wider_than_two_pi_give_every_equivalent():
    chain = load_robot("ur5e")  # ±2π on every joint but the elbow (±π)
    rng = np.random.default_rng(9)
    for q in random_q(chain, rng, 20):
        res = chain.ik_all(chain.fk(q))
        sols = np.array(res.solutions)
        assert chain.within_limits(sols).all()
        # Distinct configurations, and together they are closed under ±2π on every joint.
        assert len(np.unique(np.round(sols, 6), axis=0)) == len(sols)
        keys = {tuple(np.round(s, 6)) for s in sols}
        for s in sols:
            for j in range(6):
                for k in (-1, 1):
                    t = s.copy()
                    t[j] += 2 * PI * k
                    if chain.lower[j] <= t[j] <= chain.upper[j]:
                        assert tuple(np.round(t, 6)) in keys
        assert np.abs(sols - q).max(axis=1).min() < 1e-6


def test_seven_r_default_sweep_and_given_values():
    chain = load_robot("panda")
    j = chain.joint_index("panda_joint7")
    q = np.array([0.3, -0.4, 0.2, -2.0, 0.1, 1.8, 0.6])
    T = chain.fk(q)
    res = chain.ik_all(T)
    assert res.success and len(res.held_values) == 36
    sols = np.array(res.solutions)
    assert set(np.round(sols[:, j], 12)) <= set(np.round(res.held_values, 12))
    assert_reproduces(chain, sols, T)
    res = chain.ik_all(T, held=[0.6, 0.0])
    sols = np.array(res.solutions)
    assert np.abs(sols - q).max(axis=1).min() < 1e-9
    assert "2 values of panda_joint7 swept" in res.message


@pytest.mark.parametrize("arm", ["ur5 ±2π", "panda, shared held values", "panda, per-target held"])
def test_a_batch_solved_in_several_passes_equals_one_pass(monkeypatch, arm):
    """ik_all_batch works in passes of SOLVE_CHUNK lanes; with passes of 5 lanes (partial last
    pass, a 7R sweep split across targets) every field equals the one-pass result, including
    unreachable and singular targets."""
    from kinematics_node.core.ik.closed_form import chain_solver as cf

    rng = np.random.default_rng(5)
    chain = ur5_erd(limited=False) if arm.startswith("ur5") else load_robot("panda")
    q = random_q(chain, rng, 23)
    if arm.startswith("ur5"):
        q[4, 4] = 0.0  # wrist singular
    T = chain.fk(q)
    T[7, :3, 3] += (3.0, 0.0, 0.0)  # out of reach
    held = None
    if arm == "panda, shared held values":
        held = np.linspace(-2.0, 2.0, 3)
    elif arm == "panda, per-target held":
        held = np.stack((q[:, 6], q[:, 6] * 0.5), axis=1)
    monkeypatch.setattr(cf, "SOLVE_CHUNK", 10**9)
    one = chain.ik_all_batch(T, held=held)
    monkeypatch.setattr(cf, "SOLVE_CHUNK", 5)
    many = chain.ik_all_batch(T, held=held)
    assert one.count[7] == 0 and one.count.sum() > 23
    assert one.singular[4] or not arm.startswith("ur5")
    for field in ("q", "success", "count", "offsets", "solutions", "singular"):
        np.testing.assert_array_equal(getattr(many, field), getattr(one, field), err_msg=field)
    assert many.message == one.message


# ---------------------------------------------------------------------- singular and unreachable
def test_singular_wrist_gives_a_valid_set_and_says_so():
    # UR: joint 6 parallel to joints 2-4, so joint 6 is undetermined (joint 4 takes the rest);
    # Puma: joints 4 and 6 coincide, joint 4 is undetermined (joint 6 takes the rest).
    for chain, q, free in (
        (ur5_erd(), np.array([0.4, -1.0, 1.2, 0.3, 0.0, -0.5]), 5),
        (dh_arm(PUMA), np.array([0.4, -0.6, 0.5, 0.3, 0.0, -0.5]), 3),
    ):
        T = chain.fk(q)
        seed = np.array([0.0, 0.0, 0.0, 0.9, 0.0, 0.7])
        res = chain.ik_all(T, seed)
        sols = np.array(res.solutions)
        assert res.success and res.singular and "singular" in res.message
        assert np.all(np.isfinite(sols))
        assert_reproduces(chain, sols, T)
        # The undetermined joint took the seed's value on some branch.
        assert np.abs(sols[:, free] - seed[free]).min() < 1e-9
        batch = chain.ik_all_batch(T[None], seed[None])
        assert batch.singular[0] and batch.count[0] == len(sols)


def test_wrist_centre_on_the_first_axis_is_singular_not_nan():
    # Elbow manipulator pointing straight up at home (MR Fig. 6.1 style): the wrist centre lies on
    # axis 1, so q1 is undetermined there.
    L1, L2, L3 = 0.4, 0.5, 0.4
    z, y, x = np.array([0, 0, 1.0]), np.array([0, 1.0, 0]), np.array([1.0, 0, 0])

    def screw(w, p):
        return np.r_[w, np.cross(p, w)]

    wc = np.array([0, 0, L1 + L2 + L3])
    S = np.column_stack(
        [
            screw(z, np.zeros(3)),
            screw(y, np.array([0, 0, L1])),
            screw(y, np.array([0, 0, L1 + L2])),
            screw(z, wc),
            screw(y, wc),
            screw(x, wc),
        ]
    )
    M = se3.make_transform(np.eye(3), wc + np.array([0, 0, 0.1]))
    chain = SerialChain.from_poe(S, M, lower=[-PI] * 6, upper=[PI] * 6)
    assert chain.ik_family == "spherical_wrist"
    q = np.array([0.0, 0.0, 0.0, 0.2, 0.3, 0.1])
    res = chain.ik_all(chain.fk(q), np.array([0.7, 0, 0, 0, 0, 0]))
    assert res.success and res.singular and "joint 1's axis" in res.message
    sols = np.array(res.solutions)
    assert np.all(np.isfinite(sols))
    assert_reproduces(chain, sols, chain.fk(q))
    assert np.abs(sols[:, 0] - 0.7).min() < 1e-9  # q1 from the seed


def test_unreachable_targets_give_an_empty_set_and_the_reason():
    chain = ur5_erd()
    T = chain.fk(np.zeros(6))
    T[:3, 3] += (3.0, 0.0, 0.0)
    res = chain.ik_all(T)
    assert not res.success and res.solutions == ()
    assert "unreachable" in res.message and "reach" in res.message
    assert np.all(np.isfinite(res.q)) and chain.within_limits(res.q)
    assert res.position_error > 1.0
    batch = chain.ik_all_batch(np.stack((T, chain.fk(np.full(6, 0.3)))))
    assert batch.count[0] == 0 and batch.count[1] > 0 and batch.success.tolist() == [False, True]
    np.testing.assert_array_equal(batch.q[0], chain.ik_all(T).q)


def test_solutions_outside_the_limits_are_reported():
    chain = dh_arm(PUMA, lower=-0.2, upper=0.2)
    q = np.array([0.1, 0.1, 0.1, 0.1, 0.1, 0.1])
    T = chain.fk(q)
    assert chain.ik_all(T).success
    T_far = dh_arm(PUMA).fk(np.array([2.0, 0.1, 0.1, 0.1, 0.1, 0.1]))
    res = chain.ik_all(T_far)
    assert not res.success and "none lies within the joint limits" in res.message


# ---------------------------------------------------------------------- bad input
def test_bad_input_is_refused_with_a_clear_message():
    ur = ur5_erd()
    T = ur.fk(np.zeros(6))
    with pytest.raises(InvalidInputError, match="held is only for 7R"):
        ur.ik_all(T, held=0.3)
    with pytest.raises(InvalidInputError, match=r"shape \(4, 4\)"):
        ur.ik_all(np.stack((T, T)))
    bad = T.copy()
    bad[0, 3] = np.nan
    with pytest.raises(InvalidInputError, match="non-finite"):
        ur.ik_all(bad)
    with pytest.raises(InvalidInputError, match="rotation"):
        ur.ik_all(np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(InvalidInputError, match="tolerance"):
        ur.ik_all(T, tolerance=0.0)
    with pytest.raises(InvalidInputError, match="6 values"):
        ur.ik_all(T, q_seed=np.zeros(5))
    with pytest.raises(InvalidInputError, match=r"\(N, 4, 4\)"):
        ur.ik_all_batch(T)
    panda = load_robot("panda")
    Tp = panda.fk(np.zeros(7) - 0.5)
    with pytest.raises(InvalidInputError, match="within its limits"):
        panda.ik_all(Tp, held=10.0)
    with pytest.raises(InvalidInputError, match="held must be"):
        panda.ik_all(Tp, held=np.zeros((2, 2)))


def test_results_are_read_only_and_a_slightly_off_rotation_is_accepted():
    ur = ur5_erd()
    q = np.array([0.2, -0.8, 1.0, 0.1, 0.5, -0.3])
    T = ur.fk(q)
    res = ur.ik_all(T)
    with pytest.raises(ValueError):
        res.q[0] = 1.0
    with pytest.raises(ValueError):
        res.solutions[0][0] = 1.0
    batch = ur.ik_all_batch(T[None])
    with pytest.raises(ValueError):
        batch.solutions[0, 0] = 1.0
    # A rotation off SO(3) by 1e-8 (within check_transform's 1e-6) is projected back, not refused.
    T_off = T.copy()
    T_off[:3, :3] *= 1 + 1e-8
    res_off = ur.ik_all(T_off)
    assert res_off.success and np.abs(np.array(res_off.solutions) - q).max(axis=1).min() < 1e-6


def test_continuous_joints_come_back_within_pi_of_the_seed():
    # Kinova Jaco 2 (example-robot-data): spherical wrist, joints 1, 4 and 6 continuous.
    path = erd_path("kinova_description/robots/kinova.urdf")
    chain = SerialChain.from_urdf(path, None, "j2s6s200_end_effector")
    assert chain.ik_family == "spherical_wrist" and chain.continuous.sum() == 3
    rng = np.random.default_rng(12)
    q, seeds = random_q(chain, rng, 2000), random_q(chain, rng, 2000)
    res = chain.ik_all_batch(chain.fk(q), seeds)
    owner = np.repeat(np.arange(len(q)), res.count)
    diff = np.abs(np.angle(np.exp(1j * (res.solutions - q[owner])))).max(axis=1)  # modulo 2π
    best = np.full(len(q), np.inf)
    np.minimum.at(best, owner, diff)
    assert best.max() < 1e-6
    cont = chain.continuous
    assert np.abs(res.solutions[:, cont] - seeds[owner][:, cont]).max() <= PI + 1e-9
    assert chain.within_limits(res.solutions).all()
