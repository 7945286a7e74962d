"""The single-target paths of the closed form (`ik_all` on one target) against the general ones.

The prepared three-parallel solver (`closed_form.three_parallel.ThreeParallel`) must give the candidates
of the reference scalar solver (`three_parallel`, itself the twin of the vectorised one), and one
`ik_all` call the solutions of `ik_all_batch`, also with whole-turn equivalents (limits ±2π).
"""

from __future__ import annotations

import math

import closed_form_reference
import numpy as np
import pytest
from kin_testing import (
    assert_same_batched_solve,
    erd_path,
    moved_base,
    random_q,
    reversed_arm,
    wrapped_gap,
)

from kinematics_node.core import SerialChain, se3
from kinematics_node.core.ik.closed_form import api, chain_solver, detection, solution_set
from kinematics_node.core.ik.closed_form import geometry as scalar
from kinematics_node.sim.robots import load_robot

FK_TOL = 1e-9


def ur5(limited: bool) -> SerialChain:
    name = "ur5_joint_limited_robot.urdf" if limited else "ur5_robot.urdf"
    return SerialChain.from_urdf(erd_path(f"ur_description/urdf/{name}"), None, "tool0")


def mixed_limits(chain: SerialChain) -> SerialChain:
    """The arm with limits of mixed widths: ±2π, a narrow range (many solutions have no angle
    within it), 3π off-centre (one or two equivalents), a turn exactly."""
    lower = np.array([-2 * np.pi, -1.0, 0.0, -2 * np.pi, -np.pi, -2 * np.pi])
    upper = np.array([2 * np.pi, 2.0, 3 * np.pi, 2 * np.pi, np.pi, 2 * np.pi])
    return SerialChain.from_poe(np.asarray(chain.S), np.asarray(chain.M), lower=lower, upper=upper)


def narrow_limits(chain: SerialChain) -> SerialChain:
    """Limits within a turn, two of them narrow: no angle has a second equivalent, and many
    solutions have none within the limits."""
    lower = np.array([-np.pi, -1.0, -np.pi, -2.0, -np.pi, -np.pi])
    upper = np.array([np.pi, 2.0, np.pi, 0.5, np.pi, np.pi])
    return SerialChain.from_poe(np.asarray(chain.S), np.asarray(chain.M), lower=lower, upper=upper)


ARMS = {
    "ur5-limited": lambda: ur5(True),
    "ur5": lambda: ur5(False),
    "ur5e": lambda: load_robot("ur5e"),
    "ur5 on a moved base": lambda: moved_base(ur5(True)),
    "ur5 reversed": lambda: reversed_arm(ur5(True)),
    "ur5 mixed limits": lambda: mixed_limits(ur5(True)),
    "ur5 narrow limits": lambda: narrow_limits(ur5(True)),
}


@pytest.mark.parametrize("arm", list(ARMS))
def test_prepared_three_parallel_solver_equals_the_reference(arm):
    chain = ARMS[arm]()
    solver = detection.solver_of(chain)
    assert solver is not None and solver.structure.kind == "three_parallel"
    assert solver.three_parallel is not None
    g = solver.scalar_geometry
    rng = np.random.default_rng(5)
    q = random_q(chain, rng, 400)
    # Exactly singular rows: wrist aligned (q₅ = 0), elbow straight (q₃ = 0), both.
    q[:40, 4] = 0.0
    q[40:80, 2] = 0.0
    q[80:100, [2, 4]] = 0.0
    T = chain.fk(q)
    stage_names = chain_solver._STAGE_ORDER["three_parallel"]
    regular_gap = singular_gap = 0.0
    for i in range(len(q)):
        G = T[i] @ solver.M_inv
        if solver.structure.reversed:
            G = se3.inverse(G)
        R = tuple(tuple(row) for row in G[:3, :3].tolist())
        p = tuple(G[:3, 3].tolist())
        d = rng.uniform(-4.0, 4.0, 6).tolist()  # defaults of free angles, beyond ±π too
        ref_stages, fast_stages = scalar.Stages(stage_names), scalar.Stages(stage_names)
        ref = closed_form_reference.three_parallel(g, R, p, d, ref_stages)
        fast = solver.three_parallel.solve(R, p, d, fast_stages)
        assert fast_stages.passed == ref_stages.passed
        assert len(fast) == len(ref)
        for (qr, why_r), (qf, why_f) in zip(ref, fast, strict=True):
            assert why_f == why_r
            assert all(-math.pi < x <= math.pi for x in qf)
            gap = wrapped_gap(qr, qf)
            if i < 100:
                singular_gap = max(singular_gap, gap)
            else:
                regular_gap = max(regular_gap, gap)
    assert regular_gap <= 1e-9
    # At the singular rows the subproblems meet at a tangent (a square root of round-off):
    # regrouped products differ there by ~√ε; the FK check and refinement restore precision.
    assert singular_gap <= 1e-6


@pytest.mark.parametrize(
    "arm",
    ["ur5", "ur5e", "ur5 on a moved base", "ur5 reversed", "ur5 mixed limits", "ur5 narrow limits"],
)
def test_single_call_equals_batch_with_whole_turn_equivalents(arm):
    chain = ARMS[arm]()
    rng = np.random.default_rng(6)
    q = random_q(chain, rng, 40)
    seeds = random_q(chain, rng, 40)
    T = chain.fk(q)
    batch = chain.ik_all_batch(T, seeds)
    for i in range(len(q)):
        res = chain.ik_all(T[i], seeds[i])
        sols = np.array(res.solutions)
        assert res.success and sols.shape == batch.solutions_of(i).shape
        np.testing.assert_allclose(sols, batch.solutions_of(i), atol=1e-9)
        assert np.abs(sols - q[i]).max(axis=1).min() < 1e-9  # q itself is among them
        assert chain.within_limits(sols).all()
        err = np.abs(chain.fk(sols) - T[i]).max()
        assert err <= FK_TOL
        d = np.linalg.norm(sols - seeds[i], axis=1)
        assert np.all(np.diff(d) >= -1e-12)
        assert res.position_error <= FK_TOL and res.orientation_error <= FK_TOL


@pytest.mark.parametrize("arm", ["ur5-limited", "ur5 on a moved base", "ur5 reversed"])
def test_prepared_vectorised_three_parallel_solver_equals_the_reference(arm):
    """`solve_three_parallel_prepared` (ik_all_batch) against `solve_three_parallel`: same
    branches, same flags and reasons, angles equal to round-off (√ε at exact tangents)."""
    from kinematics_node.core.ik.closed_form import geometry as vector
    from kinematics_node.core.ik.closed_form import three_parallel as vector_tp

    chain = ARMS[arm]()
    solver = detection.solver_of(chain)
    rng = np.random.default_rng(12)
    q = random_q(chain, rng, 600)
    q[:60, 4] = 0.0
    q[60:120, 2] = 0.0
    q[120:150, [2, 4]] = 0.0
    T = chain.fk(q)
    T[150:200, :3, 3] *= 3.0  # out of reach: branches fail at some stage
    G = T @ solver.M_inv
    if solver.structure.reversed:
        G = np.stack([se3.inverse(x) for x in G])
    dflt = rng.uniform(-4.0, 4.0, (len(q), 6))
    ref_trace, fast_trace = vector.Trace(), vector.Trace()
    Q_ref, ok_ref = vector_tp.solve_three_parallel(
        solver.geometry, G[:, :3, :3], G[:, :3, 3], dflt, ref_trace
    )
    Q_fast, ok_fast = vector_tp.solve_three_parallel_prepared(
        solver.three_parallel, G[:, :3, :3], G[:, :3, 3], dflt, fast_trace
    )
    assert not ok_ref[150:200].all()
    assert_same_batched_solve((Q_ref, ok_ref, ref_trace), (Q_fast, ok_fast, fast_trace), 150)


def test_order_within_targets_equals_lexsort():
    """The batch's per-target sort is `np.lexsort((dist, owner))`, ties (equal distances, e.g.
    ±π twins) in row order, for targets with no rows, one row or many."""
    rng = np.random.default_rng(13)
    N, n = 300, 6
    count = rng.choice([0, 1, 3, 8, 40], size=N).astype(np.int64)
    offsets = np.zeros(N + 1, dtype=np.int64)
    np.cumsum(count, out=offsets[1:])
    owner = np.repeat(np.arange(N), count)
    Q = rng.choice([-np.pi, -1.0, 0.0, 0.5, np.pi], size=(owner.size, n))  # many ties
    seeds = rng.uniform(-1.0, 1.0, (N, n))
    seeds[::3] = 0.0
    order = solution_set.order_within_targets(Q, owner, seeds, count, offsets)
    D = Q - seeds[owner]
    expected = np.lexsort((np.einsum("ij,ij->i", D, D), owner))
    np.testing.assert_array_equal(order, expected)


def test_rank_array_equals_rank_candidates():
    """`rank_array` (a general 6R arm's roots, as an array) gives `rank_candidates`' equivalents,
    distances and order: limits finite, unbounded, wider than a turn and narrow, angles anywhere
    (the solver's θ₃ is not wrapped), weights uneven; candidates without an equivalent left out."""
    rng = np.random.default_rng(31)
    base = ur5(True)
    lower = np.array([-2 * np.pi, -1.0, -np.inf, -2.0, -np.pi, -3.0])
    upper = np.array([2 * np.pi, 2.0, np.inf, 0.5, np.pi, 7.0])
    for lo, hi in ((lower, upper), (np.full(6, -np.pi), np.full(6, np.pi))):
        chain = SerialChain.from_poe(np.asarray(base.S), np.asarray(base.M), lower=lo, upper=hi)
        limits = solution_set.JointLimits(chain)
        dropped = 0
        for _ in range(200):
            Q = rng.uniform(-2.5 * np.pi, 2.5 * np.pi, (int(rng.integers(0, 17)), 6))
            seed = rng.uniform(np.maximum(lo, -3.0), np.minimum(hi, 3.0)).tolist()
            w = rng.uniform(0.2, 3.0, 6).tolist()
            got = solution_set.rank_array(Q, seed, limits, w)
            want = solution_set.rank_candidates(
                [(q, ()) for q in scalar.wrap_angles(Q).tolist()], seed, limits, w
            )
            assert len(got) == len(want)
            dropped += Q.shape[0] - len(got)
            for (dg, qg), (dw, qw) in zip(got, want, strict=True):
                assert dg == pytest.approx(dw, abs=1e-9)
                np.testing.assert_allclose(qg, qw, atol=1e-9)
        assert dropped > 0 or lo[0] == -np.pi  # the narrow limits leave some out


def test_the_written_out_rigid_check_agrees_with_numpy():
    """`rigid_on_floats` (written out on floats) against the same criteria in NumPy: finite, last
    row (0, 0, 0, 1) within the row tolerance, |RᵀR − I| within the rotation tolerance, det R > 0;
    and `_exact_transform` (tolerances 1e-13 and 0) accepts exactly those transforms."""
    from kinematics_node.core._checks import rigid_on_floats

    def numpy_rigid(A: np.ndarray, rot_tol: float, row_tol: float) -> bool:
        if not np.isfinite(A).all():
            return False
        if np.abs(A[3] - (0.0, 0.0, 0.0, 1.0)).max() > row_tol:
            return False
        R = A[:3, :3]
        return bool(np.abs(R.T @ R - np.eye(3)).max() <= rot_tol and np.linalg.det(R) > 0)

    rng = np.random.default_rng(14)
    chain = ur5(True)
    for T in chain.fk(random_q(chain, rng, 200)):
        for bad in (None, "rot", "row", "nan", "inf", "mirror", "scaled"):
            A = T.copy()
            if bad == "rot":
                A[rng.integers(3), rng.integers(3)] += 10.0 ** rng.uniform(-15, -5)
            elif bad == "row":
                A[3, rng.integers(4)] += 10.0 ** rng.uniform(-12, -6)
            elif bad == "nan":
                A[rng.integers(4), rng.integers(4)] = np.nan
            elif bad == "inf":
                A[rng.integers(3), 3] = -np.inf
            elif bad == "mirror":
                A[:3, 0] *= -1.0
            elif bad == "scaled":
                A[:3, :3] *= 1.0 + 10.0 ** rng.uniform(-9, -5)
            for rot_tol, row_tol in ((1e-6, 1e-9), (1e-13, 0.0)):
                got = rigid_on_floats(A.tolist(), rot_tol, row_tol)
                want = numpy_rigid(A, rot_tol, row_tol)
                # (the two may round |RᵀR − I| differently right at the tolerance)
                near = (
                    np.isfinite(A).all()
                    and abs(np.abs(A[:3, :3].T @ A[:3, :3] - np.eye(3)).max() - rot_tol) < 1e-15
                )
                assert got == want or near, (bad, rot_tol)
            assert (api._exact_transform(A) is not None) == rigid_on_floats(A.tolist(), 1e-13, 0.0)


@pytest.mark.parametrize(
    "arm",
    ["ur5", "ur5-limited", "ur5 narrow limits", "ur5 mixed limits", "general 6R", "offset Puma"],
)
def test_ik_closed_form_is_the_weighted_nearest_member_of_the_set(arm):
    """`ik` ranks the candidates by their nearest whole-turn equivalent (with or without a test of
    the limits per angle): its answer is the member of `ik_all` with the least weighted distance.
    On general 6R arms `ik` ranks unpolished roots and refines only the one it takes."""
    from core.test_closed_form_general import ARMS as GENERAL
    from core.test_closed_form_general import dh_chain

    from kinematics_node.core import IKOptions

    if arm == "general 6R":
        chain = dh_chain(GENERAL["random 3"])
    elif arm == "offset Puma":
        chain = dh_chain(GENERAL["offset Puma"])
    else:
        chain = ARMS[arm]()
    rng = np.random.default_rng(15)
    w = (3.0, 1.0, 0.5, 1.0, 2.0, 1.0)
    opts = IKOptions(method="closed_form", joint_weights=w)
    for q, seed in zip(random_q(chain, rng, 40), random_q(chain, rng, 40), strict=True):
        T = chain.fk(q)
        res = chain.ik(T, seed, opts)
        every = np.array(chain.ik_all(T, seed).solutions)
        cost = ((every - seed) ** 2 * np.array(w)).sum(axis=1)
        assert res.success
        assert float(((res.q - seed) ** 2 * np.array(w)).sum()) == pytest.approx(
            cost.min(), abs=1e-9
        )
        assert np.abs(chain.fk(res.q) - T).max() <= FK_TOL


def test_check_seed_on_floats_equals_the_array_rules():
    """The float fast path of `check_seed` returns what clamping returns, and anything it does not
    accept (outside the limits, NaN, inf, other dtypes or shapes) takes the array rules."""
    from kinematics_node.core import InvalidInputError
    from kinematics_node.core.ik.result import check_seed

    chain = ARMS["ur5 narrow limits"]()
    rng = np.random.default_rng(16)
    for s in [
        *random_q(chain, rng, 20),
        rng.uniform(-4, 4, 6),
        chain.lower.copy(),
        chain.upper.copy(),
    ]:
        got = check_seed(chain, s, "q_seed", None)
        np.testing.assert_array_equal(got, np.clip(s, chain.lower, chain.upper))
        assert got is not s
    np.testing.assert_array_equal(
        check_seed(chain, [0, 0, 0, 0, 0, 0], "q_seed", None), np.zeros(6)
    )
    for bad in (np.full(6, np.nan), np.array([0, 0, np.inf, 0, 0, 0.0]), np.zeros(5)):
        with pytest.raises(InvalidInputError):
            check_seed(chain, bad, "q_seed", None)


# The Puma 560 (standard DH) with its wrist axes 5 and 6 apart by 1e-10 m: in the spherical-wrist
# family only to rounding, as rtbdata's URDF of it is (axes meeting to ~1e-10).
PUMA_ROUNDED = [
    (0.0, math.pi / 2, 0.0),
    (0.4318, 0.0, 0.0),
    (0.0203, -math.pi / 2, 0.15005),
    (0.0, math.pi / 2, 0.4318),
    (1e-10, -math.pi / 2, 0.0),
    (0.0, 0.0, 0.0),
]


def _dh(rows) -> SerialChain:
    return SerialChain.from_dh(
        [
            {"a": a, "alpha": al, "d": d, "theta": 0.0, "type": "R", "lower": -math.pi,
             "upper": math.pi}
            for a, al, d in rows
        ]
    )  # fmt: skip


def test_an_arm_in_its_family_only_to_rounding_keeps_candidates_within_its_defect():
    rounded = _dh(PUMA_ROUNDED)
    exact = _dh([(0.0 if k == 4 else a, al, d) for k, (a, al, d) in enumerate(PUMA_ROUNDED)])
    assert rounded.ik_family == exact.ik_family == "spherical_wrist"
    s_rounded, s_exact = detection.solver_of(rounded), detection.solver_of(exact)
    assert s_exact.defect < 1e-13
    assert 1e-11 < s_rounded.defect < 1e-9  # the candidates miss by about the geometry's error
    # the floor: round-off on an exact arm, whatever the tolerance; twice the defect on the
    # rounded one, up to half the tolerance
    floor = s_exact.refine_floor(1e-9)
    assert floor == s_exact.refine_floor(1e-6) and floor <= 1e-11
    assert s_rounded.refine_floor(1e-9) == min(2.0 * s_rounded.defect, 0.5e-9)
    assert s_rounded.refine_floor(1e-12) == floor
    rng = np.random.default_rng(3)
    q = rng.uniform(-math.pi, math.pi, size=(60, 6))
    worst_default = worst_tight = 0.0
    for qi in q:
        T = rounded.fk(qi)
        for tol in (1e-9, 1e-12):
            sols = np.asarray(rounded.ik_all(T, tolerance=tol).solutions)
            assert min(wrapped_gap(s, qi) for s in sols) <= 1e-6
            errs = [max(chain_solver.fk_errors(s_rounded, s.tolist(), T.tolist())) for s in sols]
            if tol == 1e-9:
                worst_default = max(worst_default, max(errs))
            else:
                worst_tight = max(worst_tight, max(errs))
    # unrefined at the default tolerance (off by the defect), refined when the tolerance asks
    assert 1e-12 < worst_default <= 0.5e-9
    assert worst_tight <= 1e-12
    # the batched path applies the same floor
    T = rounded.fk(q)
    for tol, lo, hi in ((1e-9, 1e-12, 0.5e-9), (1e-12, 0.0, 1e-12)):
        out = rounded.ik_all_batch(T, tolerance=tol)
        for i, qi in enumerate(q):
            assert min(wrapped_gap(s, qi) for s in out.solutions_of(i)) <= 1e-6
        owner = np.repeat(np.arange(len(q)), out.count)
        errs = [
            max(chain_solver.fk_errors(s_rounded, s.tolist(), T[k].tolist()))
            for s, k in zip(out.solutions, owner, strict=True)
        ]
        assert lo < max(errs) <= hi


@pytest.mark.parametrize("arm", ["ur5", "puma_rounded"])
def test_stacked_refinement_equals_one_candidate_at_a_time(arm):
    chain = ur5(False) if arm == "ur5" else _dh(PUMA_ROUNDED)
    solver = detection.solver_of(chain)
    rng = np.random.default_rng(11)
    T = chain.fk(random_q(chain, rng)).tolist()
    cands, _ = chain_solver.scalar_candidates(solver, T, solver.default_seed_list, None)
    start = [[x + 1e-4 * rng.standard_normal() for x in c] for c, _ in cands]
    steps = [1 + k % 2 for k in range(len(start))]
    many = chain_solver.refine_many(solver, start, T, steps)
    for s, n, m in zip(start, steps, many, strict=True):
        one = chain_solver.refine_one(solver, s, T, n)
        assert np.abs(np.subtract(one, m)).max() <= 1e-12
        if n == 2:  # from 1e-4 off, two steps reach round-off
            assert max(chain_solver.fk_errors(solver, m, T)) <= 1e-11
