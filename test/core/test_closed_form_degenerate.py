"""Detection never raises on degenerate geometry (issue 24, robust detection).

`benchmarks/fuzz_long.py --n 2000 --seed 4242` found a fuzzed URDF whose last three axes were
exactly parallel: explaining why it had no closed form solved singular normal equations in
`meet_point` and raised numpy's LinAlgError. Chains whose axes are parallel, coincident or all in
one plane must get a family or a sentence saying why none, and `ik_all` a result or
NoClosedFormError, never another exception. The same run later found a UR5e whose elbow sits
866 km away: the candidates' Gauss–Newton refinement then met a J Jᵀ of order 1e12 that its
absolute damping of 1e-12 no longer kept solvable.
"""

from __future__ import annotations

import numpy as np
import pytest

from kinematics_node.core import SerialChain
from kinematics_node.core.exceptions import NoClosedFormError
from kinematics_node.core.ik.closed_form import family_of, no_closed_form_reason
from kinematics_node.core.ik.closed_form.geometry import meet_point
from kinematics_node.sim.robots import robot_path


def _chain(axes, points, tip=(0.0, 0.0, 0.5)):
    """A revolute chain from unit axis directions and a point on each axis [m]."""
    w = np.asarray(axes, dtype=float)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    r = np.asarray(points, dtype=float)
    S = np.vstack((w.T, np.cross(-w, r).T))  # v = −ω × r
    M = np.eye(4)
    M[:3, 3] = tip
    return SerialChain.from_poe(S, M)


Z, X, Y = (0, 0, 1), (1, 0, 0), (0, 1, 0)
DEGENERATE = {
    # every axis parallel (a planar 6R arm)
    "planar": ([Z] * 6, [(0.1 * i, 0.0, 0.0) for i in range(6)]),
    # the last three parallel and distinct, the first three parallel too
    "two parallel triples": ([Z, Z, Z, X, X, X], [(0, 0, 0), (0.3, 0, 0), (0.6, 0, 0),
                              (0, 0.1, 0.2), (0, 0.2, 0.3), (0, 0.3, 0.1)]),
    # all six axes the same line
    "coincident": ([Z] * 6, [(0.0, 0.0, 0.1 * i) for i in range(6)]),
    # seven axes, every one parallel
    "planar 7R": ([Y] * 7, [(0.1 * i, 0.0, 0.0) for i in range(7)]),
}  # fmt: skip


def test_meet_point_of_parallel_lines_is_finite_and_its_distance_exact():
    """Parallel lines: the normal equations are singular; the point is one of the nearest and the
    distance is that of the lines from it (0.2 m from the middle of lines 0.4 m apart)."""
    w = np.array([Z, Z, Z], dtype=float)
    r = np.array([(0.0, 0.0, 0.0), (0.4, 0.0, 0.0), (0.2, 0.0, 5.0)])
    x, miss = meet_point(w, r)
    assert np.all(np.isfinite(x))
    assert miss == pytest.approx(0.2, abs=1e-12)
    # stacked: one singular lane among regular ones
    w2 = np.stack((w, np.array([X, Y, Z], dtype=float)))
    r2 = np.stack((r, np.zeros((3, 3))))
    x2, miss2 = meet_point(w2, r2)
    assert np.all(np.isfinite(x2)) and miss2[1] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("name", list(DEGENERATE))
def test_degenerate_chains_get_a_family_or_a_reason(name):
    chain = _chain(*DEGENERATE[name])
    family = family_of(chain)
    reason = no_closed_form_reason(chain)
    assert (family is None) == (reason != "")
    q = np.linspace(-1.0, 1.0, chain.dof)
    T = chain.fk(q)
    if family is None:
        assert any(w in reason for w in ("no structure", "general", "degenerate", "collinear"))
        with pytest.raises(NoClosedFormError, match="no closed-form IK"):
            chain.ik_all(T)
    else:
        res = chain.ik_all(T)
        for s in res.solutions:
            e = np.linalg.inv(chain.fk(s)) @ T
            assert np.abs(e - np.eye(4)).max() < 1e-9


@pytest.mark.parametrize(
    ("robot", "origin", "fuzzed"),
    [
        # the UR5e's elbow 866 km below its shoulder: J Jᵀ of order 1e12 in the refinement
        ("ur5e", 'xyz="-0.425 0 0" rpy="0 0 0"', 'xyz="-0.425 0 -866238.3871926423" rpy="0 0 0"'),
        # the iiwa14's joint 4 641 km away: a cluster of more than six roots in the general
        # solver (`_clusters`: LAPACK's dgels takes a right-hand side of max(6, m) rows)
        (
            "iiwa14",
            'xyz="0 0 0.4" rpy="-1.5707963267948966 0 0"',
            'xyz="-641354.2210807358 0 0.4" rpy="-1.5707963267948966 0 0"',
        ),
    ],
)
def test_an_arm_of_absurd_size_is_solved_without_raising(robot, origin, fuzzed):
    """Fuzzed arms (`fuzz_long.py`, seeds 4242 and 6): detection (which solves and refines sample
    targets with every candidate order) gives a family or a reason, `ik_all` a result or
    NoClosedFormError, and `ik` an answer with every number finite."""
    text = robot_path(robot).read_text(encoding="utf-8")
    assert text.count(f"<origin {origin}/>") == 1
    chain = SerialChain.from_urdf(
        text.replace(f"<origin {origin}/>", f"<origin {fuzzed}/>").encode()
    )
    family, reason = family_of(chain), no_closed_form_reason(chain)
    assert (family is None) == (reason != "")
    q = np.linspace(-1.1, 1.2, chain.dof)
    T = chain.fk(q)
    if family is None:
        with pytest.raises(NoClosedFormError, match="no closed-form IK"):
            chain.ik_all(T)
    else:
        for s in chain.ik_all(T).solutions:
            assert np.isfinite(s).all()
    single = chain.ik(T)
    assert np.isfinite(single.q).all()
    assert np.isfinite([single.position_error, single.orientation_error]).all()


def test_damping_keeps_a_singular_normal_matrix_solvable_at_any_scale():
    from kinematics_node.core.ik.closed_form.chain_solver import _damped

    for scale in (1e-6, 1.0, 1e12):
        J = np.zeros((6, 6))
        J[:5, :5] = scale * np.eye(5)  # rank 5: one direction lost
        y = np.linalg.solve(_damped(J @ J.T), np.ones(6))
        assert np.isfinite(y).all()
