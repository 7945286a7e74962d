"""`task_scaling.scale_into_bounds` (SNS): the joint velocities carry a share of the command exactly,
within the bounds, and that share is the largest one where it is unique (a square Jacobian), against
SciPy's linear programming (HiGHS) as the oracle."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog
from servo_testing import robot

from kinematics_node.core.servo import dls, task_scaling


def _first(J, c, r):
    sol = dls.solve(J, c + r, 0.05, 0.05)
    a = dls.apply(sol, c)
    return a, sol.undamped + sol.damped - a, sol.row_basis


def _lp_share(J, c, r, lo, hi):
    """max s s.t. J q̇ − s c = r, lo ≤ q̇ ≤ hi, 0 ≤ s ≤ 1 (None if infeasible)."""
    n = J.shape[1]
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    res = linprog(
        cost,
        A_eq=np.hstack([J, -c[:, None]]),
        b_eq=r,
        bounds=list(zip(lo, hi, strict=True)) + [(0.0, 1.0)],
        method="highs",
    )
    return None if res.status != 0 else float(res.x[-1])


def _cases(name, count):
    chain = robot(name)
    rng = np.random.default_rng(7)
    for _ in range(count):
        q = rng.uniform(np.maximum(chain.lower, -3), np.minimum(chain.upper, 3))
        J = chain.jacobian(q, "world")
        if np.linalg.svd(J, compute_uv=False)[-1] < 0.05:
            continue
        c = rng.normal(size=6) * np.array([0.5, 0.5, 0.5, 0.1, 0.1, 0.1])
        r = rng.normal(size=6) * 1e-3
        vmax = rng.uniform(0.1, 1.0, chain.dof)
        lo, hi = -vmax, vmax.copy()
        hi[rng.integers(chain.dof)] = 0.0  # one joint at a bound: may not move further
        yield J, c, r, lo.tolist(), hi.tolist()


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_the_joints_carry_a_share_of_the_command_exactly_within_their_bounds(name):
    checked = missed = 0
    for J, c, r, lo, hi in _cases(name, 60):
        motion = task_scaling.scale_into_bounds(J, c, r, lo, hi, _first(J, c, r), 0.05)
        best = _lp_share(J, c, r, lo, hi)
        if motion is None:
            # SNS is greedy: on a redundant arm it can miss a feasible share (then the servo
            # falls back to a wider box); on a square Jacobian it must not
            assert J.shape[0] < J.shape[1] or best is None or best < 1e-6
            missed += best is not None
            continue
        qd, s = motion.velocities, motion.share
        assert 0.0 <= s <= 1.0
        np.testing.assert_allclose(J @ qd, s * c + r, atol=1e-9)  # the path is kept
        assert np.all(qd >= np.array(lo) - 1e-12) and np.all(qd <= np.array(hi) + 1e-12)
        assert best is not None and s <= best + 1e-9  # never more than the optimum
        if J.shape[0] == J.shape[1]:
            assert s == pytest.approx(best, abs=1e-7)  # unique solution: SNS finds the optimum
        checked += 1
    assert checked >= 20 and missed <= checked // 3  # measured: Panda 9 of 43, iiwa14 fewer


def test_a_command_that_fits_is_carried_whole():
    J = robot("panda").jacobian(np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8]), "world")
    c = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    lo, hi = [-2.0] * 7, [2.0] * 7
    motion = task_scaling.scale_into_bounds(J, c, np.zeros(6), lo, hi, _first(J, c, 0 * c), 0.05)
    assert motion is not None and motion.share == 1.0 and motion.active.all()


def test_largest_share_names_the_joint_that_limits_it():
    s, k = task_scaling.largest_share([0.0, 0.0], [1.0, -4.0], [-1.0, -1.0], [1.0, 1.0])
    assert (s, k) == (0.25, 1)
    s, k = task_scaling.largest_share([2.0, 0.0], [0.0, 1.0], [-1.0, -1.0], [1.0, 1.0])
    assert s == -1.0 and k == 0  # joint 0 fits for no share at all


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_exact_share_is_the_linear_programs_optimum_in_a_box_away_from_zero(name):
    """`exact_share` against HiGHS, in small boxes around a moving state (q̇ = 0 outside them,
    where SNS's premise fails): the same largest share to 1e-9, J q̇ = s c + r exactly."""
    chain = robot(name)
    rng = np.random.default_rng(3)
    solved = infeasible = 0
    for _ in range(120):
        q = rng.uniform(np.maximum(chain.lower, -3), np.minimum(chain.upper, 3))
        J = chain.jacobian(q, "world")
        c = rng.normal(size=6) * np.array([0.5, 0.5, 0.5, 0.1, 0.1, 0.1])
        v = rng.normal(size=chain.dof) * 0.3
        w = rng.uniform(1e-4, 0.05, chain.dof)
        lo, hi = v - w, v + w
        r = J @ (v + rng.uniform(-0.8, 0.8, chain.dof) * w) - rng.uniform(0.0, 1.2) * c
        best = _lp_share(J, c, r, lo, hi)
        got = task_scaling.exact_share(J, c, r, lo.tolist(), hi.tolist(), v.tolist())
        if best is None:
            assert got is None
            infeasible += 1
            continue
        assert got is not None
        qd, s = got
        assert s == pytest.approx(best, abs=1e-9)
        np.testing.assert_allclose(J @ qd, s * c + r, atol=1e-9)
        assert np.all(qd >= lo - 1e-12) and np.all(qd <= hi + 1e-12)
        solved += 1
    assert solved >= 40 and infeasible >= 5  # both kinds were met


def test_exact_share_the_smallest_share_in_a_range():
    J = robot("panda").jacobian(np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8]), "world")
    c = np.array([0.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    lo, hi = [-2.0] * 7, [2.0] * 7
    got = task_scaling.exact_share(J, c, np.zeros(6), lo, hi, [0.0] * 7, (0.3, 1.5), False)
    assert got is not None and got[1] == pytest.approx(0.3)
    np.testing.assert_allclose(J @ got[0], 0.3 * c, atol=1e-12)
