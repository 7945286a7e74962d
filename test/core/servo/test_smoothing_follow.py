"""`JerkLimitedIntegrator.reachable` and `follow`: a target inside the reach is arrived at exactly
at the end of the period, and the motion in between keeps the velocity, acceleration and jerk
limits (checked on the positions' finite differences, which nobody here computes for it)."""

from __future__ import annotations

import numpy as np
import pytest
from servo_testing import robot

from kinematics_node.core.servo import ServoConfig, ServoLimits
from kinematics_node.core.servo.smoothing import JerkLimitedIntegrator, ruckig_available

pytestmark = pytest.mark.skipif(not ruckig_available(), reason="needs ruckig")


@pytest.mark.parametrize("period", [0.01, 0.001])
def test_follow_arrives_exactly_within_the_limits(period):
    chain = robot("panda")
    limits = ServoLimits.from_chain(chain, ServoConfig(period_s=period))
    q0 = np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8])
    integ = JerkLimitedIntegrator(limits, period, q0)
    rng = np.random.default_rng(5)
    qs, vs, acc = [integ.q.copy()], [integ.v.copy()], [integ.a.copy()]
    phase = rng.uniform(0, 2 * np.pi, 7)
    for k in range(400):
        lo, hi = integ.reachable()
        assert all(a <= b for a, b in zip(lo, hi, strict=True))
        # a square wave of ±0.3 rad/s: mostly out of reach, so the target is the reach's bound
        want = 0.3 * np.sign(np.sin(2 * np.pi * 2.0 * k * 0.01 + phase))
        target = [min(max(w, a), b) for w, a, b in zip(want, lo, hi, strict=True)]
        assert integ.follow(target) is None
        assert integ.v_list == target  # no lag at all
        qs.append(integ.q.copy())
        vs.append(integ.v.copy())
        acc.append(integ.a.copy())
    q, v, a = np.array(qs), np.array(vs), np.array(acc)
    assert np.abs(v).max() > 0.05  # it did move
    assert np.all(np.abs(v) <= limits.velocity * (1 + 1e-12))
    assert np.all(np.abs(a) <= limits.acceleration * (1 + 1e-12))
    j_fd = np.diff(q, 3, axis=0) / period**3
    assert np.all(np.abs(j_fd) <= limits.jerk * (1 + 1e-6) + 1e-3)
    a_fd = np.diff(q, 2, axis=0) / period**2
    assert np.all(np.abs(a_fd) <= limits.acceleration * (1 + 1e-9))


def test_a_target_out_of_reach_is_stepped_toward_by_ruckig():
    chain = robot("panda")
    limits = ServoLimits.from_chain(chain, ServoConfig())
    integ = JerkLimitedIntegrator(limits, 0.01, np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8]))
    integ.follow([1.0] + [0.0] * 6)  # far beyond one period's reach: the smoothing's step
    assert 0.0 < integ.v_list[0] < 0.01
