"""The prepared spherical-wrist solver (`closed_form.spherical_wrist.Spherical`) against the general scalar
one (`spherical`, itself the twin of the vectorised one): same branches, stages, flags and
reasons, angles equal to round-off; on 6R arms of every position case, read from the base or the
tip, on a moved base, and on 7R arms with the held joint at several values (the per-value cache
of `_Solver.held_prepared` against the NumPy route of `held_geometry`).
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
from kinematics_node.core.ik.closed_form import chain_solver, detection, held
from kinematics_node.core.ik.closed_form import geometry as scalar
from kinematics_node.sim.robots import load_robot

PI = np.pi


def dh_arm(rows):
    return SerialChain.from_dh(
        [
            {"a": a, "alpha": al, "d": d, "theta": th, "type": "R", "lower": -PI, "upper": PI}
            for a, al, d, th in rows
        ]
    )


# (a, alpha, d, theta) rows: Puma 560 (1 ∩ 2, 2 ∥ 3), a KUKA-like OPW arm (2 ∥ 3), axes 2 ∩ 3,
# axes 1 ∥ 2; all with a spherical wrist.
PUMA = [(0.0, PI / 2, 0.0, 0.0), (0.4318, 0.0, 0.0, 0.0), (0.0203, -PI / 2, 0.15005, 0.0),
        (0.0, PI / 2, 0.4318, 0.0), (0.0, -PI / 2, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0)]  # fmt: skip
KUKA = [(0.35, -PI / 2, 0.815, 0.0), (0.85, 0.0, 0.0, -PI / 2), (0.145, -PI / 2, 0.0, 0.0),
        (0.0, PI / 2, 0.82, 0.0), (0.0, -PI / 2, 0.0, 0.0), (0.0, 0.0, 0.17, 0.0)]  # fmt: skip
MEET23 = [(0.3, PI / 2, 0.4, 0.0), (0.0, -PI / 2, 0.1, 0.0), (0.05, PI / 2, 0.0, 0.0),
          (0.0, -PI / 2, 0.4, 0.0), (0.0, PI / 2, 0.0, 0.0), (0.0, 0.0, 0.1, 0.0)]  # fmt: skip
PAR12 = [(0.4, 0.0, 0.3, 0.0), (0.3, PI / 2, 0.0, 0.0), (0.05, -PI / 2, 0.1, 0.0),
         (0.0, PI / 2, 0.4, 0.0), (0.0, -PI / 2, 0.0, 0.0), (0.0, 0.0, 0.1, 0.0)]  # fmt: skip


def kinova() -> SerialChain:
    path = erd_path("kinova_description/robots/kinova.urdf")
    return SerialChain.from_urdf(path, None, "j2s6s200_end_effector")


ARMS_6R = {
    "puma": lambda: dh_arm(PUMA),
    "kuka": lambda: dh_arm(KUKA),
    "meet23": lambda: dh_arm(MEET23),
    "par12": lambda: dh_arm(PAR12),
    "kuka reversed": lambda: reversed_arm(dh_arm(KUKA)),
    "kuka on a moved base": lambda: moved_base(dh_arm(KUKA)),
    "meet23 on a moved base": lambda: moved_base(dh_arm(MEET23)),
    "kinova": kinova,
}
ARMS_7R = {
    "panda": lambda: load_robot("panda"),
    "iiwa14": lambda: load_robot("iiwa14"),
    "panda on a moved base": lambda: moved_base(load_robot("panda")),
    "iiwa14 on a moved base": lambda: moved_base(load_robot("iiwa14")),
}


def targets(chain: SerialChain, rng: np.random.Generator, wrist: int) -> tuple[np.ndarray, int]:
    """FK of 300 random configurations: the first 60 with the wrist aligned (joint `wrist` at 0,
    exactly singular), rows 60-100 moved out of reach; and how many rows are singular."""
    q = random_q(chain, rng, 300)
    q[:60, wrist] = 0.0
    T = chain.fk(q)
    T[60:100, :3, 3] *= 4.0
    return T, 60


def compare(ref, ref_stages, fast, fast_stages, singular: bool) -> float:
    """Same stages, branches and reasons; the largest angle gap (wrapped)."""
    assert fast_stages.passed == ref_stages.passed
    assert len(fast) == len(ref)
    gap = 0.0
    for (qr, why_r), (qf, why_f) in zip(ref, fast, strict=True):
        assert why_f == why_r
        assert all(math.isfinite(x) for x in qf)
        gap = max(gap, wrapped_gap(qr, qf))
    return gap


@pytest.mark.parametrize("arm", list(ARMS_6R))
def test_prepared_spherical_solver_equals_the_general_one_6r(arm):
    chain = ARMS_6R[arm]()
    solver = detection.solver_of(chain)
    assert solver is not None and solver.structure.kind == "spherical_wrist"
    assert solver.spherical is not None
    st, g = solver.structure, solver.scalar_geometry
    rng = np.random.default_rng(21)
    T, n_singular = targets(chain, rng, 1 if st.reversed else 4)
    names = chain_solver._STAGE_ORDER[st.case]
    regular_gap = singular_gap = 0.0
    n_empty = 0
    for i in range(len(T)):
        G = T[i] @ solver.M_inv
        if st.reversed:
            G = se3.inverse(G)
        R = tuple(tuple(row) for row in G[:3, :3].tolist())
        p = tuple(G[:3, 3].tolist())
        d = rng.uniform(-4.0, 4.0, 6).tolist()  # defaults of free angles, beyond ±π too
        ref_stages, fast_stages = scalar.Stages(names), scalar.Stages(names)
        ref = closed_form_reference.spherical(st.case, g, R, p, d, ref_stages)
        fast = solver.spherical.solve(R, p, d, fast_stages)
        gap = compare(ref, ref_stages, fast, fast_stages, i < n_singular)
        n_empty += not ref
        if i < n_singular:
            singular_gap = max(singular_gap, gap)
        else:
            regular_gap = max(regular_gap, gap)
    assert n_empty >= 30  # the targets out of reach
    assert regular_gap <= 1e-9
    # At exactly singular rows the subproblems meet at a tangent (a square root of round-off).
    assert singular_gap <= 1e-6


@pytest.mark.parametrize("arm", list(ARMS_7R))
def test_prepared_spherical_solver_equals_the_general_one_7r(arm):
    """`_scalar_candidates` with the held joint at θ (cached geometry, prepared solver, G on
    floats) against the general solver on the NumPy route's geometry and G = T M⁻¹ E⁻¹."""
    chain = ARMS_7R[arm]()
    solver = detection.solver_of(chain)
    assert solver is not None and solver.structure.kind == "spherical_wrist"
    assert solver.held is not None and solver.held_moves is not None
    st, j = solver.structure, solver.held
    rng = np.random.default_rng(22)
    wrist = {True: 1, False: 5}[st.reversed]  # the 7R joint whose 0 aligns the wrist
    T, n_singular = targets(chain, rng, wrist)
    names = chain_solver._STAGE_ORDER[st.case]
    seeds = random_q(chain, rng, len(T))
    regular_gap = singular_gap = 0.0
    for i in range(len(T)):
        seed = seeds[i].tolist()
        for theta in (seed[j], float(chain.lower[j]) + 0.3, 0.7, seed[j]):  # (last: cached)
            gv, E = solver.held_geometry(np.array([theta]))
            g_ref = scalar.scalar_lane(gv, 0)
            G = T[i] @ solver.M_inv @ scalar.inverse_transforms(E)[0]
            d = [seed[k] for k in solver.keep]
            if st.reversed:
                G = se3.inverse(G)
                d = [-x for x in reversed(d)]
            R = tuple(tuple(row) for row in G[:3, :3].tolist())
            p = tuple(G[:3, 3].tolist())
            ref_stages = scalar.Stages(names)
            ref = chain_solver._candidates_rp(solver, g_ref, None, R, p, d, theta)[0]
            ref_raw = closed_form_reference.spherical(st.case, g_ref, R, p, d, ref_stages)
            assert len(ref) == len(ref_raw)
            fast, fast_stages = chain_solver.scalar_candidates(solver, T[i].tolist(), seed, theta)
            gap = compare(ref, ref_stages, fast, fast_stages, i < n_singular)
            for q, _ in fast:
                assert q[j] == theta and all(-math.pi < x <= math.pi for x in q[:j] + q[j + 1 :])
            if i < n_singular:
                singular_gap = max(singular_gap, gap)
            else:
                regular_gap = max(regular_gap, gap)
    assert regular_gap <= 1e-9
    assert singular_gap <= 1e-6


@pytest.mark.parametrize("arm", list(ARMS_7R))
def test_held_values_on_floats_equal_held_order(arm):
    """`_held_order_one` (one seed, floats) gives `held_order`'s values, also for a held joint
    with a range wider than a turn and for a continuous one."""
    base = ARMS_7R[arm]()
    solver = detection.solver_of(base)
    j = solver.held
    rng = np.random.default_rng(23)
    for lo_j, hi_j in ((None, None), (-4.0, 4.0), (-np.inf, np.inf), (-0.5, 0.5)):
        lower, upper = base.lower.copy(), base.upper.copy()
        if lo_j is not None:
            lower[j], upper[j] = lo_j, hi_j
        chain = SerialChain.from_poe(
            np.asarray(base.S), np.asarray(base.M), lower=lower, upper=upper
        )
        s = detection.solver_of(chain)
        for seed in random_q(chain, rng, 30):
            for count in (1, 2, 4, 37):
                want = held.held_order(chain, seed[None], count)[0].tolist()
                assert held.held_order_one(s, float(seed[j]), count) == want


@pytest.mark.parametrize("arm", ["panda", "iiwa14", "kinova"])
def test_ik_answers_reproduce_the_target_and_are_in_the_set(arm):
    """End to end: `ik` answers within the limits, from the closed form reproducing the target to
    1e-9; `ik_all` of FK(q) contains q; targets out of reach fail with a reason."""
    from kinematics_node.core import IKOptions

    chain = kinova() if arm == "kinova" else load_robot(arm)
    # the family's detection (20-60 ms, once per chain) ahead, as docs/closed_form.md advises:
    # inside the first call it takes most of that call's 50 ms
    assert chain.ik_family is not None
    rng = np.random.default_rng(24)
    opts = IKOptions(position_tolerance=1e-5, orientation_tolerance=1e-5, timeout=0.05)
    n_closed = 0
    for q in random_q(chain, rng, 60):
        T = chain.fk(q)
        res = chain.ik(T, None, opts)
        assert res.success
        closed = "closed form" in res.message
        n_closed += closed
        assert chain.within_limits(res.q)
        # (a 7R target the closed form misses at its first held values goes to the numeric
        # search, which stops within the tolerances)
        assert res.position_error <= (1e-9 if closed else 1e-5)
        assert res.orientation_error <= (1e-9 if closed else 1e-5)
        if closed:
            assert np.abs(chain.fk(res.q) - T).max() <= 1e-9
        held = None if chain.dof == 6 else [q[detection.solver_of(chain).held]]
        every = np.array(chain.ik_all(T, q, held).solutions)
        assert np.abs(every - q).max(axis=1).min() < 1e-9
    assert n_closed >= 30
    far = chain.fk(random_q(chain, rng))
    far[:3, 3] *= 10.0
    res = chain.ik(far, None, opts)
    assert not res.success and "unreachable" in res.message


@pytest.mark.parametrize("arm", [*ARMS_6R, "panda", "panda on a moved base"])
def test_prepared_vectorised_spherical_wrist_equals_the_general_one(arm):
    """`solve_spherical` with the prepared wrist (`_wrist_prepared`, ik_batch / ik_all_batch)
    against the general one: same branches, flags and reasons, angles equal to round-off."""
    from kinematics_node.core.ik.closed_form import spherical_wrist as vector
    from kinematics_node.core.ik.closed_form.geometry import Trace

    chain = (ARMS_6R | ARMS_7R)[arm]()
    solver = detection.solver_of(chain)
    st = solver.structure
    rng = np.random.default_rng(25)
    wrist = (1 if st.reversed else 5) if solver.held is not None else (1 if st.reversed else 4)
    T, n_singular = targets(chain, rng, wrist)
    if solver.held is None:
        g, prep, G = solver.geometry, solver.spherical, T @ solver.M_inv
    else:
        assert solver._held_static  # Panda: the held joint is the last, nothing moves with it
        theta = rng.uniform(chain.lower[solver.held], chain.upper[solver.held], len(T))
        g, E = solver.held_lanes(theta)
        prep = solver._held_static_solver
        G = T @ solver.M_inv @ scalar.inverse_transforms(E)
    if st.reversed:
        G = np.stack([se3.inverse(x) for x in G])
    dflt = rng.uniform(-4.0, 4.0, (len(T), 6))
    ref_trace, fast_trace = Trace(), Trace()
    Q_ref, ok_ref = vector.solve_spherical(st.case, g, G[:, :3, :3], G[:, :3, 3], dflt, ref_trace)
    Q_fast, ok_fast = vector.solve_spherical(
        st.case, g, G[:, :3, :3], G[:, :3, 3], dflt, fast_trace, prep
    )
    assert (~ok_ref[60:100]).all(axis=1).sum() >= 20  # (most) out of reach
    assert_same_batched_solve((Q_ref, ok_ref, ref_trace), (Q_fast, ok_fast, fast_trace), n_singular)
