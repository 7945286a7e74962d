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
