"""`reach_voxels`: what a reachability map counts is true. Reached poses are reproduced by FK
within the limits, manipulability is Pinocchio's, the closed form and the numeric IK agree, the
numbers are the same in any process, and the issue's three correctness checks hold on a coarse
map (the full-size figures: benchmarks/workspace_correctness.py)."""

from __future__ import annotations

import hashlib
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from kin_testing import PinocchioOracle, random_q

from kinematics_node.core import InvalidInputError, KinematicsError
from kinematics_node.core.analysis import manipulability, manipulability_det
from kinematics_node.core.workspace import VoxelGrid, approach_rotations, reach_voxels, reachability
from kinematics_node.core.workspace.reachability import targets
from kinematics_node.sim.robots import load_robot, robot_path

ROOT = Path(__file__).resolve().parents[3]
PI = np.pi


def _bench():
    spec = importlib.util.spec_from_file_location(
        "workspace_correctness", ROOT / "benchmarks" / "workspace_correctness.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (its dataclass looks itself up there)
    spec.loader.exec_module(module)
    return module


def _small_map(robot: str, resolution: float, directions: int, **kwargs):
    chain = load_robot(robot)
    grid = VoxelGrid.around(chain, resolution)
    R = approach_rotations(directions)
    return chain, grid, R, reach_voxels(chain, grid.centres, R, **kwargs)


def _scara_rotations(k: int) -> np.ndarray:
    """k tool orientations a SCARA reaches (its tool z points down): turns about the vertical."""
    a = 2 * PI * np.arange(k) / k
    c, s_ = np.cos(a), np.sin(a)
    Rz = np.zeros((k, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s_, s_, c, 1.0
    down = np.diag([1.0, -1.0, -1.0])  # the SCARA's tool at home
    return down @ Rz


def _numeric_case(every: int = 4):
    """A chain without a closed-form family (the bundled SCARA: every 6R and 7R arm has one,
    the general 6R solver at worst), its grid's centres every other one, and orientations it
    can reach."""
    chain = load_robot("scara")
    assert chain.ik_family is None
    grid = VoxelGrid.around(chain, 0.1)
    return chain, grid.centres[::every], _scara_rotations(4)


@pytest.mark.parametrize(("robot", "resolution"), [("ur5e", 0.2), ("panda", 0.3)])
def test_every_reached_pose_is_reproduced_by_fk_within_the_limits(robot, resolution):
    chain, grid, R, reach = _small_map(robot, resolution, 20)
    T = targets(grid.centres, R)
    hit = reach.reached.reshape(-1)
    assert 0.1 < hit.mean() < 0.9  # a map with both
    q = reach.q.reshape(-1, chain.dof)
    F = chain.fk(q[hit])
    assert np.abs(F - T[hit]).max() <= 1e-9
    assert np.all(q[hit] >= chain.lower) and np.all(q[hit] <= chain.upper)
    # and what is not reached says so in every field
    assert np.isnan(q[~hit]).all()
    assert np.all(reach.manipulability.reshape(-1)[~hit] == 0.0)
    assert np.all(reach.solutions.reshape(-1)[~hit] == 0)
    assert np.all(reach.solutions.reshape(-1)[hit] >= 1)
    np.testing.assert_allclose(reach.index, 100.0 * reach.reached.mean(axis=1), rtol=1e-15)


def test_manipulability_is_pinocchios_det_j_for_that_solution():
    chain, grid, R, reach = _small_map("ur5e", 0.25, 10)
    pin = PinocchioOracle.from_urdf(robot_path("ur5e"), chain.joint_names)
    hit = np.argwhere(reach.reached)
    rng = np.random.default_rng(10)
    for m, k in hit[rng.choice(len(hit), 60, replace=False)]:
        T, J = pin.pose_and_jacobians(reach.q[m, k], chain.tip_link)
        expected = abs(np.linalg.det(J["world"]))
        assert reach.manipulability[m, k] == pytest.approx(expected, rel=1e-9, abs=1e-12)
        np.testing.assert_allclose(T[:3, 3], grid.centres[m], atol=1e-9)


def test_a_7r_arm_manipulability_is_pinocchios_sqrt_det_j_jt():
    chain, grid, R, reach = _small_map("panda", 0.3, 10)
    pin = PinocchioOracle.from_urdf(robot_path("panda"), chain.joint_names)
    hit = np.argwhere(reach.reached)
    for m, k in hit[:: max(1, len(hit) // 40)]:
        _, J = pin.pose_and_jacobians(reach.q[m, k], chain.tip_link)
        expected = np.sqrt(np.linalg.det(J["world"] @ J["world"].T))
        assert reach.manipulability[m, k] == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_the_determinant_measure_equals_the_singular_values_product():
    rng = np.random.default_rng(11)
    for robot, frames in (("ur5e", ("world", "space", "body")), ("panda", ("world", "space"))):
        chain = load_robot(robot)
        q = random_q(chain, rng, 500)
        expected = manipulability(chain.jacobian(q))
        for frame in frames:  # det Ad = 1: the same in every frame
            got = manipulability_det(chain.jacobian(q, frame))
            np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-13)
    # fewer joints than rows: √det(JᵀJ), the product of the n singular values
    planar = load_robot("planar3r")
    J = planar.jacobian(random_q(planar, rng, 50))
    np.testing.assert_allclose(manipulability_det(J), manipulability(J), rtol=1e-9, atol=1e-13)
    # a singular configuration: 0, never NaN
    ur = load_robot("ur5e")
    assert manipulability_det(ur.jacobian(np.zeros(6))) == pytest.approx(0.0, abs=1e-12)


def test_the_counts_and_the_best_manipulability_match_ik_all():
    chain, grid, R, reach = _small_map("ur5e", 0.25, 10)
    T = targets(grid.centres, R)
    rng = np.random.default_rng(12)
    hit = np.flatnonzero(reach.reached.reshape(-1))
    for t in rng.choice(hit, 40, replace=False):
        every = np.asarray(chain.ik_all(T[t]).solutions)
        wrapped = (every + PI) % (2 * PI) - PI
        distinct = {tuple(np.round(q, 6)) for q in wrapped}  # branches modulo whole turns
        assert reach.solutions.reshape(-1)[t] == len(distinct)
        best = manipulability(chain.jacobian(every)).max()  # by the SVD, over every solution
        assert reach.manipulability.reshape(-1)[t] == pytest.approx(best, rel=1e-9)


def test_the_numeric_ik_reaches_a_subset_of_the_closed_form():
    chain, grid, R, closed = _small_map("ur5e", 0.3, 8)
    numeric = reach_voxels(chain, grid.centres, R, method="numeric", restarts=20)
    assert closed.method == "closed_form" and numeric.method == "numeric"
    # the numeric search finds nothing the closed form misses (the closed form is complete) ...
    assert not np.any(numeric.reached & ~closed.reached)
    # ... and misses little of it (measured: none of the 815 of 2,112; 20 restarts, 1e-9)
    assert numeric.reached.sum() >= 0.98 * closed.reached.sum()
    assert np.all(numeric.solutions <= 1)


def test_a_chain_without_a_family_is_mapped_by_the_numeric_ik():
    chain, centres, R = _numeric_case()
    reach = reach_voxels(chain, centres, R, restarts=10)
    assert reach.method == "numeric"
    hit = reach.reached.reshape(-1)
    assert hit.sum() >= 100  # (its 0.2 m of vertical travel: a slab of the grid's ball)
    q = reach.q.reshape(-1, chain.dof)[hit]
    assert np.abs(chain.fk(q) - targets(centres, R)[hit]).max() <= 1e-9
    assert np.all(q >= chain.lower) and np.all(q <= chain.upper)
    # the orientations about the vertical reached alike (the SCARA's last joint turns the tool
    # through ±2π), but for what 10 random restarts miss
    per_roll = reach.reached.sum(axis=0)
    assert per_roll.min() >= 0.9 * per_roll.max()
    # a 4-joint arm's measure: the product of its 4 singular values, √det(JᵀJ) (which squares
    # the condition number: off by ~1e-12 absolute near a singularity)
    J = chain.jacobian(q)
    w = reach.manipulability.reshape(-1)[hit]
    np.testing.assert_allclose(w, manipulability(J), rtol=1e-9, atol=1e-10)
    with pytest.raises(KinematicsError, match="closed"):
        reach_voxels(chain, centres[:2], R, method="closed_form")


_IN_ANOTHER_PROCESS = """
import sys
from kinematics_node.core.workspace import reach_voxels
sys.path.insert(0, sys.argv[2])
sys.path.insert(0, sys.argv[3])
from test_reachability import _case, _digest
chain, centres, R = _case(sys.argv[1])
print(_digest(reach_voxels(chain, centres, R, restarts=10)))
"""


def _digest(reach) -> str:
    h = hashlib.sha256()
    for a in (reach.reached, reach.solutions, reach.manipulability, reach.q):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(reach.method.encode())
    return h.hexdigest()


def _case(robot: str):
    if robot == "numeric":
        return _numeric_case(every=8)
    chain = load_robot(robot)
    return chain, VoxelGrid.around(chain, 0.3).centres[::3], approach_rotations(6)


@pytest.mark.parametrize("robot", ["numeric", "ur5e", "panda"])
def test_the_same_map_bit_for_bit_in_another_process(robot):
    chain, centres, R = _case(robot)
    here = _digest(reach_voxels(chain, centres, R, restarts=10))
    env = {**os.environ, "PYTHONHASHSEED": "123", "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            _IN_ANOTHER_PROCESS,
            robot,
            str(Path(__file__).parent),
            str(ROOT / "test"),
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        check=True,
        timeout=120,
    )
    assert out.stdout.strip() == here


def test_the_numeric_chunks_are_seeded_by_position(monkeypatch):
    # a pass's restarts are drawn from seed + its first target, so a chunk gives the same
    # numbers whether it is mapped alone or within the whole (the map job's chunks)
    monkeypatch.setattr(reachability, "TARGETS_PER_PASS", 256)
    chain, centres, R = _numeric_case(every=8)
    whole = reach_voxels(chain, centres, R, restarts=5, seed=7)
    a = reach_voxels(chain, centres[:64], R, restarts=5, seed=7)  # one pass of 256 targets
    b = reach_voxels(chain, centres[64:], R, restarts=5, seed=7 + 256)
    assert whole.reached.any()
    np.testing.assert_array_equal(np.concatenate([a.q, b.q]), whole.q)
    np.testing.assert_array_equal(np.concatenate([a.reached, b.reached]), whole.reached)


def test_the_issue_checks_on_a_coarse_ur5e_map():
    """Issue #34's correctness checks (a)-(c), small: (a) every reached pose reproduced to 1e-9
    within the limits; (b) 300 unreached poses: the numeric IK (30 restarts) solves none;
    (c) every voxel hit by 100k random configurations has D > 0 unless its centre is out of
    reach."""
    f = _bench().run("ur5e", 0.2, 20, 300, 30, 100_000, None, 1, verbose=False)
    assert f.reached > 0
    assert f.worst_position <= 1e-9 and f.worst_rotation <= 1e-9 and f.outside_limits == 0
    assert f.unreached_tried == 300 and f.numeric_found == 0
    assert f.voxels_hit > 0.7 * f.voxels
    # every voxel hit with D = 0 either has its centre out of reach (a boundary voxel) or is
    # reached at its centre, by the map's own solver, in an orientation between the sampled ones
    # (measured: 189 and 3 of 653 voxels hit)
    in_reach = f.hit_with_d0 - f.hit_d0_centre_out_of_reach
    assert f.hit_d0_other_orientation == in_reach
    assert f.hit_d0_centre_out_of_reach <= 0.35 * f.voxels_hit  # 20 cm voxels: a thick shell


def test_the_issue_checks_on_a_coarse_panda_map():
    # reach_voxels' default sweep of the held joint (36 values): the numeric IK solves 1 of 200
    # poses counted unreachable (with 8 values: 6, with 3: 24)
    f = _bench().run("panda", 0.3, 12, 200, 30, 50_000, None, 2, verbose=False)
    assert f.worst_position <= 1e-9 and f.worst_rotation <= 1e-9 and f.outside_limits == 0
    assert f.numeric_found <= 2


@pytest.mark.parametrize(
    ("centres", "rotations", "kwargs", "words"),
    [
        ([[0.1, 0.2]], None, {}, "centres must be finite"),
        ([[np.nan, 0.2, 0.3]], None, {}, "centres must be finite"),
        ([[0.1, 0.2, 0.3]], np.eye(3), {}, "rotations must have shape"),
        ([[0.1, 0.2, 0.3]], None, {"method": "fast"}, "method must be"),
        ([[0.1, 0.2, 0.3]], None, {"tolerance": 0.0}, "tolerance"),
    ],
)
def test_bad_input_is_refused_saying_why(centres, rotations, kwargs, words):
    chain = load_robot("ur5e")
    R = approach_rotations(4) if rotations is None else rotations
    with pytest.raises(InvalidInputError, match=words):
        reach_voxels(chain, centres, R, **kwargs)


def test_rotations_that_are_not_rotations_are_refused():
    chain = load_robot("ur5e")
    R = np.array(approach_rotations(3))
    R[1, 0, 0] = np.nan
    with pytest.raises(InvalidInputError):
        reach_voxels(chain, [[0.3, 0.2, 0.3]], R)
    with pytest.raises(InvalidInputError):
        reach_voxels(chain, [[0.3, 0.2, 0.3]], 2.0 * approach_rotations(3))
