"""`ik` and `ik_batch` with the closed form beside the numeric search (`IKOptions.method`).

Oracles: forward kinematics (every answer must reproduce its target), `ik_all` (the exhaustive
closed-form set: the answer of `ik` on a 6R arm must be its member nearest the seed), and the
numeric search on the same targets. Arms: example-robot-data's UR5 (three parallel axes, limits
±2π), a Puma 560 built from its DH table (spherical wrist), Panda (7R, joint 7 held) and the
bundled iiwa14 (7R, joint 3 held), and an arm with no closed form.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from kin_testing import erd_path, random_q, ur_hole_target

from kinematics_node.core import IKOptions, InvalidInputError, SerialChain
from kinematics_node.core.ik.closed_form import family_of
from kinematics_node.sim.robots import load_robot

TOL = 1e-9
_CHAINS: dict[str, SerialChain] = {}


def chain_of(name: str) -> SerialChain:
    if name not in _CHAINS:
        if name == "ur5":
            path = erd_path("ur_description/urdf/ur5_robot.urdf")
            _CHAINS[name] = SerialChain.from_urdf(path, tip_link="tool0")
        elif name == "panda":
            path = erd_path("panda_description/urdf/panda.urdf")
            _CHAINS[name] = SerialChain.from_urdf(path, tip_link="panda_hand")
        elif name == "puma":
            from core.test_closed_form import PUMA, dh_arm

            _CHAINS[name] = dh_arm(PUMA)
        else:
            _CHAINS[name] = load_robot(name)
    return _CHAINS[name]


def reproduces(chain: SerialChain, q: np.ndarray, T: np.ndarray, tol: float) -> bool:
    Tq = chain.fk(q)
    # rotation angle from ‖R_a − R_b‖_F = 2√2 sin(θ/2): accurate at small angles (acos is not)
    angle = 2.0 * math.asin(min(1.0, float(np.linalg.norm(Tq[:3, :3] - T[:3, :3])) / math.sqrt(8)))
    inside = bool(np.all(q >= chain.lower) and np.all(q <= chain.upper))
    return inside and float(np.linalg.norm(Tq[:3, 3] - T[:3, 3])) <= tol and angle <= tol


# ---------------------------------------------------------------------- 6R: the nearest of the set
@pytest.mark.parametrize("name", ["ur5", "puma"])
def test_6r_ik_is_the_member_of_the_closed_form_set_nearest_the_seed(name):
    chain = chain_of(name)
    rng = np.random.default_rng(5)
    Q = random_q(chain, rng, 200)
    seeds = random_q(chain, rng, 200)
    opts = IKOptions(position_tolerance=TOL, orientation_tolerance=TOL)
    for q, seed in zip(Q, seeds, strict=True):
        T = chain.fk(q)
        res = chain.ik(T, seed, opts)
        assert res.success and "closed form" in res.message, res.message
        assert res.iterations == 0 and reproduces(chain, res.q, T, TOL)
        every = chain.ik_all(T, q_seed=seed)
        nearest = every.solutions[0]
        d_res, d_best = np.linalg.norm(res.q - seed), np.linalg.norm(nearest - seed)
        assert d_res == pytest.approx(d_best, abs=1e-9), (res.q, nearest)


def test_6r_several_solutions_are_the_nearest_distinct_members_of_the_set():
    chain = chain_of("ur5")
    rng = np.random.default_rng(8)
    for q in random_q(chain, rng, 20):
        T = chain.fk(q)
        seed = random_q(chain, rng)
        res = chain.ik(T, seed, IKOptions(num_solutions=5, mode="distance"))
        assert res.success and len(res.solutions) == 5
        d = [float(np.linalg.norm(s - seed)) for s in res.solutions]
        assert d == sorted(d)
        every = chain.ik_all(T, q_seed=seed).solutions
        d_all = sorted(float(np.linalg.norm(s - seed)) for s in every)
        np.testing.assert_allclose(d, d_all[:5], atol=1e-9)  # the 5 nearest (distinct by ≥ 2π)
        for s in res.solutions:
            assert reproduces(chain, s, T, 1e-5)


def test_joint_weights_rank_the_closed_form_candidates():
    """With a heavy weight on joint 1 the nearest solution keeps joint 1 closest to the seed."""
    chain = chain_of("puma")  # limits ±π: at most 8 solutions per pose, in distinct branches
    rng = np.random.default_rng(9)
    for q in random_q(chain, rng, 20):
        T = chain.fk(q)
        seed = random_q(chain, rng)
        w = (100.0, 1.0, 1.0, 1.0, 1.0, 1.0)
        res = chain.ik(T, seed, IKOptions(joint_weights=w))
        every = chain.ik_all(T, q_seed=seed).solutions
        cost = [float(np.sum(np.array(w) * (s - seed) ** 2)) for s in every]
        assert float(np.sum(np.array(w) * (res.q - seed) ** 2)) == pytest.approx(min(cost))


# ---------------------------------------------------------------------- 7R
@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_7r_auto_solves_and_every_answer_reproduces_its_target(name):
    chain = chain_of(name)
    rng = np.random.default_rng(3)
    opts = IKOptions(position_tolerance=1e-9, orientation_tolerance=1e-9, timeout=0.05)
    solved = 0
    for q in random_q(chain, rng, 60):
        T = chain.fk(q)
        res = chain.ik(T, options=opts)
        assert res.success, res.message
        assert reproduces(chain, res.q, T, 1e-9)
        solved += "closed form" in res.message and "numeric" not in res.message
    assert solved > 0  # the held joint at the seed's value answers some targets


def test_7r_closed_form_sweeps_the_held_joint_when_the_seed_value_has_no_solution():
    """Targets whose held joint (Panda: joint 7) must sit far from the seed's value: holding it at
    the seed's value finds nothing (checked), the sweep finds a solution."""
    chain = chain_of("panda")
    j = family_of(chain).held_joint
    assert j == "panda_joint7"
    rng = np.random.default_rng(4)
    only = IKOptions(method="closed_form", position_tolerance=1e-9, orientation_tolerance=1e-9)
    swept = 0
    for q in random_q(chain, rng, 40):
        T = chain.fk(q)
        at_seed = chain.ik_all(T, held=[0.0])  # the default seed's joint 7 is 0
        res = chain.ik(T, options=only)
        if res.success:
            assert reproduces(chain, res.q, T, 1e-9)
            swept += not at_seed.solutions
        else:
            assert "held" in res.message and res.q is not None
    assert swept >= 3


# ---------------------------------------------------------------------- fallbacks and choices
def test_unreachable_6r_target_names_the_closed_form_reason_and_still_searches():
    chain = chain_of("ur5")
    T = ur_hole_target()  # within the reach sphere, unreachable
    opts = IKOptions(timeout=0.02)
    elapsed = []
    for _ in range(3):  # a busy machine may delay any one call; an overrun shows in every call
        t0 = time.perf_counter()
        res = chain.ik(T, options=opts)
        elapsed.append(time.perf_counter() - t0)
        assert not res.success and np.all(np.isfinite(res.q))
        assert (
            res.message.startswith("closed form: unreachable") and "numeric search" in res.message
        )
    # the search used its budget, and no more
    assert min(elapsed) >= 0.015 and min(elapsed) <= 0.02 + 0.01 and max(elapsed) < 0.5, elapsed


def test_method_closed_form_alone_answers_at_once_when_unreachable():
    chain = chain_of("ur5")
    T = np.eye(4)
    T[:3, 3] = (5.0, 0.0, 0.0)
    t0 = time.perf_counter()
    res = chain.ik(T, options=IKOptions(method="closed_form", timeout=1.0))
    assert time.perf_counter() - t0 < 0.1
    assert not res.success and "unreachable" in res.message and np.all(np.isfinite(res.q))


def test_method_numeric_does_not_use_the_closed_form():
    chain = chain_of("ur5")
    q = random_q(chain, np.random.default_rng(1))
    res = chain.ik(chain.fk(q), options=IKOptions(method="numeric"))
    assert res.success and res.iterations > 0 and "closed form" not in res.message


@pytest.mark.parametrize(
    ("options", "why"),
    [
        (IKOptions(position_only=True), "position_only"),
        (IKOptions(weights=(1, 1, 0, 1, 1, 1)), "freed pose component"),
        (IKOptions(axis_tolerances=(1e-4, 1e-4, math.inf, 1e-5, 1e-5, 1e-5)), "freed pose"),
        (IKOptions(num_solutions=3), "7R"),
    ],
)
def test_closed_form_refused_where_it_does_not_apply(options, why):
    from dataclasses import replace

    chain = chain_of("panda" if why == "7R" else "ur5")
    T = chain.fk(random_q(chain, np.random.default_rng(2)))
    with pytest.raises(InvalidInputError, match=f"method='closed_form' does not apply.*{why}"):
        chain.ik(T, options=replace(options, method="closed_form"))
    res = chain.ik(T, options=options)  # "auto" takes the numeric search instead
    assert res.success and "closed form" not in res.message


def test_arm_without_a_family_refuses_closed_form_and_auto_searches():
    """A 5R arm (the Puma without its last joint) has no closed form; "auto" searches."""
    from core.test_closed_form import PUMA, dh_arm

    chain = dh_arm(PUMA[:5])
    assert chain.ik_family is None
    T = chain.fk(random_q(chain, np.random.default_rng(2)))
    with pytest.raises(InvalidInputError, match="does not apply: it has 5 joints"):
        chain.ik(T, options=IKOptions(method="closed_form"))
    res = chain.ik(T, options=IKOptions(timeout=0.5))
    assert res.success and res.iterations > 0 and reproduces(chain, res.q, T, 1e-4)


def test_finite_axis_tolerances_use_the_closed_form_and_are_met():
    chain = chain_of("ur5")
    bounds = (1e-6, 2e-6, 3e-6, 1e-7, 2e-7, 3e-7)
    q = random_q(chain, np.random.default_rng(6))
    T = chain.fk(q)
    res = chain.ik(T, options=IKOptions(axis_tolerances=bounds))
    assert res.success and "closed form" in res.message
    assert reproduces(chain, res.q, T, 1e-7)


# ---------------------------------------------------------------------- batches
@pytest.mark.parametrize("name", ["ur5", "iiwa14"])
def test_vectorised_batch_uses_the_closed_form_and_matches_single_calls(name):
    chain = chain_of(name)
    rng = np.random.default_rng(12)
    Q = random_q(chain, rng, 64)  # ≥ SCALAR_BATCH_BELOW: the vectorised path
    T = chain.fk(Q)
    seeds = random_q(chain, rng, 64)
    opts = IKOptions(position_tolerance=1e-9, orientation_tolerance=1e-9, timeout=0.05)
    batch = chain.ik_batch(T, seeds, opts)
    assert batch.success.all(), batch.message
    assert "in closed form" in batch.message
    for k in range(len(T)):
        assert reproduces(chain, batch.q[k], T[k], 1e-9)
        if name == "ur5":  # exhaustive: the batch and a single call pick the same nearest member
            single = chain.ik(T[k], seeds[k], opts)
            d_b = np.linalg.norm(batch.q[k] - seeds[k])
            assert d_b == pytest.approx(np.linalg.norm(single.q - seeds[k]), abs=1e-9)


def test_batch_with_unreachable_targets_reports_them_unsolved_without_nan():
    chain = chain_of("ur5")
    rng = np.random.default_rng(13)
    T = chain.fk(random_q(chain, rng, 60))
    T[::3, 0, 3] += 5.0  # every third target out of reach
    res = chain.ik_batch(T, options=IKOptions(batch_timeout=0.5))
    assert np.all(np.isfinite(res.q))
    assert not res.success[::3].any()
    keep = np.ones(60, dtype=bool)
    keep[::3] = False
    assert res.success[keep].all()
    for k in np.flatnonzero(res.success):
        assert reproduces(chain, res.q[k], T[k], 1e-5)


# ---------------------------------------------------------------------- the family across processes
@pytest.mark.parametrize("name", ["ur5", "iiwa14"])
def test_an_exported_family_is_installed_on_a_copy_without_detecting_it(name, monkeypatch):
    """What the node's IK workers do: the family detected in the node travels with the pickled
    chain, and the worker's copy uses it (detection would take 20–100 ms inside a job)."""
    import pickle

    from kinematics_node.core.ik import closed_form

    chain = chain_of(name)
    exported = closed_form.export_family(chain)
    clone = pickle.loads(pickle.dumps(chain))

    def no_detection(_chain):
        raise AssertionError("detect() ran on the copy")

    monkeypatch.setattr(closed_form.detection, "detect", no_detection)
    closed_form.import_family(clone, exported)
    assert closed_form.family_of(clone) == closed_form.family_of(chain)
    T = chain.fk(random_q(chain, np.random.default_rng(21)))
    a, b = chain.ik(T), clone.ik(T)
    assert b.success and "closed form" in b.message
    np.testing.assert_array_equal(a.q, b.q)


def test_importing_a_family_that_does_not_fit_is_refused():
    from kinematics_node.core.ik import closed_form

    chain = chain_of("ur5")
    for bad in [("three_parallel", "", False, 3), ("nonsense", "", False, None), (1, 2)]:
        with pytest.raises(InvalidInputError, match="not an exported closed-form family"):
            closed_form.import_family(SerialChain.from_poe(chain.S, chain.M), bad)


# ---------------------------------------------------------------------- solve_closed_form
@pytest.mark.parametrize("name", ["ur5", "puma", "iiwa14"])
def test_solve_closed_form_is_ik_s_answer_where_the_first_try_finds_one(name):
    """Where it answers, the same configuration `ik` gives with the closed form alone (for 7R:
    the held joint at the seed's value); where it does not, the first try has no solution."""
    from kinematics_node.core.ik.solver import solve_closed_form

    chain = chain_of(name)
    rng = np.random.default_rng(11)
    only = IKOptions(method="closed_form", position_tolerance=TOL, orientation_tolerance=TOL)
    answered = 0
    for q, seed in zip(random_q(chain, rng, 60), random_q(chain, rng, 60), strict=True):
        T = chain.fk(q)
        res = solve_closed_form(chain, T, seed, only)
        if res is None:
            assert chain.ik_family.startswith("7r")  # a 6R arm's closed form is exhaustive
            held = family_of(chain).held_joint
            at_seed = seed[chain.joint_names.index(held)]
            assert not chain.ik_all(T, held=[at_seed]).solutions
            continue
        answered += 1
        assert res.success and reproduces(chain, res.q, T, TOL)
        np.testing.assert_allclose(res.q, chain.ik(T, seed, only).q, atol=1e-12)
    assert answered >= 30


def test_solve_closed_form_gives_none_where_ik_would_search_or_has_nothing():
    from kinematics_node.core.ik.solver import solve_closed_form

    chain = chain_of("ur5")
    T = chain.fk(random_q(chain, np.random.default_rng(2)))
    assert solve_closed_form(chain, T) is not None
    for options in (
        IKOptions(method="numeric"),
        IKOptions(position_only=True),
        IKOptions(weights=(1, 1, 0, 1, 1, 1)),
    ):
        assert solve_closed_form(chain, T, options=options) is None, options
    assert solve_closed_form(chain, ur_hole_target()) is None  # unreachable, inside the sphere
    far = np.eye(4)
    far[:3, 3] = (5.0, 0.0, 0.0)
    assert solve_closed_form(chain, far) is None
    from core.test_closed_form import PUMA, dh_arm

    rows = [list(r) for r in PUMA]
    rows[4][0] = 1e-3  # an offset wrist: no named family, the general 6R solver
    offset = dh_arm(rows)
    T = offset.fk(random_q(offset, np.random.default_rng(2)))
    res = solve_closed_form(offset, T)
    assert res is not None and reproduces(offset, res.q, T, 1e-9)
    five = dh_arm(PUMA[:5])  # no closed form at all
    assert solve_closed_form(five, five.fk(random_q(five, np.random.default_rng(2)))) is None
    with pytest.raises(InvalidInputError):
        solve_closed_form(chain, np.full((4, 4), np.nan))


def test_a_numeric_set_stays_distinct_when_a_solution_falls_between_two_members():
    """`SingleSolver._found`: a solution the same as two distinct members (within
    `solution_separation` of each, between them) replaced one of them where it was nearer the
    seed, and the set then held two solutions 9 mrad apart (a free axis's samples, CI on Kilted).
    It is left out now; a solution the same as one member still replaces it when nearer."""
    from kinematics_node.core.ik.problem import IKProblem
    from kinematics_node.core.ik.single import SingleSolver

    chain = chain_of("ur5")
    opts = IKOptions(method="numeric", num_solutions=3)
    seed = np.zeros(chain.dof)
    solver = SingleSolver(IKProblem.build(chain, opts), chain.fk(seed), seed)
    sep = opts.solution_separation

    def at(last: float) -> list[float]:  # solutions that differ in the last joint only
        return [0.0] * (chain.dof - 1) + [last]

    found: list = []
    for last in (0.5 + 1.8 * sep, 0.5):  # two distinct members, the farther from the seed first
        solver._found(found, at(last), 0.0, 0.0)
    solver._found(found, at(0.5 + 0.9 * sep), 0.0, 0.0)  # between them, nearer than the first
    assert [q[-1] for _, q, _, _ in found] == [0.5 + 1.8 * sep, 0.5]
    solver._found(found, at(0.5 - 0.5 * sep), 0.0, 0.0)  # the same as the second only, nearer
    kept = [q[-1] for _, q, _, _ in found]
    assert kept == [0.5 + 1.8 * sep, 0.5 - 0.5 * sep]
    assert all(abs(a - b) > sep for i, a in enumerate(kept) for b in kept[i + 1 :])


def test_a_numeric_search_run_again_goes_on_with_its_next_restarts():
    """`SingleSolver.run` called again (`ik` on a 7R arm: the search, the closed form's sweep,
    then the search again) starts from the next restart of its random stream: before, a new
    solver replayed the seed and, with `rng_seed` set, exactly the same restarts. Each run's
    starts are those of one uninterrupted stream, and `max_restarts` counts over all runs."""
    from kinematics_node.core.ik.problem import IKProblem
    from kinematics_node.core.ik.single import SingleSolver

    chain = chain_of("panda")
    opts = IKOptions(method="numeric", rng_seed=3, max_restarts=3)
    seed = np.zeros(chain.dof)
    T = chain.fk(np.full(chain.dof, 0.4))
    problem = IKProblem.build(chain, opts)

    def starts_of(solver: SingleSolver, runs: int) -> list[list[float]]:
        seen: list[list[float]] = []
        attempt = solver.attempt

        def recorded(q0: list[float], deadline: float):  # noqa: ANN202
            seen.append(list(q0))
            return attempt(q0, deadline)

        solver.attempt = recorded  # type: ignore[method-assign]
        for _ in range(runs):
            solver.run(0.0)  # past deadline: one attempt per run
        return seen

    resumed = starts_of(SingleSolver(problem, T, seed), 5)
    fresh = SingleSolver(problem, T, seed)
    stream = [fresh._random_start() for _ in range(3)]
    assert resumed[0] == list(seed)
    assert resumed[1:] == stream  # the next restart each time, never the seed again
    assert len(resumed) == 4  # max_restarts = 3 over all runs: the fifth run attempts nothing
