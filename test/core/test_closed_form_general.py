"""The general 6R closed form (issue 24): every solution of any 6R chain, and every 7R arm.

Oracles: forward kinematics (the configuration a target came from must be in its set, and every
solution must reproduce the target) and the numeric solver from many random seeds (an exhaustive
search finds no solution the set lacks). CI runs a few configurations per arm;
`benchmarks/general_6r_benchmark.py` runs 10,000 per arm (the "slow" check).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from kinematics_node.core import IKOptions, SerialChain
from kinematics_node.core.ik.closed_form import family_of, no_closed_form_reason
from kinematics_node.core.ik.closed_form.geometry import pose_errors

PI = np.pi


def dh_chain(rows, lower=-PI, upper=PI) -> SerialChain:
    """A revolute chain from standard DH rows (a, alpha, d) [m, rad, m], limits ±π."""
    return SerialChain.from_dh(
        [
            {"a": a, "alpha": al, "d": d, "theta": 0.0, "type": "R", "lower": lower, "upper": upper}
            for a, al, d in rows
        ]
    )


def random_rows(rng, n=6):
    return [(rng.uniform(0.0, 0.6), rng.uniform(-PI, PI), rng.uniform(-0.4, 0.4)) for _ in range(n)]


RANDOM_ARMS = {f"random {k}": random_rows(np.random.default_rng(100 + k)) for k in range(20)}
DEGENERATE_ARMS = {
    # every twist 90°, offsets only along the links: no two axes parallel or meeting
    "90° twists": [(0.3, PI / 2, 0.1), (0.4, -PI / 2, 0.2), (0.2, PI / 2, 0.15),
                   (0.25, -PI / 2, 0.1), (0.1, PI / 2, 0.2), (0.15, 0.0, 0.1)],
    # zero link lengths (a = 0: consecutive axes meet) and general twists, no spherical wrist
    "zero lengths": [(0.0, 0.7, 0.3), (0.4, -1.1, 0.0), (0.0, 0.9, 0.25),
                     (0.3, -0.6, 0.1), (0.0, 1.2, 0.2), (0.2, 0.0, 0.1)],
    # two parallel pairs (α = 0) with offsets that break every named family
    "parallel pairs": [(0.2, PI / 2, 0.3), (0.5, 0.0, 0.1), (0.3, PI / 2, 0.12),
                       (0.1, -PI / 2, 0.4), (0.25, 0.0, 0.05), (0.1, 0.8, 0.1)],
    # a Puma whose wrist is offset by 1 mm (in the spherical-wrist family only approximately)
    "offset Puma": [(0.0, PI / 2, 0.0), (0.4318, 0.0, 0.0), (0.0203, -PI / 2, 0.15005),
                    (0.0, PI / 2, 0.4318), (1e-3, -PI / 2, 0.0), (0.0, 0.0, 0.0)],
}  # fmt: skip
ARMS = {**RANDOM_ARMS, **DEGENERATE_ARMS}


def _contains(sols: np.ndarray, q: np.ndarray, tol: float) -> bool:
    if not len(sols):
        return False
    d = np.abs((np.asarray(sols) - q + PI) % (2 * PI) - PI).max(axis=1)
    return bool(d.min() <= tol)


@pytest.mark.parametrize("name", list(ARMS))
def test_every_6r_arm_gets_all_solutions_and_each_reproduces_its_target(name):
    chain = dh_chain(ARMS[name])
    assert chain.ik_family == "general_6r"
    rng = np.random.default_rng(7)
    q = rng.uniform(-PI, PI, size=(40, 6))
    T = chain.fk(q)
    out = chain.ik_all_batch(T)
    for i in range(len(q)):
        sols = out.solutions_of(i)
        assert _contains(sols, q[i], 1e-6), (name, i, q[i])
        ep, er = pose_errors(chain.fk(sols), np.broadcast_to(T[i], (len(sols), 4, 4)))
        assert ep.max() <= 1e-9 and er.max() <= 1e-9
        assert len(sols) <= 16
    # one target at a time gives the same sets (the single-target path)
    for i in range(5):
        single = np.asarray(chain.ik_all(T[i]).solutions)
        assert single.shape == out.solutions_of(i).shape
        for s in single:
            assert _contains(out.solutions_of(i), s, 1e-6)


@pytest.mark.parametrize("name", ["random 0", "random 3", "90° twists"])
def test_the_set_equals_what_an_exhaustive_numeric_search_finds(name):
    """The numeric solver (to 1e-10) from 150 random seeds finds no solution outside
    the closed-form set,
    and every solution of the set is found by it from some seed."""
    chain = dh_chain(ARMS[name])
    rng = np.random.default_rng(11)
    q = rng.uniform(-PI, PI, 6)
    T = chain.fk(q)
    closed = np.asarray(chain.ik_all(T).solutions)
    found: list[np.ndarray] = []
    opts = IKOptions(
        method="numeric", timeout=0.05, position_tolerance=1e-10, orientation_tolerance=1e-10
    )
    for seed in rng.uniform(-PI, PI, size=(150, 6)):
        res = chain.ik(T, q_seed=seed, options=opts)
        if res.success:
            qn = (res.q + PI) % (2 * PI) - PI
            if not any(np.abs(qn - f).max() <= 1e-6 for f in found):
                found.append(qn)
    assert found
    for f in found:
        assert _contains(closed, f, 1e-6), f
    for c in closed:
        assert _contains(np.array(found), c, 1e-6), c


def test_a_seven_r_arm_without_a_named_family_holds_a_joint_for_the_general_solver():
    rows = random_rows(np.random.default_rng(7), 7)
    chain = dh_chain(rows)
    info = family_of(chain)
    assert info is not None and info.name == "7r_general_6r" and info.held_joint is not None
    j = chain.joint_names.index(info.held_joint)
    rng = np.random.default_rng(3)
    q = rng.uniform(-PI, PI, size=(20, 7))
    T = chain.fk(q)
    out = chain.ik_all_batch(T, held=q[:, j : j + 1])
    for i in range(len(q)):
        assert _contains(out.solutions_of(i), q[i], 1e-6)
    only = IKOptions(method="closed_form")
    for i in range(5):
        res = chain.ik(T[i], options=only)
        assert res.success and "closed form" in res.message
        ep, er = pose_errors(chain.fk(res.q)[None], T[i][None])
        assert ep[0] <= 1e-9 and er[0] <= 1e-9


def test_auto_on_a_held_general_arm_searches_numerically_before_it_sweeps():
    """Each held value of a 7r_general_6r arm costs an eigenvalue problem, so "auto" must not
    spend its budget on closed-form tries before the numeric search (on Baxter that cut the
    success rate from 100 % to 92.6 % within 5 ms): where the search finds a solution, `ik` and
    `ik_batch` answer exactly as method "numeric" does; where the search is denied any restart
    and fails, the sweep still finds one."""
    chain = dh_chain(random_rows(np.random.default_rng(7), 7))
    assert chain.ik_family == "7r_general_6r"
    rng = np.random.default_rng(5)
    T = chain.fk(rng.uniform(-PI, PI, size=(48, 7)))
    auto = IKOptions(timeout=1.0, rng_seed=0)
    numeric = replace(auto, method="numeric")
    for i in range(8):
        a, b = chain.ik(T[i], options=auto), chain.ik(T[i], options=numeric)
        assert a.success and b.success
        np.testing.assert_array_equal(a.q, b.q)
        assert "closed form" not in a.message
    a, b = chain.ik_batch(T, options=auto), chain.ik_batch(T, options=numeric)
    assert a.success.all() and b.success.all()
    np.testing.assert_array_equal(a.q, b.q)
    # No restart: the descent from the seed fails on some target, which the sweep then solves.
    one = IKOptions(timeout=1.0, max_restarts=0)
    missed = [t for t in T if not chain.ik(t, options=replace(one, method="numeric")).success]
    assert missed
    res = chain.ik(missed[0], options=one)
    assert res.success and "closed form" in res.message


def test_a_held_general_arm_sweeps_its_held_joint_in_chunks_within_the_deadline(monkeypatch):
    """The sweep of a 7r_general_6r arm solves several held values at once (`nearest_batch`: a
    chunk costs nearly the same for 1 or 8 values on Baxter): its answer reproduces the target
    within the limits at one of the values of `held_order`; past the deadline only the first
    value is solved (as before the chunks), before it chunks of at most MAX_CHUNK until every
    value is tried."""
    import time

    from kinematics_node.core.ik.closed_form import api
    from kinematics_node.core.ik.closed_form.detection import solver_of
    from kinematics_node.core.ik.closed_form.held import held_order_one

    chain = dh_chain(random_rows(np.random.default_rng(7), 7))
    solver = solver_of(chain)
    j = solver.held
    rng = np.random.default_rng(11)
    q = rng.uniform(-PI, PI, size=(6, 7))
    w = np.ones(7)
    seed = np.zeros(7)
    values = held_order_one(solver, 0.0, 37)
    for T in chain.fk(q):
        got = api.nearest(chain, T, seed, 1, 1e-9, 1e-9, w, 1e-3, time.perf_counter() + 1.0, 37)
        assert got is not None and got.solutions
        (s,) = got.solutions
        ep, er = pose_errors(chain.fk(s)[None], T[None])
        assert ep[0] <= 1e-9 and er[0] <= 1e-9
        assert np.all(s >= chain.lower - 1e-12) and np.all(s <= chain.upper + 1e-12)
        assert min(abs(s[j] - v) for v in values) <= 1e-12
    chunks: list[int] = []
    real = api.nearest_batch

    def counted(*args, **kwargs):
        chunks.append(np.asarray(args[-1]).shape[1])
        return real(*args, **kwargs)

    monkeypatch.setattr(api, "nearest_batch", counted)
    far = np.eye(4)
    far[:3, 3] = 100.0  # out of reach: no value gives a solution
    for deadline, expected in ((time.perf_counter() - 1.0, 1), (np.inf, 37)):
        chunks.clear()
        got = api.nearest(chain, far, seed, 1, 1e-9, 1e-9, w, 1e-3, deadline, 37)
        assert got is not None and not got.solutions and f"at {expected} values" in got.reason
        assert sum(chunks) == expected and max(chunks) <= api.MAX_CHUNK


def test_unreachable_targets_give_an_empty_set_with_the_reason():
    chain = dh_chain(ARMS["random 1"])
    far = np.eye(4)
    far[:3, 3] = (10.0, 0.0, 0.0)
    res = chain.ik_all(far)
    assert len(res.solutions) == 0 and "unreachable" in res.message


def test_mimic_and_five_joint_chains_still_have_no_closed_form():
    five = dh_chain(ARMS["random 2"][:5])
    assert five.ik_family is None


@pytest.mark.parametrize("name", ["random 3", "90° twists", "parallel pairs"])
def test_the_fitted_right_hand_side_and_the_deflated_eigenproblem_are_exact(name):
    """Two shortcuts of the general solver, against their definitions: the right-hand side from
    the fitted map K equals the one evaluated from the 14 equations, and the 16 eigenvalues of
    the deflated companion matrix are those of the full 24 × 24 one less the spurious ±i."""
    from kinematics_node.core.ik.closed_form import general_6r as g6
    from kinematics_node.core.ik.closed_form.detection import solver_of

    chain = dh_chain(ARMS[name])
    geometry = solver_of(chain).geometry
    arm = g6.Arm(geometry.w, geometry.r, 1.3)
    rng = np.random.default_rng(4)
    T = chain.fk(rng.uniform(-PI, PI, size=(5, 6)))
    R, t = T[:, :3, :3], T[:, :3, 3]
    Q, q0, _ = arm.target_side(R, t)
    direct = g6.Arm(geometry.w, geometry.r, 1.3, fit=False).target_side(R, t)
    np.testing.assert_allclose(Q, direct[0], atol=1e-12)
    np.testing.assert_allclose(q0, direct[1], atol=1e-12)
    F, A, good, _, _ = g6._companion(arm, arm.G[0], Q, q0, None)
    assert good.all()
    for Fi, Ai in zip(F, A, strict=True):
        C = np.zeros((3, 12, 12))  # Σ = C₀ + C₁x + C₂x², from its six equations on x₄ⁱ x₅ʲ
        for k in range(3):
            C[k, :6, :9] = C[k, 6:, 3:] = Fi[:, 9 * k : 9 * k + 9]
        D = np.linalg.solve(C[2], np.concatenate((C[0], C[1]), axis=1))
        M = np.block([[np.zeros((12, 12)), np.eye(12)], [-D[:, :12], -D[:, 12:]]])
        full, deflated = np.linalg.eigvals(M), np.linalg.eigvals(Ai)

        def spurious(lam):
            return np.abs(np.abs(lam.imag) - 1.0) + np.abs(lam.real) < 1e-6

        # (1 + x²)⁴ at least; parallel axes add more, which stay complex and are passed over
        assert spurious(full).sum() == spurious(deflated).sum() + 8
        np.testing.assert_allclose(
            np.sort_complex(deflated[~spurious(deflated)]),
            np.sort_complex(full[~spurious(full)]),
            atol=1e-7,
        )


# Manocha & Canny, "Efficient inverse kinematics for general 6R manipulators", IEEE Trans. Robotics
# and Automation 10(5):648-657, 1994, section V's example (problem 6 of Wampler & Morgan 1991, a
# variation of the arm of Manseur & Doty, "A robot manipulator with 16 real inverse kinematic
# solution sets", IJRR 8(5), 1989): Table I, standard DH rows (a, d, α [deg]) ...
MANOCHA_CANNY_DH = [(0.3, 0.0, 90.0), (1.0, 0.0, 1.0), (0.0, 0.2, 90.0),
                    (1.5, 0.0, 1.0), (0.0, 0.0, 90.0), (0.0, 0.0, 1.0)]  # fmt: skip
# ... the hand pose A_hand as printed (4 decimals; the scan we read lost the minus signs of
# entries (1, 2), (1, 4) and (3, 1), restored as the rotation and the solutions below require) ...
MANOCHA_CANNY_POSE = [[-0.7601, -0.6416, 0.1022, -1.1401], [0.1333, 0.0, 0.9910, 0.0],
                      [-0.6359, 0.7669, 0.0855, 0.0], [0.0, 0.0, 0.0, 1.0]]  # fmt: skip
# ... and Table III, its 16 real solutions (θ₁ … θ₆ [deg], to 0.01°).
MANOCHA_CANNY_SOLUTIONS = [
    (-96.28, -6.27, 179.96, 38.48, 52.55, -39.40), (-120.78, 172.33, -179.07, 31.33, -146.71, 142.82),
    (88.67, -176.72, -176.72, -63.24, 157.19, 140.43), (113.84, 5.30, -177.74, -55.92, -62.98, -43.37),
    (-178.12, 108.19, -147.73, -5.69, -164.67, 179.58), (168.32, -103.89, 146.60, -17.24, -171.87, 98.16),
    (-12.94, -105.09, -114.97, 3.02, 7.41, -79.42), (2.51, 108.07, 112.04, -10.52, 0.00, -0.10),
    (2.51, 108.07, -67.95, -169.47, 179.99, 179.89), (-12.94, -105.09, 65.02, 176.97, 172.58, 100.57),
    (168.32, -103.89, -33.39, -162.75, -8.12, -81.83), (-178.12, 108.19, 32.26, -174.30, -15.32, -0.41),
    (88.67, -176.72, 3.27, -116.75, 22.80, -39.56), (-96.28, -6.27, -0.03, 141.51, 127.44, 140.59),
    (-120.78, 172.33, 0.92, 148.66, -33.28, -37.17), (113.84, 5.30, 2.25, -124.07, -117.01, 136.62),
]  # fmt: skip


def test_the_published_arm_with_16_real_solutions_gets_all_16():
    """Manocha & Canny's example: `ik_all` returns 16 solutions, one near each published one (the
    pose is printed to 4 decimals and the solutions to 0.01°), each exact for the pose given."""
    chain = SerialChain.from_dh(
        [{"a": a, "alpha": np.radians(al), "d": d, "theta": 0.0} for a, d, al in MANOCHA_CANNY_DH]
    )
    published = np.radians(MANOCHA_CANNY_SOLUTIONS)
    T = np.array(MANOCHA_CANNY_POSE)
    # the table and the pose as read: every published solution reaches the printed pose
    assert np.abs(chain.fk(published) - T).max() < 1e-3
    U, _, Vt = np.linalg.svd(T[:3, :3])  # the printed rotation, onto SO(3)
    T[:3, :3] = U @ Vt
    for sols in (np.asarray(chain.ik_all(T).solutions), chain.ik_all_batch(T[None]).solutions):
        assert sols.shape == (16, 6)
        ep, er = pose_errors(chain.fk(sols), np.broadcast_to(T, (16, 4, 4)))
        assert ep.max() <= 1e-9 and er.max() <= 1e-9
        gap = np.abs((sols[:, None] - published[None] + PI) % (2 * PI) - PI).max(axis=2)
        nearest = gap.argmin(axis=1)
        assert sorted(nearest.tolist()) == list(range(16))  # one for each published solution
        assert np.degrees(gap.min(axis=1)).max() < 0.05


def test_a_joint_with_a_range_over_two_turns_gives_every_whole_turn_equivalent():
    """Limits of ±2.2π on joint 6 (up to three equivalents of an angle) and ±2π on joint 1: the
    set is every solution of the ±π arm moved by every whole turn that stays within the limits,
    in `ik_all` and in `ik_all_batch` alike."""
    rows = ARMS["random 0"]
    lower = np.array([-2 * PI, -PI, -PI, -PI, -PI, -2.2 * PI])
    wide = SerialChain.from_dh(
        [
            {"a": a, "alpha": al, "d": d, "theta": 0.0, "type": "R", "lower": lo, "upper": -lo}
            for (a, al, d), lo in zip(rows, lower, strict=True)
        ]
    )
    rng = np.random.default_rng(8)
    T = wide.fk(rng.uniform(-PI, PI, size=(6, 6)))
    batch = wide.ik_all_batch(T)
    for i, t in enumerate(T):
        base = np.asarray(dh_chain(rows).ik_all(t).solutions)
        expected = np.array(
            [
                s + 2 * PI * np.array([k1, 0, 0, 0, 0, k6])
                for s in base
                for k1 in (-1, 0, 1)
                for k6 in (-2, -1, 0, 1, 2)
                if abs(s[0] + 2 * PI * k1) <= 2 * PI and abs(s[5] + 2 * PI * k6) <= 2.2 * PI
            ]
        )
        got = np.asarray(wide.ik_all(t).solutions)
        for sols in (got, batch.solutions_of(i)):
            assert sols.shape == expected.shape
            gap = np.abs(sols[:, None] - expected[None]).max(axis=2)
            assert gap.min(axis=1).max() < 1e-9 and gap.min(axis=0).max() < 1e-9


def test_one_target_with_coinciding_roots_equals_the_stacked_solve(monkeypatch):
    """The one-lane solve handles roots that coincide (a shared null space, `_clusters`) itself:
    on the Puma with a 1 mm wrist offset, its loop read from joint 3, most targets have such a
    pair (read from joint 6, as detected, none). Its sets must equal the stacked (many-target)
    solve's, and the cluster path must have run."""
    from kinematics_node.core.ik.closed_form import general_6r, import_family

    chain = dh_chain(ARMS["offset Puma"])
    import_family(chain, ("general_6r", "2", False, None))
    rng = np.random.default_rng(21)
    q = rng.uniform(-PI, PI, size=(60, 6))
    T = chain.fk(q)
    batch = chain.ik_all_batch(T)
    calls: dict[str, int] = {"_clusters": 0, "_real_roots": 0}

    def counted(name):
        real = getattr(general_6r, name)

        def wrapper(*args):
            calls[name] += 1
            return real(*args)

        monkeypatch.setattr(general_6r, name, wrapper)

    counted("_clusters")
    counted("_real_roots")  # the stacked path, which one target no longer falls back to
    for i in range(len(q)):
        single = np.asarray(chain.ik_all(T[i]).solutions)
        assert _contains(single, q[i], 1e-6)
        expected = batch.solutions_of(i)
        assert single.shape == expected.shape, i
        for s in single:
            assert _contains(expected, s, 1e-7)
    assert calls["_clusters"] >= 10
    assert calls["_real_roots"] <= 3


@pytest.mark.parametrize("name", ["random 0", "90° twists", "parallel pairs"])
def test_one_target_by_qr_and_eigenvectors_equals_the_svd_and_the_stacked_solve(name, monkeypatch):
    """One target's elimination by QR (`_null_and_pinv`) gives the sets of the SVD it falls back
    to (forced here), and its null vectors from the deflated problem's eigenvectors
    (`_null_vectors`) give the stacked solve's roots (inverse iteration): unpolished to 1e-7 of
    the polished ones, which reproduce the target to 1e-9."""
    from kinematics_node.core.ik.closed_form import general_6r as g6
    from kinematics_node.core.ik.closed_form.detection import solver_of

    chain = dh_chain(ARMS[name])
    solver = solver_of(chain)
    assert not solver.structure.reversed
    arm = solver.general
    rng = np.random.default_rng(8)
    q = rng.uniform(-PI, PI, size=(30, 6))
    T = chain.fk(q) @ solver.M_inv  # G = T M⁻¹, what the solver's joints produce from home
    stacked, ok = g6.solve_general_6r(arm, T[:, :3, :3], T[:, :3, 3], g6.Trace())
    qr_calls = {"n": 0}
    real = g6.lapack.dtrcon

    def counted(*args):
        qr_calls["n"] += 1
        return real(*args)

    monkeypatch.setattr(g6.lapack, "dtrcon", counted)
    for i in range(len(q)):
        R, t = T[i, :3, :3].tolist(), T[i, :3, 3].tolist()
        polished = g6.solve_one_rows(arm, R, t)
        unpolished = g6.solve_one_rows(arm, R, t, polish=False)
        with monkeypatch.context() as m:
            m.setattr(g6, "_Q_RCOND", np.inf)
            by_svd = g6.solve_one_rows(arm, R, t)
        assert polished is not None and unpolished is not None and by_svd is not None
        expected = stacked[i][ok[i]]
        assert polished.shape == by_svd.shape == unpolished.shape == expected.shape, i
        for s in polished:
            assert _contains(by_svd, s, 1e-9) and _contains(expected, s, 1e-9)
            assert _contains(unpolished, s, 1e-7)
        assert _contains(polished, q[i], 1e-6)
    assert qr_calls["n"] >= 2 * len(q)  # the QR path ran (and the SVD's when forced)


def test_an_arm_built_per_target_on_a_shared_base_equals_one_built_whole():
    """The offset Puma's loop read from joint 3 (shift 2: the target moves the loop's last two
    joints) has its arm built per target; the joints the target does not move come from the arm
    prepared once (`shifted_base`). Built on it or whole, the arm has the same coefficients, and
    the solver the same solutions, which contain the configuration the target came from."""
    from kinematics_node.core.ik.closed_form import general_6r as g6
    from kinematics_node.core.ik.closed_form import import_family
    from kinematics_node.core.ik.closed_form.detection import solver_of

    chain = dh_chain(ARMS["offset Puma"])
    import_family(chain, ("general_6r", "2", False, None))
    solver = solver_of(chain)
    shift = int(solver.structure.case or 0)
    assert shift == 2 and solver.general_base is not None
    g = solver.geometry
    rev = solver.structure.reversed
    rng = np.random.default_rng(17)
    q = rng.uniform(-PI, PI, size=(20, 6))
    T = chain.fk(q) @ solver.M_inv
    if rev:
        T = np.linalg.inv(T)
    for i in range(len(q)):
        R, t = T[i : i + 1, :3, :3], T[i : i + 1, :3, 3]
        whole, ok_w = g6.solve_general_6r_shifted(g.w, g.r, None, R, t, g.scale, g6.Trace(), shift)
        based, ok_b = g6.solve_general_6r_shifted(
            g.w, g.r, solver.general_base, R, t, g.scale, g6.Trace(), shift
        )
        # the candidates that reproduce the target (the others, complex pairs taken for double
        # roots, are rejected by the FK check and may differ by rounding)
        target = chain.fk(q[i])
        a, b = (
            np.array([s for s in Q[0][ok[0]] if _reproduces(chain, s, rev, target)])
            for Q, ok in ((whole, ok_w), (based, ok_b))
        )
        assert a.shape == b.shape and len(a) >= 1, i
        for s in a:
            assert _contains(b, s, 1e-9)
        assert _contains(-a[:, ::-1] if rev else a, q[i], 1e-6)
    # the coefficients themselves, for one target's arm
    order = [*range(shift, 6), *range(shift)]
    w = g.w.copy()
    w[:, :shift] = w[:, :shift] @ T[0, :3, :3]
    r = g.r.copy()
    r[:, :shift] = (r[:, :shift] - T[0, :3, 3]) @ T[0, :3, :3]
    a1 = g6.Arm(w[:, order], r[:, order], g.scale, fit=False)
    a2 = g6.Arm(w[:, order], r[:, order], g.scale, fit=False, base=(solver.general_base, 6 - shift))
    for name in ("P", "Pf", "M12", "B12", "Bay", "Q2", "S", "PfBay"):
        np.testing.assert_allclose(getattr(a2, name), getattr(a1, name), atol=1e-12)
    assert a2.K is not None  # fitted once on the base: the target's right-hand side on floats


@pytest.mark.parametrize(
    ("name", "shift"), [("offset Puma", 5), ("offset Puma", 4), ("random 3", 5)]
)
def test_a_loop_with_the_moved_joints_first_equals_the_loop_read_as_given(name, shift):
    """Read from joint 5 or 6 (shift 4, 5), one target's loop is written in the frame moved by
    G, so that the joints the target moves come first (`MovedFirst`): the same equations
    moved by one rigid motion. Its solutions must be those of the stacked solve, which moves the
    other joints (each set checked by FK, not against each other alone), and contain the
    configuration, one target at a time and all at once; and the right-hand side that
    `MovedFirst` moves with the target must be that of the arm built whole from the moved axes,
    whose other coefficients are the prepared arm's."""
    from kinematics_node.core.ik.closed_form import general_6r as g6
    from kinematics_node.core.ik.closed_form import import_family
    from kinematics_node.core.ik.closed_form.detection import solver_of
    from kinematics_node.core.ik.closed_form.geometry import axis_lines

    chain = dh_chain(ARMS[name])
    M_inv = solver_of(chain).M_inv
    w, r = (x[None] for x in axis_lines(np.asarray(chain.S)))
    scale = solver_of(chain).scale
    base = g6.shifted_base(w, r, scale, shift)
    assert base.K is None  # joint 1 of the loop moves with the target: no fitted right-hand side
    moved_first = g6.MovedFirst(base, shift)
    rng = np.random.default_rng(5 + shift)
    q = rng.uniform(-PI, PI, size=(25, 6))
    G = chain.fk(q) @ M_inv
    for i in range(len(q)):
        R, t = G[i, :3, :3], G[i, :3, 3]
        one = moved_first.solve(R.tolist(), t.tolist())
        assert one is not None
        whole, ok = g6.solve_general_6r_shifted(
            w, r, None, R[None], t[None], scale, g6.Trace(), shift
        )
        target = chain.fk(q[i])
        # unrefined roots (the FK check refines them): a near-double root is found to √ε
        a, b = (
            np.array([s for s in Q if _reproduces(chain, s, False, target, 1e-7)])
            for Q in (one, whole[0][ok[0]])
        )
        assert a.shape == b.shape and len(a) >= 1, i
        for s in a:
            assert _contains(b, s, 1e-7)
        assert _contains(a, q[i], 1e-6)
    # every target at once (one arm, a pair of first joints per lane), through the chain's API
    # (roots checked and refined by FK): the same sets as one target at a time
    chain = dh_chain(ARMS[name])  # a new chain: detection has run on the first
    import_family(chain, ("general_6r", str(shift), False, None))
    batch = chain.ik_all_batch(chain.fk(q))
    for i in range(len(q)):
        single = np.asarray(chain.ik_all(chain.fk(q[i])).solutions)
        assert single.shape == batch.solutions_of(i).shape, i
        for s in single:
            assert _contains(batch.solutions_of(i), s, 1e-7)
        assert _contains(single, q[i], 1e-6)
    # the last target's right-hand side: that of the arm built whole from the moved axes
    order = [*range(shift, 6), *range(shift)]
    wl, rl = w[:, order].copy(), r[:, order].copy()
    moved = 6 - shift
    wl[:, :moved] = wl[:, :moved] @ R.T
    rl[:, :moved] = rl[:, :moved] @ R.T + t
    whole_arm = g6.Arm(wl, rl, scale, fit=False)
    Q, q0, u = whole_arm.target_side(R[None], t[None])
    for got, want in zip(
        moved_first.right_hand_side(R[None], t[None]), (Q, q0, whole_arm.B12[0] @ u[0]), strict=True
    ):
        np.testing.assert_allclose(got.reshape(want.shape), want, atol=1e-12)
    for name_ in ("P", "Pf", "Q2", "S", "PfBay"):  # joints 3-6: the prepared arm's
        np.testing.assert_allclose(getattr(base, name_), getattr(whole_arm, name_), atol=1e-12)


def _reproduces(
    chain: SerialChain, s: np.ndarray, reversed_: bool, target: np.ndarray, tol: float = 1e-9
) -> bool:
    """Whether the solver's candidate s (read from the tip if `reversed_`) reaches target."""
    ep, er = pose_errors(chain.fk(-s[::-1] if reversed_ else s)[None], target[None])
    return bool(ep[0] < tol and er[0] < tol)


def test_the_polishing_step_is_the_gauss_newton_step_and_skips_large_or_singular_ones():
    """`_polish_steps` solves J Jᵀ Δ = −J r by the adjugate: the step of a least-squares solve
    where it is small, none where it is large (a root far off) or J Jᵀ is singular."""
    from kinematics_node.core.ik.closed_form.general_6r import _POLISH_LIMIT, _polish_steps

    rng = np.random.default_rng(5)
    J = rng.standard_normal((16, 3, 6))
    res = rng.standard_normal((16, 6)) * 1e-3
    res[3] *= 1e4  # a root far from converging
    J[5, 2] = J[5, 0]  # rank 2: J Jᵀ singular
    J[6] = np.nan
    step = _polish_steps(J, res)
    for i in range(16):
        gn = np.linalg.lstsq(J[i].T, -res[i], rcond=None)[0] if i != 6 else np.full(3, np.nan)
        if i in (5, 6) or not np.abs(gn).max() < _POLISH_LIMIT:
            assert (step[i] == 0.0).all(), i
        else:
            np.testing.assert_allclose(step[i], gn, rtol=1e-10, atol=1e-15)
    assert (step[3] == 0.0).all() and np.isfinite(step).all()


#: A random 6R arm (two parallel pairs) and a configuration of it at σ_min/σ_max ≈ 2e-5, where
#: a second solution lies 5e-3 rad away (a near-double root).
NEAR_SINGULAR_ROWS = [
    (0.05, 0.0, -0.13496612447110573),
    (0.44892523877808777, 2.8868216425322206, 0.05662918212536755),
    (0.5201905578767068, -1.279139152565536, 0.0),
    (0.5543640045093989, 3.136834517503117, -0.3776934901353346),
    (0.05, 0.0, 0.14858209420381574),
    (0.2763644370772249, 0.5571552580781272, 0.16911395661330042),
]
NEAR_SINGULAR_Q = np.array([-0.2128045760309969, 2.8440004127266434, 1.8402907507046038,
                            2.5380307616416866, 3.1288345926129253, 1.6415885493197742])  # fmt: skip


def test_a_target_near_a_singularity_is_not_called_unreachable():
    """A random 6R arm (two parallel pairs) at a configuration with σ_min/σ_max ≈ 2e-5: its
    candidates were 1e-7 off, where Gauss–Newton converges neither quadratically nor
    monotonically, and two steps left every one above 1e-9, so `ik_all` said "unreachable".
    The refinement now goes on while a candidate is still off; `ik` finds it in closed form."""
    q = NEAR_SINGULAR_Q
    chain = dh_chain(NEAR_SINGULAR_ROWS)
    assert chain.ik_family == "general_6r"
    sv = np.linalg.svd(chain.jacobian(q, "space"), compute_uv=False)
    assert sv[-1] / sv[0] < 1e-4  # (the case: near a singularity)
    T = chain.fk(q)
    out = chain.ik_all(T)
    assert out.success and len(out.solutions) >= 1, out.message
    ep, er = pose_errors(
        chain.fk(np.array(out.solutions)), np.repeat(T[None], len(out.solutions), 0)
    )
    assert ep.max() <= 1e-9 and er.max() <= 1e-9
    opts = IKOptions(method="closed_form", position_tolerance=1e-9, orientation_tolerance=1e-9)
    res = chain.ik(T, options=opts)
    assert res.success, res.message


def test_both_members_of_a_near_double_root_come_back():
    """At that configuration two solutions 5e-3 rad apart (θ₃ within 1e-4) make a near-double
    root, which rounding turns into a complex pair half the time: the elimination then gives
    one candidate half-way, which refinement takes to one of the two. Its mirror image through
    the candidate (`REFLECT_ABOVE`) refines to the other, so `ik_all` and `ik_all_batch` give
    both, whichever way the rounding falls (targets moved by 1e-16 m; before the mirror images,
    one target at a time gave both for 20 of 40 such targets)."""
    q = NEAR_SINGULAR_Q
    chain = dh_chain(NEAR_SINGULAR_ROWS)
    T = np.repeat(chain.fk(q)[None], 12, axis=0)
    T[1:, :3, 3] += np.random.default_rng(3).normal(size=(11, 3)) * 1e-16
    batch = chain.ik_all_batch(T)
    for i, t in enumerate(T):
        for sols in (np.asarray(chain.ik_all(t).solutions), batch.solutions_of(i)):
            ep, er = pose_errors(chain.fk(sols), np.repeat(t[None], len(sols), 0))
            assert ep.max() <= 1e-9 and er.max() <= 1e-9
            assert _contains(sols, q, 1e-6), i
            twin = [s for s in sols if 1e-3 < np.abs(s - q).max() < 1e-2]
            assert len(twin) == 1, (i, sols)  # the other member, once


@pytest.mark.parametrize("twist", [0.0, PI])
def test_a_six_joint_arm_with_two_collinear_axes_has_no_closed_form_and_says_why(twist):
    """Joints 3 and 4 on one line (a = 0, α = 0 or π): a redundant arm whose every reachable
    pose has infinitely many solutions. Detection says so (it said the wrist axes miss a point),
    and the numeric search still solves it."""
    rows = [(0.3, PI / 2, 0.2), (0.4, 0.7, 0.1), (0.0, twist, 0.25),
            (0.35, -1.1, 0.1), (0.2, 0.9, 0.15), (0.1, 0.4, 0.1)]  # fmt: skip
    chain = dh_chain(rows)
    assert chain.ik_family is None
    reason = no_closed_form_reason(chain)
    assert "'joint3' and 'joint4'" in reason and "collinear" in reason, reason
    q = np.array([0.3, -0.5, 0.8, 0.4, -0.6, 1.1])
    res = chain.ik(chain.fk(q), options=IKOptions(method="numeric", rng_seed=1))
    assert res.success, res.message


def test_the_held_sweep_sizes_its_chunks_to_end_by_the_deadline(monkeypatch):
    """`_nearest_in_chunks` on a clock of its own, where a chunk of k values takes twice the cost
    estimate (a slower machine): the first chunk is as large as the estimate allows; from its
    measured cost the next is sized to end before the deadline, and the sweep stops when not one
    more value fits (it overran a 5 ms budget by up to 1.7 ms when a chunk's cost was taken as
    proportional to its size). The pace measured is kept for the next call."""
    from kinematics_node.core.ik.closed_form import api
    from kinematics_node.core.ik.closed_form.detection import solver_of
    from kinematics_node.core.ik.closed_form.held import held_order_one

    chain = dh_chain(random_rows(np.random.default_rng(7), 7))
    solver = solver_of(chain)
    now = [100.0]
    chunks: list[int] = []

    def cost(k: int) -> float:
        return 2.0 * (api.CHUNK_FIXED_COST + k * api.CHUNK_VALUE_COST)

    def slow(*args, **kwargs):
        k = np.asarray(args[-1]).shape[1]
        chunks.append(k)
        now[0] += cost(k)
        return api.NearestBatch(np.zeros((1, 7)), np.array([False]), np.ones(1), np.ones(1))

    monkeypatch.setattr(api, "nearest_batch", slow)
    monkeypatch.setattr(api.time, "perf_counter", lambda: now[0])
    monkeypatch.setattr(solver, "chunk_speed", 1.0)  # (no chunk measured before)
    far = np.eye(4)
    far[:3, 3] = 100.0
    budget = 8.0e-3
    values = held_order_one(solver, 0.0, 37)
    got = api._nearest_in_chunks(
        chain, solver, far, np.zeros(7), values, (1e-9, 1e-9), np.ones(7), now[0] + budget
    )
    assert not got.solutions and f"at {sum(chunks)} values" in got.reason
    assert chunks[0] == api.MAX_CHUNK
    left = budget - cost(chunks[0])  # sized at the pace just measured, twice the estimate
    assert chunks[1:] == [int((left / 2.0 - api.CHUNK_FIXED_COST) / api.CHUNK_VALUE_COST)]
    spent = now[0] - 100.0
    assert spent <= budget < spent + cost(1)  # within the budget; not one more value fitted
    # the pace kept for the next call: a running mean of the two chunks' (2x the estimate)
    assert solver.chunk_speed == pytest.approx(0.7 * (0.7 * 1.0 + 0.3 * 2.0) + 0.3 * 2.0)


def test_held_arms_kept_per_value_and_stacked_solve_as_arms_built_whole():
    """A 7r_general_6r arm keeps its held general arms per value (`held_general`) and stacks
    them for a chunk (`Arm.stack`), a lane taken alone by `Arm.lane`: every mix of values
    kept and built gives the solutions of an arm built whole for those values."""
    from kinematics_node.core.ik.closed_form.chain_solver import solve_branches
    from kinematics_node.core.ik.closed_form.detection import solver_of
    from kinematics_node.core.ik.closed_form.general_6r import Arm

    chain = dh_chain(random_rows(np.random.default_rng(7), 7))
    solver = solver_of(chain)
    assert chain.ik_family == "7r_general_6r"
    rng = np.random.default_rng(3)
    q = rng.uniform(-PI, PI, size=(4, 7))
    T = chain.fk(q)
    values = np.array([0.4, -1.1, 2.0, 0.9, -2.5])

    def fresh(held):
        g, _ = solver.held_lanes(held)
        return Arm(g.w, g.r, solver.scale, fit=False)

    solver._general_cache.clear()
    solver._stacked_cache.clear()
    solver.held_general(values[[3, 1]])  # two kept, built as one stack (then taken per lane)
    solver.held_general(values[[0]])  # one kept, built alone
    for held in (values, values[[1]], values[[2, 3]]):
        _, arm = solver.held_general(held)
        whole = fresh(held)
        for name in ("P", "Q2", "S", "K", "M12", "B12", "Bay"):
            a, b = getattr(arm, name), getattr(whole, name)
            if b is not None:
                np.testing.assert_allclose(a, b, atol=1e-12, err_msg=name)
        for i, t in enumerate(T):
            Q, ok, *_ = solve_branches(solver, t[None], q[i][None], held[None])
            assert ok.any()
            got = Q[ok]
            # each accepted branch reproduces the target at its lane's held value
            ep, er = pose_errors(chain.fk(got), np.repeat(t[None], len(got), 0))
            assert np.median(ep) < 1e-6 and np.median(er) < 1e-6
    assert set(solver._general_cache) == set(values.tolist())


def test_a_held_arm_whose_loop_is_read_shifted_keeps_its_arm_per_held_value():
    """A random 7R arm whose held 6R arm is read from joint 6 (`Structure.case` "5"): its held
    values' prepared arms are kept per value and stacked (`held_shifted`), every lane solved on
    its own value's arm. One target with its own held value among others gives that
    configuration back; a batch over shared values reproduces every target."""
    from kinematics_node.core.ik.closed_form.detection import solver_of

    rows = [
        (0.20381491162431287, -PI / 2, 0.16452968642577726),
        (0.04442216899891991, -1.9250859696185127, -0.09491131456609814),
        (0.46135378985587866, -1.5013356286702075, 0.17776644409069275),
        (0.05, 0.0, -0.37951388874121617),
        (0.07186764468028947, 0.0, -0.31315028947643886),
        (0.48568602554324136, PI, 0.0),
        (0.2840611054932753, 2.8622539345457794, 0.04758177001805963),
    ]
    chain = dh_chain(rows)
    solver = solver_of(chain)
    assert chain.ik_family == "7r_general_6r" and solver.structure.case == "5"
    j = solver.held
    rng = np.random.default_rng(4)
    q = rng.uniform(-PI, PI, size=(8, 7))
    T = chain.fk(q)
    for i in range(len(q)):
        held = np.array([q[i, j], 0.1, -2.0])
        for _ in range(2):  # built, then kept
            out = chain.ik_all(T[i], held=held)
            assert _contains(np.array(out.solutions), q[i], 1e-6)
            ep, er = pose_errors(chain.fk(np.array(out.solutions)), T[[i] * len(out.solutions)])
            assert ep.max() <= 1e-9 and er.max() <= 1e-9
    batch = chain.ik_all_batch(T, held=np.linspace(-2.5, 2.5, 6))
    assert batch.count.sum() > 0
    ep, er = pose_errors(chain.fk(batch.solutions), T[np.repeat(np.arange(len(T)), batch.count)])
    assert ep.max() <= 1e-9 and er.max() <= 1e-9
    assert {0.1, -2.0} <= set(solver._shifted_cache)


def test_held_arms_kept_per_value_survive_their_cache_filling_up(monkeypatch):
    """When the values kept per held value would exceed `GENERAL_CACHE_SIZE`, the cache is
    emptied and every value of the call built again: a call mixing kept values and new ones
    then found the kept ones gone (KeyError), as `ik` with a new seed each call would after
    ~250 calls."""
    from kinematics_node.core.ik.closed_form import chain_solver
    from kinematics_node.core.ik.closed_form.detection import solver_of
    from kinematics_node.core.ik.closed_form.general_6r import Arm

    chain = dh_chain(random_rows(np.random.default_rng(7), 7))
    solver = solver_of(chain)
    monkeypatch.setattr(chain_solver, "GENERAL_CACHE_SIZE", 3)
    solver._general_cache.clear()
    solver._stacked_cache.clear()
    solver.held_general(np.array([0.1, 0.2]))
    solver.held_general(np.array([0.3]))
    _, arm = solver.held_general(np.array([0.2, 0.4]))  # 0.2 kept, 0.4 new: 4 > 3
    assert arm.lanes == 2 and set(solver._general_cache) == {0.2, 0.4}
    g, _ = solver.held_lanes(np.array([0.2, 0.4]))
    whole = Arm(g.w, g.r, solver.scale, fit=False)
    np.testing.assert_allclose(arm.S, whole.S, atol=1e-12)
