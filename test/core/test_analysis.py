"""Manipulability, ellipsoid, condition number and singularity checks."""

import numpy as np
import pytest
from kin_testing import random_q

from kinematics_node.core import (
    condition_number,
    is_near_singular,
    manipulability,
    manipulability_ellipsoid,
)


def test_measures_agree_with_their_definitions(real_arm):
    chain, _ = real_arm
    for q in random_q(chain, np.random.default_rng(31), 5):
        J = chain.jacobian(q, "world")
        Jv = J[3:]
        assert manipulability(J, "linear") == pytest.approx(
            np.sqrt(np.linalg.det(Jv @ Jv.T)), rel=1e-9
        )
        assert condition_number(J, "full") == pytest.approx(np.linalg.cond(J), rel=1e-9)
        lengths, dirs = manipulability_ellipsoid(J, "linear")
        # principal semi-axes: eigenvectors of J Jᵀ, lengths √λ (MR §5.4)
        lam, vec = np.linalg.eigh(Jv @ Jv.T)
        np.testing.assert_allclose(lengths, np.sqrt(lam[::-1]), rtol=1e-9)
        for k in range(3):
            assert abs(dirs[:, k] @ vec[:, 2 - k]) == pytest.approx(1.0, abs=1e-8)


def test_ur5_wrist_singularity_is_detected():
    from kin_testing import erd_path

    from kinematics_node.core import SerialChain

    chain = SerialChain.from_urdf(erd_path("ur_description/urdf/ur5_robot.urdf"), tip_link="tool0")
    q = np.array([0.3, -1.2, 1.4, 0.2, 0.0, 0.7])  # wrist 2 at 0: axes 4 and 6 parallel
    J = chain.jacobian(q, "world")
    assert is_near_singular(J, "full", threshold=1e-9)
    assert condition_number(J) > 1e12
    assert manipulability(J) == pytest.approx(0.0, abs=1e-12)
    q[4] = 0.8
    assert not is_near_singular(chain.jacobian(q, "world"), "full")


def test_batched_measures_shapes(real_arm):
    chain, _ = real_arm
    J = chain.jacobian(random_q(chain, np.random.default_rng(32), 8), "world")
    assert manipulability(J).shape == (8,)
    assert condition_number(J, "angular").shape == (8,)
    with pytest.raises(ValueError, match="part must be"):
        manipulability(J, "twist")


def test_conditioning_gathers_the_measures_of_one_jacobian(real_arm):
    from kinematics_node.core import conditioning, singular_values

    chain, _ = real_arm
    for q in random_q(chain, np.random.default_rng(32), 3):
        J = chain.jacobian(q, "world")
        c = conditioning(J, singular_threshold=1e-3)
        assert c.manipulability == pytest.approx(float(manipulability(J, "linear")), rel=1e-12)
        assert c.condition_number == pytest.approx(float(condition_number(J, "full")), rel=1e-12)
        assert c.min_singular_value == pytest.approx(np.linalg.svd(J, compute_uv=False)[-1])
        assert c.near_singular == bool(is_near_singular(J, "full", 1e-3))
        np.testing.assert_allclose(
            singular_values(J, "angular"), np.linalg.svd(J[:3], compute_uv=False)
        )
    J0 = np.zeros((6, chain.dof))  # every singular value 0: singular, infinitely ill-conditioned
    c0 = conditioning(J0)
    assert c0.condition_number == np.inf and c0.near_singular and c0.manipulability == 0.0


def test_translational_ellipsoid_is_the_svd_of_the_linear_rows(real_arm):
    """Axes, lengths and pose of the ellipsoid against numpy's eigen-decomposition of J_v J_vᵀ
    (not the SVD the code uses): R diag(σ²) Rᵀ = J_v J_vᵀ, R a proper rotation."""
    from kinematics_node.core.analysis import translational_ellipsoid

    chain, _ = real_arm
    for q in random_q(chain, np.random.default_rng(7), 40):
        T, J = chain.fk_jacobian(q, "world")
        e = translational_ellipsoid(J, T[:3, 3])
        Jv = J[3:]
        lam, vec = np.linalg.eigh(Jv @ Jv.T)
        np.testing.assert_allclose(e.semi_axes, np.sqrt(np.clip(lam[::-1], 0, None)), rtol=1e-9)
        R = e.rotation
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(R @ np.diag(e.semi_axes**2) @ R.T, Jv @ Jv.T, atol=1e-12)
        for k in range(3):
            assert abs(R[:, k] @ vec[:, 2 - k]) == pytest.approx(1.0, abs=1e-8)
        np.testing.assert_array_equal(e.weakest, R[:, 2])
        np.testing.assert_array_equal(e.centre, T[:3, 3])
        assert e.condition_number == pytest.approx(np.linalg.cond(Jv), rel=1e-9)


def test_translational_ellipsoid_rotation_is_proper_where_numpys_u_is_not():
    """Random Jacobians, some of whose U (numpy's SVD) are reflections: the rotation is proper
    and still diagonalises J_v J_vᵀ."""
    from kinematics_node.core.analysis import translational_ellipsoid

    rng = np.random.default_rng(3)
    reflections = 0
    for n in range(1, 8):  # LAPACK's U is a reflection for every 3 x 4, about half the 3 x 1
        for _ in range(10):
            J = rng.normal(size=(6, n))
            reflections += np.linalg.det(np.linalg.svd(J[3:])[0]) < 0
            e = translational_ellipsoid(J, np.zeros(3))
            assert np.linalg.det(e.rotation) == pytest.approx(1.0, abs=1e-12)
            np.testing.assert_allclose(
                e.rotation @ np.diag(e.semi_axes**2) @ e.rotation.T, J[3:] @ J[3:].T, atol=1e-12
            )
    assert reflections > 5  # the flip was exercised


def test_translational_ellipsoid_of_a_planar_arm_is_flat():
    """Fewer than 3 linear singular values (a 2-joint planar arm): σ₃ = 0, κ = ∞, the weakest
    direction is the plane's normal."""
    from kinematics_node.core import SerialChain
    from kinematics_node.core.analysis import translational_ellipsoid

    chain = SerialChain.from_dh([[1.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0]])
    T, J = chain.fk_jacobian(np.array([0.3, 0.8]), "world")
    e = translational_ellipsoid(J, T[:3, 3])
    assert e.semi_axes[2] == 0.0 and e.semi_axes[1] > 0.0
    assert e.condition_number == np.inf
    assert abs(e.weakest[2]) == pytest.approx(1.0)
    assert np.linalg.det(e.rotation) == pytest.approx(1.0)


def test_translational_ellipsoid_refuses_bad_input():
    from kinematics_node.core.analysis import translational_ellipsoid

    with pytest.raises(ValueError, match="finite"):
        translational_ellipsoid(np.full((6, 3), np.nan), np.zeros(3))
    with pytest.raises(ValueError, match=r"\(6, n\)"):
        translational_ellipsoid(np.zeros((3, 3)), np.zeros(3))


def test_condition_colour_goes_from_green_to_red_monotonically():
    from kinematics_node.core.analysis import RED_CONDITION, condition_colour

    kappas = np.concatenate(([1.0], np.geomspace(1.0001, 1e4, 400), [np.inf]))
    rgb = np.array([condition_colour(float(k)) for k in kappas])
    assert tuple(rgb[0]) == (0.0, 1.0, 0.0)
    assert tuple(rgb[-1]) == (1.0, 0.0, 0.0)
    assert condition_colour(RED_CONDITION) == (1.0, 0.0, 0.0)
    assert condition_colour(np.sqrt(RED_CONDITION)) == pytest.approx((1.0, 1.0, 0.0))
    assert (np.diff(rgb[:, 0]) >= 0).all() and (np.diff(rgb[:, 1]) <= 0).all()
    assert (np.diff(rgb[:, 0]) > 0).any() and (np.diff(rgb[:, 1]) < 0).any()
    for bad in (np.nan, 0.5):
        with pytest.raises(ValueError, match="condition number"):
            condition_colour(bad)
