"""The servo node benchmark's measuring functions (`benchmarks/servo_node_benchmark.py`), on
hand-built message records: which joint command answers which twist, which cycles are on time,
and the verdict on issue 23's node targets."""

from __future__ import annotations

import copy
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "servo_node_benchmark.py"
sys.path.insert(0, str(_PATH.parent))  # it imports node_benchmark beside it
_spec = importlib.util.spec_from_file_location("servo_node_benchmark", _PATH)
assert _spec is not None and _spec.loader is not None
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

MS = 1_000_000  # ns
PERIOD = 1 * MS


def _servo_stream(start, cycles, moves_from, q0=(0.1, 0.2), delay=300_000, transport=200_000):
    """A 1 kHz joint command stream: held at q0, moving from cycle `moves_from` on (None: never).
    Records (data, source, arrival) [ns]; each published `delay` after its cycle's start."""
    out = []
    q = list(q0)
    for k in range(cycles):
        if moves_from is not None and k >= moves_from:
            q = [q[0] + 1e-8 * (k - moves_from + 1), q[1]]
        source = start + k * PERIOD + delay
        out.append((list(q), source, source + transport))
    return out


def test_the_first_changed_command_answers_a_twist_at_rest():
    t0 = 10_000 * MS
    outputs = _servo_stream(t0, 40, moves_from=23)
    send = t0 + 21 * PERIOD + 500_000  # received before cycle 22; taken at cycle 23 (say)
    found, counts = bench.response_latencies([send], outputs, PERIOD)
    assert counts == {"moving": 0, "unanswered": 0}
    assert found == [(send, outputs[23][1], outputs[23][2])]


def test_a_command_published_before_the_send_is_never_the_answer():
    t0 = 10_000 * MS
    outputs = _servo_stream(t0, 40, moves_from=23)
    # it arrives after the send, but the node published it before: not an answer
    send = outputs[23][1] + 1
    found, counts = bench.response_latencies([send], outputs, PERIOD)
    assert found == [] and counts["moving"] == 1  # the arm was already moving at the send


def test_no_change_before_the_next_twist_is_unanswered():
    t0 = 10_000 * MS
    outputs = _servo_stream(t0, 100, moves_from=80)
    sends = [t0 + 10 * PERIOD, t0 + 70 * PERIOD]
    found, counts = bench.response_latencies(sends, outputs, PERIOD)
    # the first twist got no changed command before the second was sent; the second's is cycle 80
    assert counts["unanswered"] == 1 and len(found) == 1 and found[0][1] == outputs[80][1]


def test_a_silent_node_at_rest_answers_with_its_first_moving_command():
    """After its hold messages the node sends nothing; the first command after the twist moves."""
    t0 = 10_000 * MS
    held = _servo_stream(t0, 4, moves_from=None)
    moving = _servo_stream(t0, 60, moves_from=50)[50:]
    send = t0 + 48 * PERIOD
    found, counts = bench.response_latencies([send], held + moving, PERIOD)
    assert counts == {"moving": 0, "unanswered": 0} and found[0][1] == moving[0][1]


def test_echo_answers_are_matched_by_the_stamp_they_carry():
    sends = [5_000_000_123, 5_060_000_456, 5_120_000_789]
    outputs = [
        ([5.0, 123.0], 5_000_400_000, 5_000_600_000),
        ([5.0, 120_000_789.0], 5_120_300_000, 5_120_500_000),
        ([7.0, 0.0], 7_000_000_000, 7_000_000_100),  # answers nothing sent
    ]
    found, unanswered = bench.echo_latencies(sends, outputs)
    assert unanswered == 1
    assert found == [
        (5_000_000_123, 5_000_400_000, 5_000_600_000),
        (5_120_000_789, 5_120_300_000, 5_120_500_000),
    ]


@pytest.mark.parametrize("offset", [0.05, 0.5, 0.97])
def test_a_steady_publisher_is_on_time_whatever_its_phase(offset):
    rng = np.random.default_rng(23)
    t0 = 1_700_000_000 * 10**9 + 12_345
    jitter = rng.uniform(0.0, 0.4, 5000)  # up to 0.4 periods after the cycle's start
    times = [t0 + int((k + offset + j) * PERIOD) for k, j in enumerate(jitter)]
    result = bench.on_time(times, PERIOD)
    assert result["slots"] == 5000 and result["on_time"] == 5000 and result["fraction"] == 1.0
    assert result["phase_bin_share"] == 0.0


def test_late_and_skipped_cycles_are_counted_late():
    rng = np.random.default_rng(24)
    offsets = list(rng.uniform(0.1, 0.3, 5000))
    offsets[1000] = 1.6  # published in the next cycle's period: cycle 1000 was late
    offsets[3000] = 1.05
    times = [int((k + o) * PERIOD) for k, o in enumerate(offsets) if k != 4000]  # 4000 skipped
    result = bench.on_time(times, PERIOD)
    assert result["slots"] == 5000
    assert result["on_time"] == 5000 - 3
    assert result["fraction"] == pytest.approx(0.9994)


def test_a_long_stall_leaves_every_cycle_it_covers_late():
    times = [k * PERIOD + 200_000 for k in range(2000)]
    # a 30 ms stall: cycles 500..529 are published together at its end, after cycle 530's start
    times = [t if not 500 <= k < 530 else 530 * PERIOD + 250_000 + k for k, t in enumerate(times)]
    result = bench.on_time(times, PERIOD)
    assert result["slots"] == 2000 and result["on_time"] == 2000 - 30


def test_latency_summary_splits_node_and_transport():
    found = [(0, 400_000 + k, 600_000 + 2 * k) for k in range(101)]
    s = bench.summarize_latency(found)
    assert s["count"] == 101
    assert s["median_ms"] == pytest.approx(0.6001)
    assert s["to_publish_median_ms"] == pytest.approx(0.40005)
    assert s["transport_median_ms"] == pytest.approx(0.20005)


def test_unanswered_twists_count_as_the_slowest():
    found = [(0, 300_000, 500_000)] * 97
    s = bench.summarize_latency(found, unanswered=3)
    assert s["count"] == 97 and s["unanswered"] == 3
    assert s["median_ms"] == pytest.approx(0.5)
    assert s["p99_ms"] == float("inf") and s["max_ms"] == float("inf")
    assert s["to_publish_p99_ms"] == pytest.approx(0.3)  # of the answered
    assert s["out_median_ms"] == pytest.approx(0.3) and s["out_p99_ms"] == float("inf")
    assert bench.summarize_latency(found)["p99_ms"] == pytest.approx(0.5)


def test_node_counts_over_the_window_only():
    statuses = [
        (100, {"cycles": "1000", "late_cycles": "7", "lost_periods": "1"}),
        (200, {"code": "9"}),  # a status without the counters (not from the node's loop)
        (300, {"cycles": "1500", "late_cycles": "9", "lost_periods": "1"}),
        (400, {"cycles": "2500", "late_cycles": "12", "lost_periods": "3"}),
        (900, {"cycles": "9000", "late_cycles": "99", "lost_periods": "9"}),  # after the window
    ]
    counts = bench.node_counts(statuses, 250, 500)
    assert counts == {"cycles": 1500, "late_cycles": 5, "lost_periods": 2}
    assert bench.node_counts(statuses, 500, 800) == {}
    # no status before the window: counted from the node's start
    assert bench.node_counts(statuses, 50, 150) == {
        "cycles": 1000,
        "late_cycles": 7,
        "lost_periods": 1,
    }


def _latency(out_median, out_p99=1.5, median=9.0, p99=90.0):
    """A phase's latency figures: out (to the node's publication), judged; at the receiver,
    shown only (far past every target here, so that a verdict that read them would fail)."""
    return {"out_median_ms": out_median, "out_p99_ms": out_p99, "median_ms": median, "p99_ms": p99}


RESULTS = {
    "echo, alone": {"latency": _latency(0.5)},
    "echo, beside the servo": {"latency": _latency(0.6)},
    "servo, command to joint command": {"latency": _latency(0.9, 3.0)},
    "servo, 1 kHz streaming": {"on_time": {"fraction": 0.9995, "slots": 20000, "on_time": 19990}},
}


def _verdicts(results):
    return {target: met for target, _, met in bench.target_checks(results)}


def test_every_node_target_is_judged_and_met_when_within():
    verdicts = _verdicts(RESULTS)
    assert len(verdicts) == 4 and all(verdicts.values()), verdicts


@pytest.mark.parametrize(
    ("phase", "path", "value", "target"),
    [
        ("servo, 1 kHz streaming", ("on_time", "fraction"), 0.9989, "99.9 %"),
        ("servo, command to joint command", ("latency", "out_median_ms"), 1.01, "2× the bare"),
        ("servo, command to joint command", ("latency", "out_p99_ms"), 5.01, "p99 ≤ 5 ms"),
        ("echo, alone", ("latency", "out_median_ms"), 0.44, "(echo, alone)"),
        ("echo, beside the servo", ("latency", "out_median_ms"), 0.44, "(echo, beside the servo)"),
    ],
)
def test_a_figure_past_its_target_fails_that_target_only(phase, path, value, target):
    results = copy.deepcopy(RESULTS)
    results[phase][path[0]][path[1]] = value
    failed = [t for t, met in _verdicts(results).items() if not met]
    assert len(failed) == 1 and target in failed[0], failed


def test_without_the_echo_the_ratio_is_not_judged():
    results = {k: v for k, v in RESULTS.items() if not k.startswith("echo")}
    verdicts = _verdicts(results)
    assert not any("echo" in t for t in verdicts) and len(verdicts) == 2


def test_the_node_s_own_count_of_cycles_on_time():
    counts = {"cycles": 29_000, "late_cycles": 20, "lost_periods": 10}
    assert bench.node_on_time(counts) == pytest.approx((29_000 - 20) / 29_010)
    results = {"servo, 1 kHz streaming, unobserved": {"node_counts": counts}}
    (target, measured, met) = bench.target_checks(results)[0]
    assert "own count" in target and not met and "20 late, 10 periods lost" in measured
    counts = {"cycles": 29_000, "late_cycles": 20, "lost_periods": 0}
    assert bench.target_checks(
        {
            "servo, 1 kHz streaming": {
                "node_counts": counts,
                **{"on_time": {"fraction": 1.0, "slots": 1, "on_time": 1}},
            }
        }
    )[1][2]  # 99.93 %: met


def test_each_scheduling_setting_is_judged_on_its_own_with_its_own_echo():
    a, b = " [default scheduling]", " [SCHED_FIFO servo 40, sim_arm 50]"
    results = {"echo, alone": RESULTS["echo, alone"]}
    for suffix, median in ((a, 1.2), (b, 0.9)):  # 2.4× and 1.8× the echo beside at 0.5 ms
        results["echo, beside the servo" + suffix] = {"latency": _latency(0.5)}
        results["servo, command to joint command" + suffix] = {"latency": _latency(median, 3.0)}
        results["servo, 1 kHz streaming" + suffix] = RESULTS["servo, 1 kHz streaming"]
    verdicts = _verdicts(results)
    assert len(verdicts) == 8
    for target, met in verdicts.items():
        assert (a in target) != (b in target), target  # every target names its setting
        if "beside" in target:
            assert ("echo, beside the servo" + (a if a in target else b)) in target
            assert met == (b in target)


def test_scheduling_settings_parse_and_are_named():
    assert bench.parse_scheduling("0:0,40:50") == [(0, 0), (40, 50)]
    assert bench.parse_scheduling("30") == [(30, 30)]
    with pytest.raises(ValueError, match="0-99"):
        bench.parse_scheduling("0:100")
    assert bench.setting_name((0, 0)) == "default scheduling"
    assert bench.setting_name((40, 0)) == "SCHED_FIFO servo 40, sim_arm off"


def test_the_longest_timer_callback_is_the_windows_own():
    statuses = [
        (100, {"cycles": "10", "late_cycles": "0", "lost_periods": "0", "step_us_max": "9000"}),
        (300, {"cycles": "20", "late_cycles": "1", "lost_periods": "0", "step_us_max": "120"}),
        (400, {"cycles": "30", "late_cycles": "1", "lost_periods": "0", "step_us_max": "1500"}),
    ]
    assert bench.node_counts(statuses, 250, 500)["step_us_max"] == 1500


def test_the_peers_figures_are_context_for_their_own_setting_only():
    """The bare rclpy ticker (beside and into the sim arm) and the loop without ROS: shown in the
    99.9 % line of the same setting, never a target of their own, whatever their figure."""
    a, b = " [default scheduling]", " [SCHED_FIFO servo 40, sim_arm 50]"
    results = {}
    for suffix, ticker, sleeper in ((a, 0.9871, 0.9902), (b, 0.9993, 0.9998)):
        results["servo, 1 kHz streaming" + suffix] = RESULTS["servo, 1 kHz streaming"]
        results[bench.TICKER_LABEL + suffix] = {
            "on_time": {"fraction": ticker, "slots": 10_000, "on_time": round(ticker * 10_000)}
        }
        results[bench.TICKER_ARM_LABEL + suffix] = {
            "on_time": {"fraction": ticker - 0.01, "slots": 10_000, "on_time": 0}
        }
        results[bench.SLEEPER_LABEL + suffix] = {
            "on_time": {"fraction": sleeper, "slots": 10_000, "on_time": round(sleeper * 10_000)}
        }
    checks = bench.target_checks(results)
    assert len(checks) == 2 and all(met for _, _, met in checks)  # the servo's 99.95 %, twice
    by_setting = {(a if a in target else b): measured for target, measured, _ in checks}
    assert "ticker beside the sim arm: 98.710 % (129 of 10000 late)" in by_setting[a]
    assert "no ROS beside the sim arm: 99.020 % (98 of 10000 late)" in by_setting[a]
    assert "the ticker into the sim arm: 97.710 %" in by_setting[a]
    assert "99.930 %" in by_setting[b] and "98.710 %" not in by_setting[b]
    # the servo's own figure comes first, and decides the verdict
    assert by_setting[a].startswith("99.950 % (10 of 20000 late)")
    results["servo, 1 kHz streaming" + b] = {
        "on_time": {"fraction": 0.998, "slots": 1000, "on_time": 998}
    }
    verdicts = _verdicts(results)
    assert [b in t for t, met in verdicts.items() if not met] == [True]


def test_the_sleeper_skips_the_grid_points_it_missed():
    period = PERIOD
    rng = np.random.default_rng(25)
    deadline = 7 * period + 123
    for late in rng.uniform(0.0, 5.0, 200):
        now = deadline + int(late * period)
        following = bench.next_deadline(deadline, now, period)
        assert (following - deadline) % period == 0 and following > deadline  # on its grid
        assert now <= following < now + period  # the first point not yet past
        deadline = following


def test_the_sleeper_window_leaves_out_the_warm_up():
    wakes = [5 * MS + k * PERIOD for k in range(3000)]
    window = bench.sleeper_window(wakes, 1.0, 1.5)
    assert window[0] == wakes[0] + 1000 * PERIOD and window[-1] == wakes[0] + 2500 * PERIOD
    assert bench.sleeper_window([], 1.0, 1.5) == []


def test_a_fraction_just_below_the_target_does_not_print_as_the_target():
    """Two decimals printed 3977 of 3981 cycles on time (99.8995 %) as "99.90 %" beside a verdict
    of not met; three keep the figure and the verdict apart."""
    text = bench._on_time_text({"fraction": 3977 / 3981, "slots": 3981, "on_time": 3977})
    assert text == "99.899 % (4 of 3981 late)"
    assert bench._on_time_text({"fraction": 0.999, "slots": 1000, "on_time": 999}).startswith(
        "99.900 %"
    )  # exactly the target prints as the target
