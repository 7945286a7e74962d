"""Inverse kinematics: FK∘IK = identity on real arms (checked with Pinocchio's FK), limits, options,
refusals, deadlines, determinism, threads, batch, and the scalar SE(3) log against `se3.log`."""

from __future__ import annotations

import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from kin_testing import PinocchioOracle, erd_path, ur_hole_target
from scipy.spatial.transform import Rotation

from kinematics_node.core import IKOptions, InvalidInputError, SerialChain, se3, so3
from kinematics_node.core.ik.pose_error import relative_pose, se3_log, so3_log

ARMS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand"),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", "link_eef"),
}
POS_TOL, ORI_TOL = 1e-5, 1e-4


def _path(name: str) -> Path:
    return erd_path(ARMS[name][0])


_CHAINS: dict[str, SerialChain] = {}


def arm(name: str) -> SerialChain:
    if name not in _CHAINS:
        _CHAINS[name] = SerialChain.from_urdf(_path(name), tip_link=ARMS[name][1])
    return _CHAINS[name]


class PinFK:
    """Forward kinematics by Pinocchio (an oracle nobody here wrote) at our q, to the arm's tip."""

    def __init__(self, name: str) -> None:
        self.oracle = PinocchioOracle.from_urdf(_path(name), arm(name).joint_names)
        self.tip = ARMS[name][1]

    def __call__(self, q: np.ndarray) -> np.ndarray:
        return self.oracle.pose(q, self.tip)


def pose_errors(T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    """(‖p_a − p_b‖ [m], rotation angle of R_aᵀR_b [rad])."""
    angle = float(np.linalg.norm(so3.log(T_a[:3, :3].T @ T_b[:3, :3])))
    return float(np.linalg.norm(T_a[:3, 3] - T_b[:3, 3])), angle


def random_targets(chain: SerialChain, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    Q = rng.uniform(lo, hi, (n, chain.dof))
    return Q, chain.fk(Q)


def within_limits(chain: SerialChain, q: np.ndarray) -> bool:
    return bool(np.all(q >= chain.lower) and np.all(q <= chain.upper))


# ---------------------------------------------------------------------- FK(IK(T)) = T
@pytest.mark.parametrize("name", list(ARMS))
def test_fk_of_ik_equals_target_on_real_arms(name: str) -> None:
    chain, fk_pin = arm(name), PinFK(name)
    _, T = random_targets(chain, 12, seed=11)
    opts = IKOptions(timeout=0.5, rng_seed=3)
    for T_target in T:
        res = chain.ik(T_target, options=opts)
        assert res.success, res.message
        assert within_limits(chain, res.q)
        p_err, o_err = pose_errors(fk_pin(res.q), T_target)
        assert p_err <= POS_TOL and o_err <= ORI_TOL
        # the reported residual is the true one
        assert res.position_error == pytest.approx(p_err, abs=1e-9)
        assert res.orientation_error == pytest.approx(o_err, abs=1e-9)
        assert not res.q.flags.writeable
        assert res.solutions and np.array_equal(res.solutions[0], res.q)


def test_seed_outside_limits_is_clamped_and_result_within_limits() -> None:
    chain = arm("panda")
    _, T = random_targets(chain, 3, seed=5)
    seed = chain.upper + 1.0  # every joint beyond its upper limit
    for T_target in T:
        res = chain.ik(T_target, seed, IKOptions(timeout=0.5, rng_seed=0))
        assert res.success and within_limits(chain, res.q)


@pytest.mark.parametrize("name", ["planar3r", "scara"])
def test_arms_with_fewer_joints_than_pose_dimensions_solve_reachable_poses(name: str) -> None:
    """n < 6: a full 6-D pose is still reachable when it came from FK, and the stopping rules
    (spare degrees of freedom = max(n − 6, 0)) must not end every attempt early."""
    from kinematics_node.sim.robots import load_robot

    chain = load_robot(name)
    assert chain.dof < 6
    _, T = random_targets(chain, 10, seed=5)
    for k, T_target in enumerate(T):
        res = chain.ik(T_target, options=IKOptions(timeout=0.2, rng_seed=k))
        assert res.success, res.message
        assert within_limits(chain, res.q)
        p_err, o_err = pose_errors(chain.fk(res.q), T_target)
        assert p_err <= POS_TOL and o_err <= ORI_TOL


def test_default_seed_is_the_middle_of_the_limits() -> None:
    chain = arm("panda")
    mid = 0.5 * (chain.lower + chain.upper)
    T = chain.fk(mid)
    res = chain.ik(T, options=IKOptions(max_restarts=0, method="numeric"))
    assert res.success and res.iterations == 0  # already solved at the default seed
    np.testing.assert_allclose(res.q, mid)


# ---------------------------------------------------------------------- continuous joints
def _continuous_ur5() -> SerialChain:
    xml = _path("ur5").read_text()
    for j in ("shoulder_pan_joint", "wrist_3_joint"):
        old = f'name="{j}" type="revolute"'
        assert xml.count(old) == 1  # the fixture is what we think it is
        xml = xml.replace(old, f'name="{j}" type="continuous"')
    return SerialChain.from_urdf(xml, tip_link="tool0")


def test_continuous_joints_are_wrapped_towards_the_seed() -> None:
    chain = _continuous_ur5()
    cont = chain.continuous
    assert cont.tolist() == [True, False, False, False, False, True]
    _, T = random_targets(chain, 6, seed=21)
    for k, T_target in enumerate(T):
        seed = np.zeros(chain.dof)
        seed[cont] = (10.0, -7.0) if k % 2 else (25.0, 4.0)  # far outside [-π, π]
        res = chain.ik(T_target, seed, IKOptions(timeout=0.5, rng_seed=k))
        assert res.success, res.message
        assert np.all(np.abs(res.q[cont] - seed[cont]) <= np.pi + 1e-12)
        p_err, o_err = pose_errors(chain.fk(res.q), T_target)
        assert p_err <= POS_TOL and o_err <= ORI_TOL


# ---------------------------------------------------------------------- options
def test_position_only_reaches_position_and_ignores_orientation() -> None:
    chain, fk_pin = arm("xarm7"), PinFK("xarm7")
    _, T = random_targets(chain, 6, seed=8)
    rng = np.random.default_rng(0)
    for T_target in T:
        T_bad = T_target.copy()
        T_bad[:3, :3] = so3.exp(rng.normal(size=3))  # an orientation we do not ask for
        res = chain.ik(T_bad, options=IKOptions(position_only=True, timeout=0.5, rng_seed=1))
        assert res.success and res.orientation_error == 0.0
        p_err, o_err = pose_errors(fk_pin(res.q), T_bad)
        assert p_err <= POS_TOL
        # the orientation was ignored: the answer does not have the random orientation asked for
        assert o_err > 100 * ORI_TOL


def test_zero_position_weights_solve_orientation_only() -> None:
    chain = arm("panda")
    _, T = random_targets(chain, 4, seed=9)
    for T_target in T:
        far = T_target.copy()
        far[:3, 3] += (10.0, 0.0, 0.0)  # unreachable position
        res = chain.ik(far, options=IKOptions(weights=(1, 1, 1, 0, 0, 0), timeout=0.5, rng_seed=2))
        assert res.success and res.position_error == 0.0
        _, o_err = pose_errors(chain.fk(res.q), far)
        assert o_err <= ORI_TOL


def test_zero_weight_frees_a_rotation_the_arm_cannot_make() -> None:
    """A UR5 without its last joint (tip wrist_2_link: 5 joints) cannot spin its tip about the tip's
    y axis (the missing joint's): a spun target fails as a full pose, and is reached once that
    axis's weight is 0, with the tip's y axis where the target has it."""
    chain = SerialChain.from_urdf(_path("ur5"), "base_link", "wrist_2_link")
    assert chain.dof == 5
    rng = np.random.default_rng(10)
    for k in range(4):
        q_goal = rng.uniform(-2.0, 2.0, chain.dof)
        spun = chain.fk(q_goal) @ se3.exp(np.array([0.0, 0.8, 0.0, 0.0, 0.0, 0.0]))  # Ry(0.8)
        full = chain.ik(spun, options=IKOptions(timeout=0.02, rng_seed=k))
        assert not full.success
        opts = IKOptions(weights=(1, 0, 1, 1, 1, 1), timeout=0.5, rng_seed=k)
        res = chain.ik(spun, options=opts)
        assert res.success, res.message
        T_got = chain.fk(res.q)
        assert np.linalg.norm(T_got[:3, 3] - spun[:3, 3]) <= POS_TOL
        angle_y = math.acos(min(1.0, float(T_got[:3, 1] @ spun[:3, 1])))
        assert angle_y <= 2 * ORI_TOL  # the y axis matches; the spin about it is free


def _axis_errors(T_got: np.ndarray, T_target: np.ndarray) -> np.ndarray:
    """e = (log(Rᵀ R_t), Rᵀ(p_t − p)) in the tip axes, with SciPy's rotation vector as the log."""
    R, p = T_got[:3, :3], T_got[:3, 3]
    rotvec = Rotation.from_matrix(R.T @ T_target[:3, :3]).as_rotvec()
    return np.r_[rotvec, R.T @ (T_target[:3, 3] - p)]


def test_axis_tolerances_free_an_axis_that_full_pose_ik_cannot_meet() -> None:
    """A planar arm cannot tilt its tool out of the plane: the tilted target fails as a full pose
    and succeeds once the tilt axis (tool x) has an infinite bound; every bounded component of the
    answer is then within its bound, checked with SciPy's rotation vector."""
    from kinematics_node.sim.robots import load_robot

    chain = load_robot("planar3r")
    bounds = (math.inf, 1e-4, 1e-4, 1e-5, 1e-5, 1e-5)
    rng = np.random.default_rng(31)
    for k in range(4):
        q_goal = rng.uniform(-1.5, 1.5, chain.dof)
        tilt = se3.exp(np.r_[0.3, 0.0, 0.0, 0.0, 0.0, 0.0])  # about the tool's x axis
        T_target = chain.fk(q_goal) @ tilt
        full = chain.ik(T_target, options=IKOptions(timeout=0.02, rng_seed=k))
        assert not full.success and full.orientation_error > 0.29
        res = chain.ik(T_target, options=IKOptions(axis_tolerances=bounds, rng_seed=k))
        assert res.success, res.message
        e = _axis_errors(chain.fk(res.q), T_target)
        assert np.all(np.abs(e[1:]) <= np.array(bounds[1:]))
        assert abs(e[0]) == pytest.approx(0.3, abs=1e-3)  # the free tilt is left as it is


def test_loose_axis_tolerances_are_met_per_component_single_and_batch(batch_path: str) -> None:
    chain = arm("panda")
    bounds = (2e-2, 2e-2, 5e-2, 1e-3, 1e-3, 4e-3)
    _, T = random_targets(chain, 8, seed=33)
    opts = IKOptions(axis_tolerances=bounds, timeout=0.5, rng_seed=2)
    batch = chain.ik_batch(T, options=opts)
    assert batch.success.all(), batch.message
    for k, T_target in enumerate(T):
        res = chain.ik(T_target, options=opts)
        for q in (res.q, batch.q[k]):
            e = _axis_errors(chain.fk(q), T_target)
            assert np.all(np.abs(e) <= np.array(bounds)) and within_limits(chain, q)
        assert res.success, res.message


@pytest.mark.parametrize(
    ("bounds", "match"),
    [((1e-3,) * 5, "6 values"), ((0.0,) + (1e-3,) * 5, "> 0"), ((math.nan,) + (1e-3,) * 5, "> 0"),
     ((math.inf,) * 6, "at least one"), ("tight", "6 numbers")],
)  # fmt: skip
def test_bad_axis_tolerances_are_refused(bounds: object, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        IKOptions(axis_tolerances=bounds)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="position_only"):
        IKOptions(axis_tolerances=(math.inf,) * 3 + (1e-3,) * 3, position_only=True)


def test_distance_mode_returns_the_closest_solution_found() -> None:
    chain = arm("ur5")
    _, T = random_targets(chain, 3, seed=12)
    seed = np.array([0.3, -1.0, 1.0, -1.5, -1.5, 0.2])
    for T_target in T:
        common = dict(timeout=2.0, rng_seed=5, max_restarts=25)
        fast = chain.ik(T_target, seed, IKOptions(mode="speed", **common))
        near = chain.ik(T_target, seed, IKOptions(mode="distance", num_solutions=50, **common))
        assert fast.success and near.success
        d = [float(np.linalg.norm(s - seed)) for s in near.solutions]
        assert d == sorted(d) and len(d) >= 2
        assert np.array_equal(near.q, near.solutions[0])
        assert np.linalg.norm(near.q - seed) <= np.linalg.norm(fast.q - seed) + 1e-12
        for s in near.solutions:
            p_err, o_err = pose_errors(chain.fk(s), T_target)
            assert p_err <= POS_TOL and o_err <= ORI_TOL and within_limits(chain, s)


def test_num_solutions_are_distinct_and_valid() -> None:
    chain, fk_pin = arm("ur5"), PinFK("ur5")
    _, T = random_targets(chain, 2, seed=13)
    for T_target in T:
        res = chain.ik(T_target, options=IKOptions(num_solutions=4, timeout=2.0, rng_seed=6))
        assert res.success and len(res.solutions) == 4, res.message
        for i, a in enumerate(res.solutions):
            p_err, o_err = pose_errors(fk_pin(a), T_target)
            assert p_err <= POS_TOL and o_err <= ORI_TOL and within_limits(chain, a)
            for b in res.solutions[i + 1 :]:
                assert np.max(np.abs(a - b)) > 1e-2
        seed = 0.5 * (chain.lower + chain.upper)
        d = [np.linalg.norm(s - seed) for s in res.solutions]
        assert d == sorted(d)


# ---------------------------------------------------------------------- failures and refusals
def wall_times(call, repeats: int = 5) -> tuple[list, np.ndarray]:
    """The results of `repeats` calls and their wall times [s].

    A busy machine can delay any one call by tens of milliseconds; a solver that overruns its
    deadline overruns it in every call. So the fastest call is held to the tight bound, and every
    call to a loose one that still fails a solver ignoring its timeout.
    """
    results, times = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        results.append(call())
        times.append(time.perf_counter() - t0)
    return results, np.array(times)


def test_unreachable_target_fails_cleanly_within_the_timeout() -> None:
    chain = arm("ur5")
    T = ur_hole_target()  # within the reach sphere, but no configuration reaches it
    assert chain.ik_all(T).solutions == ()
    # max_restarts high enough that only the timeout can end the search (1000 take ~0.2 s)
    opts = IKOptions(timeout=0.02, rng_seed=0, max_restarts=10**6)
    results, elapsed = wall_times(lambda: chain.ik(T, options=opts), repeats=3)
    assert elapsed.min() >= 0.015, elapsed  # it searched: the target is not ruled out beforehand
    assert elapsed.min() < 0.02 + 0.05 and elapsed.max() < 0.02 + 0.5, elapsed
    for res in results:
        assert not res.success
        assert np.all(np.isfinite(res.q)) and within_limits(chain, res.q)
        p_err, o_err = pose_errors(chain.fk(res.q), T)
        assert res.position_error == pytest.approx(p_err, rel=1e-9)
        assert res.orientation_error == pytest.approx(o_err, abs=1e-9)
        assert p_err > opts.position_tolerance or o_err > opts.orientation_tolerance
        assert "timeout" in res.message and "best residual" in res.message and res.solutions == ()


def test_a_target_beyond_the_reach_sphere_is_answered_at_once_with_a_best_effort() -> None:
    chain = arm("panda")
    T = chain.fk(np.zeros(7))
    T[:3, 3] += (10.0, 0.0, 0.0)
    opts = IKOptions(timeout=1.0, rng_seed=0, max_restarts=10**6)
    results, elapsed = wall_times(lambda: chain.ik(T, options=opts), repeats=3)
    assert elapsed.max() < 0.25, elapsed  # one descent, not the 1 s timeout
    for res in results:
        assert not res.success and res.restarts == 0 and res.solutions == ()
        assert res.message.startswith("unreachable: the target is"), res.message
        assert np.all(np.isfinite(res.q)) and within_limits(chain, res.q)
        p_err, _ = pose_errors(chain.fk(res.q), T)
        assert res.position_error == pytest.approx(p_err, rel=1e-9)
        assert 8.0 < p_err < 10.0  # Panda reaches about 1 m; the best residual is what is left
    # a free position axis leaves no bound on where the tip may be: the search runs as usual
    free = IKOptions(timeout=0.02, axis_tolerances=(1e-4, 1e-4, 1e-4, math.inf, 1e-5, 1e-5))
    assert not chain.ik(T, options=free).message.startswith("unreachable")


def test_tiny_timeout_is_honoured() -> None:
    chain = arm("xarm7")
    T = chain.fk(np.zeros(7))
    T[:3, 3] += (3.0, 0.0, 0.0)
    # (ignoring the timeout, the default 1000 restarts take ~0.5 s, a batch of 200 ~40 s)
    for timeout in (0.002, 0.005):
        opts = IKOptions(timeout=timeout)
        results, elapsed = wall_times(lambda opts=opts: chain.ik(T, options=opts))
        assert elapsed.min() < timeout + 0.005 and elapsed.max() < timeout + 0.25, elapsed
        assert not any(res.success for res in results)
    # 200 targets: the 7R closed form's 16 first tries alone take ~40 ms on them, the restarts'
    # lanes ~3 ms; both stop at the deadline (~15 ms in all here)
    T_b = np.repeat(T[None], 200, 0)
    results, elapsed = wall_times(
        lambda: chain.ik_batch(T_b, options=IKOptions(batch_timeout=0.01)), repeats=3
    )
    assert elapsed.min() < 0.01 + 0.04 and elapsed.max() < 0.01 + 0.5, elapsed
    assert not any(res_b.success.any() for res_b in results)


def test_max_restarts_ends_the_search() -> None:
    chain = arm("ur5")
    T = ur_hole_target()
    res = chain.ik(T, options=IKOptions(max_restarts=3, timeout=10.0))
    assert not res.success and res.restarts == 3 and "max_restarts" in res.message


@pytest.mark.parametrize(
    ("T_bad", "match"),
    [
        (np.full((4, 4), np.nan), "non-finite"),
        (np.diag([2.0, 1.0, 1.0, 1.0]), "rotation"),  # scaled, not rigid
        (np.diag([-1.0, 1.0, 1.0, 1.0]), "rotation"),  # reflection
        (np.eye(3), "shape"),
        (np.vstack((np.eye(4)[:3], [[0.0, 0.0, 1.0, 1.0]])), "last row"),
    ],
)
def test_bad_targets_are_refused(T_bad: np.ndarray, match: str) -> None:
    chain = arm("ur5")
    with pytest.raises(InvalidInputError, match=match):
        chain.ik(T_bad)
    with pytest.raises(InvalidInputError):
        chain.ik_batch(np.broadcast_to(T_bad, (2,) + T_bad.shape))


def test_bad_seeds_are_refused() -> None:
    chain = arm("ur5")
    T = chain.fk(np.zeros(6))
    with pytest.raises(InvalidInputError, match="6 values"):
        chain.ik(T, np.zeros(5))
    with pytest.raises(InvalidInputError, match="non-finite"):
        chain.ik(T, [0.0, np.nan, 0, 0, 0, 0])
    with pytest.raises(InvalidInputError, match="shape"):
        chain.ik_batch(np.stack((T, T)), np.zeros((3, 6)))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"position_tolerance": -1e-5}, "position_tolerance"),
        ({"orientation_tolerance": 0.0}, "orientation_tolerance"),
        ({"timeout": 0.0}, "timeout"),
        ({"timeout": -1.0}, "timeout"),
        ({"timeout": float("nan")}, "timeout"),
        ({"mode": "fastest"}, "mode"),
        ({"weights": (1.0, 1.0, 1.0)}, "6 values"),
        ({"weights": (1, 1, 1, 1, 1, -1)}, "≥ 0"),
        ({"weights": (1, 1, 1, 0, 0, 0), "position_only": True}, "positive"),
        ({"num_solutions": 0}, "num_solutions"),
        ({"max_restarts": -1}, "max_restarts"),
        ({"max_iterations": 0}, "max_iterations"),
        ({"max_restarts": 2.5}, "max_restarts"),
        ({"rng_seed": "abc"}, "rng_seed"),
        ({"position_only": "yes"}, "position_only"),
        ({"batch_timeout": 0.0}, "batch_timeout"),
        ({"solution_separation": 0.0}, "solution_separation"),
    ],
)
def test_ik_options_validation(kwargs: dict, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        IKOptions(**kwargs)


def test_options_that_do_not_fit_the_chain_or_call_are_refused() -> None:
    chain = arm("ur5")
    T = chain.fk(np.zeros(6))
    with pytest.raises(InvalidInputError, match="joint_weights"):
        chain.ik(T, options=IKOptions(joint_weights=(1.0, 1.0)))
    with pytest.raises(InvalidInputError, match="speed"):
        chain.ik_batch(T[None], options=IKOptions(mode="distance"))
    with pytest.raises(InvalidInputError, match="IKOptions"):
        chain.ik(T, options={"timeout": 1.0})  # type: ignore[arg-type]


# ---------------------------------------------------------------------- determinism and threads
def _hard_targets(chain: SerialChain, n: int) -> np.ndarray:
    """Targets that usually need restarts from a seed at the limits."""
    return random_targets(chain, n, seed=31)[1]


def numeric(rng_seed: int) -> IKOptions:
    """The numeric search alone (the closed form would answer these targets without restarts)."""
    return IKOptions(timeout=5.0, rng_seed=rng_seed, method="numeric")


def test_equal_rng_seed_gives_equal_results() -> None:
    chain = arm("panda")
    seed = chain.lower + 0.01
    runs = [
        [chain.ik(T, seed, numeric(rng_seed=42)) for T in _hard_targets(chain, 6)] for _ in range(2)
    ]
    assert sum(r.restarts for r in runs[0]) > 0  # the random restarts were exercised
    for a, b in zip(*runs, strict=True):
        assert np.array_equal(a.q, b.q) and a.iterations == b.iterations
    other = [chain.ik(T, seed, numeric(rng_seed=7)) for T in _hard_targets(chain, 6)]
    assert any(not np.array_equal(a.q, b.q) for a, b in zip(runs[0], other, strict=True))


def test_concurrent_threads_match_single_thread_results() -> None:
    chain = arm("panda")
    seed = chain.lower + 0.01
    targets = _hard_targets(chain, 8)
    jobs = [(T, IKOptions(timeout=10.0, rng_seed=100 + k)) for k, T in enumerate(targets)]
    expected = [chain.ik(T, seed, o) for T, o in jobs]
    barrier = threading.Barrier(4)

    def work(offset: int) -> list:
        barrier.wait()
        order = jobs[offset:] + jobs[:offset]  # threads interleave different targets
        got = [chain.ik(T, seed, o) for T, o in order]
        return got[-offset:] + got[:-offset] if offset else got

    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(work, range(4)))
    for got in results:
        for a, b in zip(got, expected, strict=True):
            assert np.array_equal(a.q, b.q) and a.success == b.success


# ---------------------------------------------------------------------- batch
@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_batch_agrees_with_single_calls(name: str, batch_path: str) -> None:
    chain, fk_pin = arm(name), PinFK(name)
    N = 40
    _, T = random_targets(chain, N, seed=17)
    # budgets that never bind, so that both runs are deterministic for rng_seed = 0
    opts = IKOptions(timeout=5.0, rng_seed=0)
    res = chain.ik_batch(T, options=opts)
    assert res.q.shape == (N, chain.dof)
    for field in ("success", "position_error", "orientation_error", "iterations", "restarts"):
        assert getattr(res, field).shape == (N,)
        assert not getattr(res, field).flags.writeable
    assert res.success.all(), res.message
    single = [chain.ik(T[k], options=opts) for k in range(N)]
    assert all(s.success for s in single)
    for k in range(N):
        p_err, o_err = pose_errors(fk_pin(res.q[k]), T[k])
        assert p_err <= POS_TOL and o_err <= ORI_TOL and within_limits(chain, res.q[k])
        assert res.position_error[k] == pytest.approx(p_err, abs=1e-9)
    if batch_path == "per-target":  # the same solver per target: the very same answers
        for k, s in enumerate(single):
            np.testing.assert_array_equal(res.q[k], s.q)
            assert (res.iterations[k], res.restarts[k]) == (s.iterations, s.restarts)
            assert (res.position_error[k], res.orientation_error[k]) == (
                s.position_error,
                s.orientation_error,
            )
    else:  # lock-step restarts run in parallel; the attempt from the seed is the same LM
        one = IKOptions(timeout=5.0, rng_seed=0, max_restarts=0)
        res1 = chain.ik_batch(T, options=one)
        single1 = [chain.ik(T[k], options=one) for k in range(N)]
        # rounding differs (NumPy vs plain floats), so an attempt near its limits may end
        # differently; the others end on the same solution, each within the tolerances (a
        # redundant arm may stop at another point of its self-motion, so only the 6-joint arms'
        # answers are compared joint by joint)
        both = [k for k, s in enumerate(single1) if s.success and res1.success[k]]
        assert len(both) >= 0.8 * N
        for k in both if chain.dof == 6 else []:
            np.testing.assert_allclose(res1.q[k], single1[k].q, atol=1e-3)


def test_batch_failure_reports_best_configuration_and_custom_seeds(batch_path: str) -> None:
    chain = arm("ur5")
    Q, T = random_targets(chain, 6, seed=18)
    T[0, :3, 3] += (10.0, 0.0, 0.0)  # one unreachable target
    res = chain.ik_batch(T, Q + 0.05, IKOptions(batch_timeout=0.3, rng_seed=1))
    assert not res.success[0] and res.success[1:].all()
    assert np.all(np.isfinite(res.q)) and res.position_error[0] > 8.0
    p_err, _ = pose_errors(chain.fk(res.q[0]), T[0])
    assert res.position_error[0] == pytest.approx(p_err, rel=1e-9)
    assert "5/6" in res.message


def test_batch_position_only_and_continuous(batch_path: str) -> None:
    chain = _continuous_ur5()
    _, T = random_targets(chain, 10, seed=19)
    seeds = np.zeros((10, 6))
    seeds[:, 0] = 20.0
    res = chain.ik_batch(T, seeds, IKOptions(position_only=True, rng_seed=3))
    assert res.success.all() and np.all(res.orientation_error == 0.0)
    assert np.all(np.abs(res.q[:, 0] - 20.0) <= np.pi + 1e-12)
    np.testing.assert_allclose(chain.fk(res.q)[:, :3, 3], T[:, :3, 3], atol=POS_TOL)


def test_small_batches_return_exactly_what_single_calls_return() -> None:
    from kinematics_node.core.ik.solver import SCALAR_BATCH_BELOW

    chain = arm("panda")
    N = SCALAR_BATCH_BELOW - 1
    Q, T = random_targets(chain, N, seed=20)
    opts = IKOptions(timeout=0.5, rng_seed=7)
    res = chain.ik_batch(T, Q[::-1], opts)
    for k in range(N):
        single = chain.ik(T[k], Q[N - 1 - k], opts)
        np.testing.assert_array_equal(res.q[k], single.q)  # same solver, same seed, same answer
        assert (res.iterations[k], res.restarts[k]) == (single.iterations, single.restarts)
    assert res.success.all() and f"{N}/{N}" in res.message


@pytest.mark.filterwarnings("error")  # a NaN or overflow warning anywhere fails the test
def test_random_option_mixes_never_return_nan_or_leave_the_limits(batch_path: str) -> None:
    """Fuzz: bundled arms of 3–7 joints, targets reachable, perturbed or far away, seeds at the
    limits, random weights / axis bounds / position-only / modes. Whatever happens, q is finite
    and within the limits and the reported errors are finite (single and batch)."""
    from kinematics_node.sim.robots import load_robot

    chains = [load_robot(n) for n in ("ur5e", "panda", "scara", "planar3r")]
    rng = np.random.default_rng(99)
    for it in range(48):
        chain = chains[it % len(chains)]
        lo = np.where(np.isfinite(chain.lower), chain.lower, -4.0)
        hi = np.where(np.isfinite(chain.upper), chain.upper, 4.0)
        T = chain.fk(rng.uniform(lo, hi))
        if it % 3 == 1:
            T = T @ se3.exp(rng.normal(size=6) * 0.3)  # perhaps unreachable
        elif it % 3 == 2:
            T[:3, 3] *= 5.0  # out of reach
        seed = (lo, hi, rng.uniform(lo, hi))[it % 3]
        weights = tuple(rng.choice([0.0, 0.5, 1.0, 3.0], 6)) if it % 4 == 1 else None
        bounds = (
            tuple(rng.choice([1e-5, 1e-3, 0.1, math.inf], 5)) + (1e-3,) if it % 4 == 2 else None
        )
        if weights is not None and not any(weights):
            weights = None
        opts = IKOptions(
            weights=weights,
            axis_tolerances=bounds,
            position_only=it % 4 == 3,
            timeout=0.005,
            rng_seed=it,
            mode="distance" if it % 5 == 0 else "speed",
        )
        res = chain.ik(T, seed, opts)
        batch = chain.ik_batch(
            np.stack([T, T]), np.stack([seed, seed]), replace(opts, mode="speed")
        )
        for q in (res.q, *batch.q):
            assert np.all(np.isfinite(q)) and within_limits(chain, q)
        errors = [res.position_error, res.orientation_error]
        errors += [*batch.position_error, *batch.orientation_error]
        assert all(math.isfinite(x) for x in errors)


# ---------------------------------------------------------------------- scalar log fast path
def _pose12(T: np.ndarray) -> tuple[float, ...]:
    return tuple(T[:3, :3].ravel().tolist()) + tuple(T[:3, 3].tolist())


@pytest.mark.parametrize(
    "theta", [0.0, 1e-12, 1e-9, 1e-6, 1e-3, 9.99e-3, 1e-2, 0.5, 2.0, np.pi - 1e-3, np.pi - 1e-7]
)
def test_scalar_log_matches_se3_log(theta: float) -> None:
    rng = np.random.default_rng(int(theta * 1e6) % 1000)
    for _ in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        xi = np.r_[axis * theta, rng.normal(size=3)]
        T = se3.exp(xi)
        got = np.array(se3_log(_pose12(T)))
        np.testing.assert_allclose(got[:6], se3.log(T), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(got[:6], xi, rtol=1e-6, atol=1e-9)
        assert got[6] == pytest.approx(np.linalg.norm(so3.log(T[:3, :3])), abs=1e-12)
        phi = np.array(so3_log(_pose12(T))[:3])
        np.testing.assert_allclose(phi, so3.log(T[:3, :3]), rtol=1e-9, atol=1e-12)


def test_scalar_log_at_exactly_pi_round_trips() -> None:
    for axis in (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([1.0, 2.0, -2.0]) / 3):
        T = se3.exp(np.r_[axis * np.pi, 0.3, -0.2, 0.5])
        got = np.array(se3_log(_pose12(T)))
        assert got[6] == pytest.approx(np.pi, abs=1e-7)
        np.testing.assert_allclose(se3.exp(got[:6]), T, atol=1e-9)  # axis sign is free at π


def test_relative_pose_is_inverse_times_target() -> None:
    rng = np.random.default_rng(3)
    A, B = se3.exp(rng.normal(size=6)), se3.exp(rng.normal(size=6))
    want = se3.inverse(A) @ B
    np.testing.assert_allclose(relative_pose(_pose12(A), _pose12(B)), _pose12(want), atol=1e-14)


@pytest.mark.parametrize("n", [3, 4, 6, 7])
def test_lm_step_is_the_damped_least_squares_step_in_either_form(n: int) -> None:
    """Δq = Jᵀ(JJᵀ + λI)⁻¹r, also when fewer joints than rows make the solver use the n × n form
    (JᵀJ + λI)Δq = Jᵀr; that form returns Jᵀr too, and a zeroed (frozen) joint does not move.
    Reference: the minimiser of ‖JΔq − r‖² + λ‖Δq‖², by least squares on the stacked system
    (well conditioned even where JJᵀ + λI is not, i.e. n < 6 with a tiny λ)."""
    from kinematics_node.core.ik.single import _lm_step

    rng = np.random.default_rng(n)
    # 1e-12 only for the n × n form: the 6 × 6 one is then as ill-conditioned as JJᵀ (rank 5
    # here, with the frozen joint)
    for lam in (1e-12, 1e-2, 10.0) if n < 6 else (1e-2, 10.0):
        Jt = rng.normal(size=(n, 6))
        Jt[0] = 0.0  # a joint frozen at its limit
        r = rng.normal(size=6)
        stacked = np.vstack((Jt.T, math.sqrt(lam) * np.eye(n)))
        expected = np.linalg.lstsq(stacked, np.r_[r, np.zeros(n)], rcond=None)[0]
        out = _lm_step(Jt, r, lam, np.eye(min(n, 6)))
        assert out is not None
        dq, g = out
        np.testing.assert_allclose(dq, expected, rtol=1e-6, atol=1e-9)
        assert dq[0] == 0.0
        if n < 6:
            assert g is not None
            np.testing.assert_allclose(g, Jt @ r, rtol=1e-12)


@pytest.mark.parametrize("n", [3, 4, 7])
def test_batched_lm_steps_are_the_damped_least_squares_steps(n: int) -> None:
    """`_ik_batch._lm_steps` in either form: each step minimises ‖JΔq − r‖² + λ‖Δq‖², and the
    predicted decrease is Δqᵀ(λΔq + Jᵀr)."""
    from kinematics_node.core.ik.batch import _lm_steps

    rng = np.random.default_rng(10 + n)
    k = 5
    J = rng.normal(size=(k, 6, n))
    r = rng.normal(size=(k, 6))
    lam = np.array([1e-12, 1e-3, 1e-2, 1.0, 10.0]) if n < 6 else np.full(k, 1e-2)
    dq, predicted = _lm_steps(J, r, lam, np.eye(min(n, 6)))
    for i in range(k):
        stacked = np.vstack((J[i], math.sqrt(lam[i]) * np.eye(n)))
        expected = np.linalg.lstsq(stacked, np.r_[r[i], np.zeros(n)], rcond=None)[0]
        np.testing.assert_allclose(dq[i], expected, rtol=1e-6, atol=1e-9)
        g = J[i].T @ r[i]
        assert predicted[i] == pytest.approx(dq[i] @ (lam[i] * dq[i] + g), rel=1e-9)
