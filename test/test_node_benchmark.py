"""The node benchmark's verdict on issue 10's targets (`benchmarks/node_benchmark.py`), on
hand-built results: each target is judged met exactly when its figure is within it."""

from __future__ import annotations

import copy
import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "node_benchmark.py"
_spec = importlib.util.spec_from_file_location("node_benchmark", _PATH)
assert _spec is not None and _spec.loader is not None
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

POSES = {"pose_answered": 1.0, "twist_answered": 1.0, "pose_latency_median_ms": 0.8}
POSES |= {"pose_latency_p99_ms": 2.0, "cpu_percent": 55.0}
IK = {"ik_calls": 1900, "ik_late": 0, "ik_latency_max_ms": 55.0}
IK |= {"ik_reachable_unsolved": 0, "ik_unreachable_solved": 0}
ECHO = {"pose_answered": 1.0, "pose_latency_median_ms": 0.6, "pose_latency_p99_ms": 1.2}
RESULTS = {
    "echo, 1 kHz": ECHO | {"rate_hz": 1000.0, "cpu_percent": 60.0},
    "the echo on our LeanExecutor, 1 kHz": ECHO | {"rate_hz": 1000.0, "cpu_percent": 39.0},
    "ours ur5e (6 joints), 1 kHz": POSES | {"rate_hz": 1000.0},
    "echo, 500 Hz": ECHO | {"rate_hz": 500.0, "cpu_percent": 30.0},
    "ours ur5e, 500 Hz + 4 IK clients": POSES | IK | {"rate_hz": 500.0},
    "ours ur5e, 1 kHz + one 2 s IK call": POSES | {"rate_hz": 1000.0},
    "soak": {"growth_percent": 0.1},
}
RESULTS["ours ur5e, 1 kHz + one 2 s IK call"]["pose_rate_during_slow_ik"] = 1.0


def _verdicts(results):
    return {target: met for target, _, met in bench.target_checks(results)}


def test_every_target_is_judged_and_met_when_within():
    verdicts = _verdicts(RESULTS)
    assert all(verdicts.values()), verdicts
    # pose targets for both of our streaming phases, IK targets for the IK one; echoes judged never
    assert sum("≥ 99 % answered" in t for t in verdicts) == 2
    assert sum("IK clients" in t for t in verdicts) == 6
    assert not any("echo" in t.split(":")[0] for t in verdicts)
    assert "soak: RSS at the end within 10 % of 1 min" in verdicts


@pytest.mark.parametrize(
    ("label", "field", "value", "target"),
    [
        ("ours ur5e (6 joints), 1 kHz", "twist_answered", 0.989, "≥ 99 % answered"),
        ("ours ur5e (6 joints), 1 kHz", "pose_latency_median_ms", 1.21, "median"),  # 2.02× 0.6
        ("ours ur5e, 500 Hz + 4 IK clients", "pose_latency_median_ms", 1.51, "median"),
        ("ours ur5e (6 joints), 1 kHz", "pose_latency_p99_ms", 10.1, "p99"),
        ("ours ur5e (6 joints), 1 kHz", "cpu_percent", 121.0, "CPU"),  # 2.02× 60
        ("ours ur5e, 500 Hz + 4 IK clients", "cpu_percent", 61.0, "CPU"),  # 2.03× 30
        ("ours ur5e, 500 Hz + 4 IK clients", "ik_late", 1, "timeout + 20 ms"),
        ("ours ur5e, 500 Hz + 4 IK clients", "ik_reachable_unsolved", 1, "reachable solved"),
        ("ours ur5e, 500 Hz + 4 IK clients", "ik_unreachable_solved", 1, "reachable solved"),
        ("ours ur5e, 1 kHz + one 2 s IK call", "pose_rate_during_slow_ik", 0.949, "95 %"),
        ("soak", "growth_percent", 10.5, "soak"),
    ],
)
def test_a_figure_past_its_target_fails_that_target_only(label, field, value, target):
    results = copy.deepcopy(RESULTS)
    results[label][field] = value
    failed = [t for t, met in _verdicts(results).items() if not met]
    assert len(failed) == 1 and failed[0].startswith(f"{label}:") and target in failed[0], failed


def test_without_the_echo_only_the_absolute_median_is_judged():
    results = {"ours ur5e, 500 Hz + 4 IK clients": RESULTS["ours ur5e, 500 Hz + 4 IK clients"]}
    verdicts = _verdicts(results)
    assert not any("echo's" in t for t in verdicts)
    assert verdicts["ours ur5e, 500 Hz + 4 IK clients: median ≤ 1.5 ms (no echo measured)"]


def test_figures_exactly_at_their_targets_meet_them():
    results = copy.deepcopy(RESULTS)
    results["echo, 500 Hz"] |= {"pose_latency_median_ms": 0.75, "cpu_percent": 30.0}
    at_limits = {"pose_answered": 0.99, "twist_answered": 0.99, "pose_latency_p99_ms": 10.0}
    at_limits |= {"pose_latency_median_ms": 1.5, "cpu_percent": 60.0}  # 2× the echo's, 1.5 ms
    results["ours ur5e, 500 Hz + 4 IK clients"] |= at_limits
    results["ours ur5e, 1 kHz + one 2 s IK call"]["pose_rate_during_slow_ik"] = 0.95
    results["soak"]["growth_percent"] = -10.0
    verdicts = _verdicts(results)
    assert all(verdicts.values()), [t for t, met in verdicts.items() if not met]


VISUAL = {
    bench.MARKERS: POSES | {"rate_hz": 1000.0, "markers_per_s": 10.0},
    bench.TF: POSES | {"rate_hz": 1000.0, "tf_rate": 20.0, "tf_per_s": 20.0, "tf_answered": 0.02},
    bench.EVERY: POSES | {"rate_hz": 1000.0, "tf_rate": 0.0, "tf_per_s": 1e3, "tf_answered": 1.0},
}


@pytest.mark.parametrize(
    ("label", "field", "value", "target"),
    [
        (bench.MARKERS, "markers_per_s", 8.9, "markers at ≥ 90 % of 10 Hz"),
        (bench.TF, "tf_per_s", 17.9, "/tf at ≥ 90 % of 20 Hz"),
        (bench.EVERY, "tf_answered", 0.989, "/tf for ≥ 99 % of joint_states"),
        (bench.EVERY, "pose_answered", 0.98, "≥ 99 % answered"),
    ],
)
def test_the_visualisation_phases_are_held_to_their_rates_and_to_issue_10s(
    label, field, value, target
):
    """Issue 33's phases: markers at their rate, /tf at tf_rate (with tf_rate 0: for every
    joint_states message), and the pose targets of every phase of ours."""
    results = {"echo, 1 kHz": RESULTS["echo, 1 kHz"]} | copy.deepcopy(VISUAL)
    assert all(_verdicts(results).values())
    results[label][field] = value
    failed = [t for t, met in _verdicts(results).items() if not met]
    assert failed == [f"{label}: {target}"], failed
