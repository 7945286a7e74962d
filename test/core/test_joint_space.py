"""IK joint-space helpers: whole-turn moves into the limits, the representative nearest a seed,
which joints are 2π-periodic (mimic followers included), and scalar = batch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics_node.core import IKOptions, SerialChain
from kinematics_node.core.ik.joint_space import (
    into_limits,
    into_limits_batch,
    nearest_equivalent,
    nearest_equivalent_batch,
    periodic_mask,
)

TWO_PI = 2 * math.pi
# (lower, upper) pairs: narrow, exactly 2π, wider than 2π, half-bounded, unbounded
LIMITS = [(-1.0, 0.5), (-math.pi, math.pi), (-2 * math.pi, 2 * math.pi), (0.0, math.inf),
          (-math.inf, math.inf), (-2.9, 2.9)]  # fmt: skip


def _turns(a: float, b: float) -> float:
    """(a − b) in whole turns (should be an integer when a ≡ b)."""
    return (a - b) / TWO_PI


def _representatives(v: float, lo: float, hi: float) -> list[float]:
    return [v + TWO_PI * k for k in range(-8, 9) if lo <= v + TWO_PI * k <= hi]


@pytest.mark.parametrize(("lo", "hi"), LIMITS)
def test_into_limits_turns_a_periodic_value_in_when_a_turn_fits_else_clamps(lo, hi) -> None:
    rng = np.random.default_rng(0)
    for v in rng.uniform(-15, 15, 400):
        got = into_limits(float(v), lo, hi, True)
        assert lo <= got <= hi
        reps = _representatives(float(v), lo, hi)
        if lo <= v <= hi:
            assert got == v
        elif reps:
            k = _turns(got, v)
            assert abs(k - round(k)) < 1e-12 and got in reps
        else:
            assert got in (lo, hi) and abs(got - v) == min(abs(lo - v), abs(hi - v))
        assert into_limits(float(v), lo, hi, False) == min(max(v, lo), hi)


@pytest.mark.parametrize(("lo", "hi"), LIMITS)
def test_nearest_equivalent_is_the_in_limits_turn_closest_to_the_reference(lo, hi) -> None:
    rng = np.random.default_rng(1)
    for _ in range(400):
        ref = float(rng.uniform(-12, 12))
        reps = []
        while not reps:
            v = float(rng.uniform(max(lo, -12), min(hi, 12)))
            reps = _representatives(v, lo, hi)
        got = nearest_equivalent(v, ref, lo, hi, True)
        assert lo <= got <= hi
        assert abs(_turns(got, v) - round(_turns(got, v))) < 1e-12
        assert abs(got - ref) <= min(abs(r - ref) for r in reps) + 1e-12
        assert nearest_equivalent(v, ref, lo, hi, False) == v


def test_batch_helpers_agree_with_the_scalar_ones() -> None:
    rng = np.random.default_rng(2)
    lo = np.array([a for a, _ in LIMITS])
    hi = np.array([b for _, b in LIMITS])
    periodic = np.array([True, True, True, True, True, False])
    Q = rng.uniform(-15, 15, (300, len(LIMITS)))
    got = into_limits_batch(Q, lo, hi, periodic)
    want = [
        [into_limits(*args) for args in zip(row, lo, hi, periodic, strict=True)]
        for row in Q.tolist()
    ]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)

    Qin = got  # inside the limits now
    ref = rng.uniform(-12, 12, Qin.shape)
    got = nearest_equivalent_batch(Qin, ref, lo, hi, periodic)
    want = [
        [nearest_equivalent(*args) for args in zip(row, r, lo, hi, periodic, strict=True)]
        for row, r in zip(Qin.tolist(), ref.tolist(), strict=True)
    ]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


_MIMIC_URDF = """<robot name="m">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="{mult}" offset="0.1"/></joint>
  <joint name="j3" type="{kind}"><parent link="b"/><child link="c"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
</robot>"""


@pytest.mark.parametrize(
    ("mult", "kind", "want"),
    [("1", "revolute", [True, True]), ("-2", "continuous", [True, True]),
     ("0.5", "revolute", [False, True]), ("1", "prismatic", [True, False])],
)  # fmt: skip
def test_periodic_mask_follows_joint_types_and_mimic_multipliers(mult, kind, want) -> None:
    chain = SerialChain.from_urdf(_MIMIC_URDF.format(mult=mult, kind=kind), tip_link="c")
    assert chain.solver_model.periodic.tolist() == want
    model = chain.solver_model
    assert periodic_mask(chain.joint_types, model.G, model.kernel.prismatic).tolist() == want
    # the claim behind the mask: a whole turn of a periodic joint leaves the tip pose unchanged
    q = np.array([0.4, 0.2])
    for j, periodic in enumerate(want):
        dq = np.zeros(2)
        dq[j] = TWO_PI
        same = np.allclose(chain.fk(q + dq), chain.fk(q), atol=1e-12)
        assert same == periodic


def test_elbow_limited_to_plus_minus_pi_is_solved_across_the_limit() -> None:
    """A UR arm's elbow lives in [−π, π]. Seeded at −3 rad for a pose whose elbow is +3 rad, the
    solver must cross ±π (a whole turn) instead of stopping at the limit, in one attempt."""
    from kin_testing import erd_path

    chain = SerialChain.from_urdf(erd_path("ur_description/urdf/ur5_robot.urdf"), tip_link="tool0")
    assert (chain.lower[2], chain.upper[2]) == pytest.approx((-math.pi, math.pi), abs=1e-9)
    q_goal = np.array([0.3, -1.2, 3.0, -1.0, 1.2, 0.4])
    seed = q_goal.copy()
    seed[2] = -3.0  # 0.28 rad away from the goal through ±π, 6 rad away through 0
    opts = IKOptions(
        position_tolerance=1e-10, orientation_tolerance=1e-10, max_restarts=0, method="numeric"
    )  # the closed form would answer with the other elbow branch, nearer in joint space
    res = chain.ik(chain.fk(q_goal), seed, opts)
    assert res.success, res.message
    assert np.all(res.q >= chain.lower) and np.all(res.q <= chain.upper)
    np.testing.assert_allclose(res.q, q_goal, atol=1e-8)


@pytest.mark.parametrize(("mult", "kind"), [("-2", "continuous"), ("0.5", "revolute")])
def test_ik_on_chains_with_a_mimic_joint_single_and_batch(mult, kind, batch_path) -> None:
    """The mimic follower is on the path, so IK works through θ_internal = G q + offset (the G
    branch of the Jacobian), with a periodic (integer) and a non-periodic (0.5) leader."""
    chain = SerialChain.from_urdf(_MIMIC_URDF.format(mult=mult, kind=kind), tip_link="c")
    assert chain.solver_model.G is not None
    rng = np.random.default_rng(4)
    lo, hi = np.maximum(chain.lower, -3.0), np.minimum(chain.upper, 3.0)
    T = chain.fk(rng.uniform(lo, hi, (10, chain.dof)))
    opts = IKOptions(position_tolerance=1e-8, orientation_tolerance=1e-8, timeout=0.2, rng_seed=1)
    batch = chain.ik_batch(T, options=opts)
    for k, T_target in enumerate(T):
        res = chain.ik(T_target, options=opts)
        for q in (res.q, batch.q[k]):
            np.testing.assert_allclose(chain.fk(q), T_target, atol=1e-7)
            assert np.all(q >= chain.lower) and np.all(q <= chain.upper)
        assert res.success and batch.success[k]
