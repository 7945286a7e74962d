"""`closed_form.branches_within_limits` (what a reachability map solves) against `ik_all_batch`
(every solution, whole-turn equivalents too): the same branches, each once."""

from __future__ import annotations

import numpy as np
import pytest
from kin_testing import random_q

from kinematics_node.core import SerialChain
from kinematics_node.core.ik.closed_form import branches_within_limits
from kinematics_node.sim.robots import load_robot

PI = np.pi


def _wrapped(Q: np.ndarray) -> np.ndarray:
    return (np.asarray(Q) + PI) % (2 * PI) - PI


def _distinct_mod_2pi(Q: np.ndarray, tol: float = 1e-6) -> list[np.ndarray]:
    """The rows of Q that differ modulo 2π (each class once)."""
    kept: list[np.ndarray] = []
    for q in _wrapped(Q):
        if not any(np.abs(_wrapped(q - k)).max() <= tol for k in kept):
            kept.append(q)
    return kept


def _targets(chain: SerialChain, rng: np.random.Generator, n: int) -> np.ndarray:
    """FK of random configurations (reachable), then as many random poses in the bound's cube
    (mostly unreachable)."""
    T = chain.fk(random_q(chain, rng, n))
    from scipy.spatial.transform import Rotation

    other = np.tile(np.eye(4), (n, 1, 1))
    other[:, :3, :3] = Rotation.random(n, random_state=rng.integers(1 << 31)).as_matrix()
    other[:, :3, 3] = rng.uniform(-1.0, 1.0, (n, 3))
    return np.concatenate([T, other])


def _check_same_branches(chain: SerialChain, T: np.ndarray, held=None) -> int:
    every = chain.ik_all_batch(T, held=held)
    got = branches_within_limits(chain, T, held)
    assert np.all(np.diff(got.target) >= 0), "branches grouped by target, in order"
    fk = chain.fk(got.q)
    assert np.abs(fk[:, :3, 3] - T[got.target, :3, 3]).max(initial=0) <= 1e-9
    assert np.all(got.q >= chain.lower - 1e-12) and np.all(got.q <= chain.upper + 1e-12)
    total = 0
    for i in range(T.shape[0]):
        mine = got.q[got.target == i]
        theirs = every.solutions_of(i)
        classes = _distinct_mod_2pi(theirs)
        # as many branches as ik_all_batch has distinct solutions modulo 2π, each once ...
        assert mine.shape[0] == len(classes), (i, mine, classes)
        assert len(_distinct_mod_2pi(mine)) == mine.shape[0], f"target {i}: a branch twice"
        # ... each one of ik_all_batch's solutions (itself, not only modulo 2π)
        for q in mine:
            assert np.abs(theirs - q).max(axis=1).min() <= 1e-9, (i, q)
        total += mine.shape[0]
    return total


def test_ur5e_with_whole_turn_limits():
    chain = load_robot("ur5e")  # ±2π: each branch has up to 64 equivalents within the limits
    T = _targets(chain, np.random.default_rng(5), 30)
    found = _check_same_branches(chain, T)
    assert found >= 30 * 2  # the reachable half has several branches each


def test_an_arm_with_half_turn_limits():
    ur = load_robot("ur5e")
    chain = SerialChain.from_poe(
        np.asarray(ur.S), np.asarray(ur.M), lower=[-PI] * 6, upper=[PI] * 6
    )
    T = _targets(chain, np.random.default_rng(6), 60)
    assert _check_same_branches(chain, T) >= 60


def test_an_arm_with_tight_limits_drops_branches_outside():
    ur = load_robot("ur5e")
    lo = np.array([-PI, -PI, -2.8, -PI, -PI, -PI]) / 2
    chain = SerialChain.from_poe(np.asarray(ur.S), np.asarray(ur.M), lower=lo, upper=-lo)
    T = _targets(chain, np.random.default_rng(7), 60)
    _check_same_branches(chain, T)


@pytest.mark.parametrize("held", [[0.3], [-1.0, 0.0, 1.2]])
def test_panda_with_its_held_joint_at_given_values(held):
    chain = load_robot("panda")
    T = _targets(chain, np.random.default_rng(8), 25)
    _check_same_branches(chain, T, held=held)


def test_panda_at_the_default_sweep_finds_the_configuration_it_came_from():
    chain = load_robot("panda")
    rng = np.random.default_rng(9)
    q = random_q(chain, rng, 20)
    got = branches_within_limits(chain, chain.fk(q))
    # with the held joint swept over 36 values, a reachable target has branches at many of them
    assert set(got.target.tolist()) == set(range(20))


def test_wrist_singular_targets_count_each_branch_once():
    # At a wrist singularity (wrist 2 at 0) branches of different formulas coincide: counted
    # once, as ik_all_batch's set has them once modulo 2π. (Not so at a straight elbow: the
    # elbow-up and elbow-down branches stay 8e-8 rad apart there, √ε, and count twice in both.)
    chain = load_robot("ur5e")
    q = random_q(chain, np.random.default_rng(13), 20)
    q[:, 4] = 0.0
    assert _check_same_branches(chain, chain.fk(q)) >= 20
