"""The servo node at 1 kHz with the simulated arm, side by side with a bare rclpy echo node, in one
run (issue 23, "What must hold": the node's speed).

    make ros && . build/ros/env.sh
    python -W ignore benchmarks/servo_node_benchmark.py [--seconds 30] [--json out.json]
        [--scheduling 0:0,40:50]

Every process is real rclpy over Fast DDS on loopback, in a ROS_DOMAIN_ID of the run's own.
Phases, one after the other:

* echo, alone: a bare rclpy node (rclpy's SingleThreadedExecutor; the floor a node on rclpy's
  stock executor pays) that answers each TwistStamped on /servo/delta_twist_cmds at once with a
  Float64MultiArray on /forward_position_controller/commands carrying the twist's stamp; same QoS
  as the servo node (commands in best effort, depth 10; joint commands out reliable, depth 10);
* servo, command to joint command: the `sim_arm` (UR5e, joint_states at 1 kHz, taking position
  commands as ros2_control's forward_position_controller) and the `servo` node (period 1 ms,
  command timeout `TRIAL_TIMEOUT_S`), both as built by `make ros`; a sender process sends one
  small twist
  (1 mm/s, alternately ±x) every `TRIAL_SPACING_S`, each stamped with its send time; between two
  the command times out and the arm comes to rest (the servo's joint commands stop changing). The
  latency of a twist is the arrival of the first joint command that differs from the one held
  before it, minus the twist's send time (`response_latencies`); the echo gets the same twists
  (`echo_latencies`), once alone and once beside the servo (on topics of its own, each twist sent
  to both, in turns first: the same machine load for both, which on a shared machine moves
  between phases). Split into: until the node published it (DDS's source timestamp) and from
  there to the receiver. A twist that gets no answer counts as slower than any (the servo
  refuses a twist older than its timeout when it takes it: under load that is the slow tail);
  one sent while the arm still moved is not counted (the harness's, not the node's);
* servo, 1 kHz streaming: the same two nodes (command timeout 0.1 s, the default), a twist every
  10 ms (a joystick's rate) moving the tool back and forth at 5 cm/s: the servo publishes every
  period. A cycle is on time when its joint command is published (source timestamp) within the
  period that starts at its scheduled time (`on_time`: the schedule is the node's 1 ms grid, its
  phase read from the publication times); the node's own count of late cycles (its ~/status:
  a timer callback that began a period or more after its tick, so that the timer skipped
  ticks) is reported beside it;
* ticker, the servo's peer at 1 kHz: the same phase with a bare rclpy node in the servo's place
  (`role_ticker`: a 1 ms timer publishing a 6-value Float64MultiArray, reliable depth 10, on
  /ticker/commands; subscribed to /joint_states and to the twists, doing nothing with them; the
  servo's executor, timer, thread_priority and frozen heap), the sender and the receiver as in
  the streaming phase, judged with the same `on_time`: what any rclpy node publishing at 1 kHz
  beside sim_arm holds on this machine; and once more publishing HOME on the servo's command
  topic instead ("into the sim arm"): sim_arm then takes its 1 kHz commands, as it takes the
  servo's, so that each publication is a reliable write to sim_arm's reader too (and wakes its
  higher-priority threads), as the servo's is;
* sleeper, the floor without ROS: sim_arm and a plain Python loop sleeping to a 1 ms grid at the
  servo's priority (`role_sleeper`), its wake-ups judged with `on_time` (no sender or receiver:
  a little less load than the phases above).

Scheduling, A/B in one run (`--scheduling`, pairs servo:sim_arm of the nodes' `thread_priority`):
every servo phase runs once per setting, the settings in turns phase by phase (trials A, trials
B, streaming A, streaming B, ticker A, ticker B, ...), and every figure's label says its
setting: "default scheduling" (0:0, both nodes SCHED_OTHER) or "SCHED_FIFO servo 40, sim_arm 50"
(moveit_servo's and ros2_control's controller_manager's defaults); the ticker and the sleeper
take the servo's priority. The echo nodes, the sender and the receiver always run with the default scheduling:
the echo is the bare rclpy node the target compares with.

A receiver process (on our LeanExecutor, as in node_benchmark.py, so that the harness itself stays
light on a 2-core machine) records every joint command with its source timestamp and arrival.
All clocks are CLOCK_REALTIME on one machine. The first second of each phase is warm-up. CPU of
the nodes [% of one core] from /proc. Last, the issue's targets with their figures and whether
each is met (`target_checks`). Run it on a quiet machine: every figure is shared-CPU sensitive (each phase reports the machine's
load average before and after it, the harness's own processes included).
"""

from __future__ import annotations

import argparse
import bisect
import json
import math
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
import node_benchmark as nb  # noqa: E402  (the harness pieces: rclpy set-up, /proc readers)

from kinematics_node.ros.env import (  # noqa: E402
    clean_dead_shared_memory,
    executable,
    local_ros_env,
    unavailable_reason,
)
from kinematics_node.ros.processes import start_node, stop_nodes  # noqa: E402

ROBOT = ROOT / "config" / "robots" / "ur5e.urdf"
HOME = (0.3, -1.3, 1.6, -1.9, 1.2, 0.4)  # [rad] well inside the limits, away from singularities
TWIST_TOPIC = "/servo/delta_twist_cmds"
COMMAND_TOPIC = "/forward_position_controller/commands"
ECHO_TWIST_TOPIC = "/echo/delta_twist_cmds"  # the echo beside the servo: topics of its own
ECHO_COMMAND_TOPIC = "/echo/commands"
STATUS_TOPIC = "/servo/status"
TICKER_TOPIC = "/ticker/commands"  # the bare ticker's joint-command-like output (its own topic)
PERIOD_S = 0.001
TRIAL_TIMEOUT_S = 0.02  # the servo's command timeout in the trials
TRIAL_SPACING_S = 0.07  # the arm is at rest ~42 ms after a one-shot twist with a 20 ms timeout
TRIAL_SPEED_M_S = 0.001
STREAM_RATE_HZ = 100.0
STREAM_SPEED_M_S = 0.05
WARM_UP_S = 1.0
TICKER_LABEL = "ticker (bare rclpy), 1 kHz beside the sim arm"
TICKER_ARM_LABEL = "ticker (bare rclpy), 1 kHz into the sim arm"
SLEEPER_LABEL = "sleeper (no ROS), 1 ms grid beside the sim arm"


# ============================================================================ pure helpers
def echo_latencies(
    sends_ns: Sequence[int], outputs: Sequence[tuple[Sequence[float], int, int]]
) -> tuple[list[tuple[int, int, int]], int]:
    """(send, source, arrival) [ns] of each twist the echo answered (its answer carries the
    twist's stamp as [sec, nanosec]), and how many it did not answer."""
    answers: dict[int, tuple[int, int]] = {}
    for data, source, arrival in outputs:
        if len(data) >= 2:
            answers.setdefault(int(data[0]) * 1_000_000_000 + int(data[1]), (source, arrival))
    found = [(s, *answers[s]) for s in sends_ns if s in answers]
    return found, len(sends_ns) - len(found)


def response_latencies(
    sends_ns: Sequence[int],
    outputs: Sequence[tuple[Sequence[float], int, int]],
    period_ns: int,
) -> tuple[list[tuple[int, int, int]], dict[str, int]]:
    """(send, source, arrival) [ns] of the servo's first response to each twist in `sends_ns`
    (sorted), from its joint commands `outputs` (data, source timestamp, arrival) in order of
    publication.

    The response to a twist sent at s is the first joint command published after s that
    differs from the last one published before s (the arm at rest holds one position: every
    hold command is the same, and the first step of a new motion moves it). A twist sent while
    the arm was still moving (the two commands before s differ, the last within 2 periods of s)
    is not counted ("moving"); one with no changed command before the next twist is
    "unanswered". Returns the responses and those two counts."""
    out = sorted(outputs, key=lambda o: o[1])
    sources = [o[1] for o in out]
    found: list[tuple[int, int, int]] = []
    counts = {"moving": 0, "unanswered": 0}
    for i, s in enumerate(sends_ns):
        end = sends_ns[i + 1] if i + 1 < len(sends_ns) else math.inf
        k = bisect.bisect_left(sources, s)  # out[k:] were published after the send
        if k == 0:
            counts["unanswered"] += 1
            continue
        held = list(out[k - 1][0])
        if k >= 2 and list(out[k - 2][0]) != held and s - sources[k - 1] < 2 * period_ns:
            counts["moving"] += 1
            continue
        for data, source, arrival in out[k:]:
            if source >= end:
                counts["unanswered"] += 1
                break
            if list(data) != held:
                found.append((s, source, arrival))
                break
        else:
            counts["unanswered"] += 1
    return found, counts


def on_time(publish_ns: Sequence[int], period_ns: int, bins: int = 50) -> dict[str, float]:
    """How many cycles of a periodic publisher were on time, from its publication times.

    The schedule is a grid t_k = t_0 + k·period whose phase is not visible from outside; a
    publication belongs to the slot [t_k, t_k + period) it falls in, and a slot with at least one
    publication is a cycle on time (a late cycle leaves its own slot empty and doubles up in a
    later one). The grid's phase is put where publications are rarest (the emptiest of `bins`
    phase bins of the period, its start): right before the cluster of on-time publications, so a
    publication is on time when it comes less than one period after the start of that cluster.
    Returns the slots, those on time, their fraction, and the phase's bin occupancy (the share of
    publications in the emptiest bin: near 0 when the grid is well defined)."""
    times = sorted(publish_ns)
    if len(times) < 2:
        return {"slots": 0, "on_time": 0, "fraction": math.nan, "phase_bin_share": math.nan}
    origin = times[0]
    width = period_ns / bins
    counts = [0] * bins
    for t in times:
        counts[int(((t - origin) % period_ns) // width)] += 1
    emptiest = min(range(bins), key=lambda b: (counts[b], b))
    t0 = origin + emptiest * width - period_ns  # a grid line at or before the first publication
    slots = {int((t - t0) // period_ns) for t in times}
    first, last = min(slots), max(slots)
    total = last - first + 1
    return {
        "slots": total,
        "on_time": len(slots),
        "fraction": len(slots) / total,
        "phase_bin_share": counts[emptiest] / len(times),
    }


def sleeper_window(wakes_ns: Sequence[int], skip_s: float, length_s: float) -> list[int]:
    """The wake-ups [ns] from `skip_s` after the first one, for `length_s` (the warm-up left
    out, and the window as long as a streaming phase's)."""
    if not wakes_ns:
        return []
    start = wakes_ns[0] + int(skip_s * 1e9)
    end = start + int(length_s * 1e9)
    return [t for t in wakes_ns if start <= t <= end]


def next_deadline(deadline_ns: int, now_ns: int, period_ns: int) -> int:
    """The sleeper's next wake-up after serving `deadline_ns` at `now_ns`: the first point of its
    grid (deadline + k·period, k ≥ 1) not already past; the points a late wake-up missed are
    skipped, as rcl's timer skips ticks."""
    return deadline_ns + period_ns * max(1, -(-(now_ns - deadline_ns) // period_ns))


def summarize_latency(
    found: Sequence[tuple[int, int, int]], unanswered: int = 0
) -> dict[str, float]:
    """Median, p99 and max [ms] of send → arrival, the `unanswered` counted as slower than any
    (inf); the median and p99 of send → the node's publication (DDS source timestamp: "out"),
    the unanswered counted likewise; of the part until the node published (answered only) and
    of the rest (source → arrival); the counts."""
    total = [(a - s) * 1e-6 for s, _, a in found] + [math.inf] * unanswered
    inside = [(o - s) * 1e-6 for s, o, _ in found]
    out = inside + [math.inf] * unanswered
    after = [(a - o) * 1e-6 for _, o, a in found]
    return {
        "count": len(found),
        "unanswered": unanswered,
        "median_ms": statistics.median(total) if total else math.nan,
        "p99_ms": nb._percentile(total, 0.99),
        "max_ms": max(total, default=math.nan),
        "out_median_ms": statistics.median(out) if out else math.nan,
        "out_p99_ms": nb._percentile(out, 0.99),
        "to_publish_median_ms": statistics.median(inside) if inside else math.nan,
        "to_publish_p99_ms": nb._percentile(inside, 0.99),
        "transport_median_ms": statistics.median(after) if after else math.nan,
    }


def node_counts(
    statuses: Sequence[tuple[int, dict[str, str]]], start_ns: int, end_ns: int
) -> dict[str, int]:
    """The node's own loop counters (~/status: cycles, late_cycles, lost_periods) over the window
    [start, end] [ns]: the last status before it subtracted from the last one inside it ({} when
    no status carried them in the window); and its longest timer callback in the window
    (step_us_max [µs], where the statuses carry it)."""
    keys = ("cycles", "late_cycles", "lost_periods")
    before = [v for t, v in statuses if t < start_ns and "cycles" in v]
    inside = [v for t, v in statuses if start_ns <= t <= end_ns and "cycles" in v]
    if not inside:
        return {}
    base = before[-1] if before else {k: "0" for k in keys}
    counts = {k: int(inside[-1].get(k, 0)) - int(base.get(k, 0)) for k in keys if k in inside[-1]}
    longest = [
        int(v["step_us_max"]) for t, v in statuses if start_ns <= t <= end_ns and "step_us_max" in v
    ]
    if longest:  # the node's longest timer callback in the window [µs]
        counts["step_us_max"] = max(longest)
    return counts


def node_on_time(counts: dict[str, int]) -> float:
    """The share of periods on time by the node's own counters: its timer callbacks that began
    within a period of their tick, of every period (those the timer skipped and the node did
    not make up included)."""
    periods = counts["cycles"] + counts.get("lost_periods", 0)
    return (counts["cycles"] - counts.get("late_cycles", 0)) / periods if periods else math.nan


def _suffix(label: str, base: str) -> str | None:
    """The setting part of a phase label ("" or " [setting]") when it is `base`'s, else None."""
    if not label.startswith(base):
        return None
    rest = label[len(base) :]
    return rest if rest == "" or rest.startswith(" [") else None


def _on_time_text(figures: dict[str, float]) -> str:
    """'99.119 % (176 of 19999 late)' from `on_time`'s figures: rounded down, so that a
    fraction below a target never prints as the target (3977 of 3981 is 99.899 %, not 99.90)."""
    late = int(figures["slots"] - figures["on_time"])
    return f"{_percent_down(figures['fraction'])} % ({late} of {int(figures['slots'])} late)"


def _percent_down(fraction: float) -> str:
    # (+1e-6: 999 of 1000 is 99899.99999999999 thousandths in floating point)
    return (
        f"{math.floor(100_000 * fraction + 1e-6) / 1000:.3f}" if math.isfinite(fraction) else "nan"
    )


def target_checks(results: dict[str, dict[str, Any]]) -> list[tuple[str, str, bool]]:
    """Issue 23's node targets for the phases in `results`, per scheduling setting (a label's
    " [setting]" suffix): (target, measured, met?). The 99.9 % line carries, as context, the
    figures of the peers measured in the same setting (the bare rclpy ticker, the loop without
    ROS): what any node, or any thread, holds there; they are not targets.

    The latency targets are judged from command in to joint command *out*: the twist's send time
    to the node's publication of its answer (DDS source timestamp), for the servo and the echo
    alike. The arrival at the receiver (shown beside) adds the delivery to the harness's own
    process, which runs with the default scheduling: with the nodes on SCHED_FIFO it waits
    behind them, and the echo beside the servo slows by as much (measured: 3.84 ms median beside
    a FIFO servo against 1.45 alone, its answers published at 2.02), so that part is the
    harness's, not the node's."""
    checks: list[tuple[str, str, bool]] = []
    for label, stream in results.items():
        setting = _suffix(label, "servo, 1 kHz streaming")
        if setting is None or "on_time" not in stream:
            continue
        f = stream["on_time"]["fraction"]
        measured = _on_time_text(stream["on_time"])
        for peer, name in (
            (TICKER_LABEL, "a bare rclpy ticker beside the sim arm"),
            (TICKER_ARM_LABEL, "the ticker into the sim arm"),
            (SLEEPER_LABEL, "no ROS beside the sim arm"),
        ):
            figures = results.get(peer + setting, {}).get("on_time")
            if figures is not None:  # the peers' figures: context, not a target
                measured += f"; {name}: {_on_time_text(figures)}"
        checks.append(
            (
                f"servo at 1 kHz with the sim arm{setting}: ≥ 99.9 % of cycles on time",
                measured,
                f >= 0.999,
            )
        )
    for label, r in results.items():
        counts = r.get("node_counts") or {}
        if "streaming" in label and "cycles" in counts:
            f = node_on_time(counts)
            checks.append(
                (
                    f"{label}: ≥ 99.9 % of cycles on time by the node's own count",
                    f"{_percent_down(f)} % ({counts.get('late_cycles', '?')} late, "
                    f"{counts.get('lost_periods', '?')} periods lost, of {counts['cycles']})",
                    f >= 0.999,
                )
            )
    for label, servo in results.items():
        setting = _suffix(label, "servo, command to joint command")
        if setting is None:
            continue
        lat = servo["latency"]
        median = lat["out_median_ms"]
        for echo_label in ("echo, alone", "echo, beside the servo" + setting):
            echo = results.get(echo_label)
            if echo is None:
                continue
            ratio = median / echo["latency"]["out_median_ms"]
            at_receiver = lat["median_ms"] / echo["latency"]["median_ms"]
            checks.append(
                (
                    f"command in → joint command out{setting}: median ≤ 2× the bare echo's "
                    f"({echo_label})",
                    f"{ratio:.2f}× ({median:.2f} vs {echo['latency']['out_median_ms']:.2f} ms; "
                    f"at the receiver {at_receiver:.2f}×)",
                    ratio <= 2.0,
                )
            )
        p99 = lat["out_p99_ms"]
        checks.append(
            (
                f"command in → joint command out{setting}: p99 ≤ 5 ms",
                f"{p99:.2f} ms (at the receiver {lat['p99_ms']:.2f} ms)",
                p99 <= 5.0,
            )
        )
    return checks


# ============================================================================ child roles
def role_echo(beside: bool) -> None:
    """The bare echo: TwistStamped in, Float64MultiArray [sec, nanosec of its stamp] out, at once
    (rclpy's SingleThreadedExecutor; QoS as the servo node's); `beside` the servo: on topics of
    its own."""
    rclpy = nb._init_rclpy(freeze=False)
    from geometry_msgs.msg import TwistStamped
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64MultiArray

    node = rclpy.create_node("echo_node")
    pub = node.create_publisher(
        Float64MultiArray, ECHO_COMMAND_TOPIC if beside else COMMAND_TOPIC, 10
    )
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=10,
        reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )

    def echo(msg: TwistStamped) -> None:
        out = Float64MultiArray()
        out.data = [float(msg.header.stamp.sec), float(msg.header.stamp.nanosec)]
        pub.publish(out)

    node.create_subscription(TwistStamped, ECHO_TWIST_TOPIC if beside else TWIST_TOPIC, echo, qos)
    nb._spin_until_sigint(node)


def role_ticker(priority: int, into_arm: bool = False) -> None:
    """The bare rclpy peer of the servo's periodic job: a 1 ms timer whose callback publishes a
    6-value Float64MultiArray on TICKER_TOPIC (`into_arm`: HOME on the servo's command topic,
    which sim_arm takes, as it takes the servo's), and nothing else. Built as the servo node is
    (ros/servo.py): the joint-command publisher's QoS (reliable, depth 10) without event
    callbacks; the same subscriptions' load (/joint_states from sim_arm at 1 kHz and the
    sender's twists on /servo/delta_twist_cmds, both taken and dropped), every entity in one
    reentrant callback group; `apply_thread_priority(priority)` once the entities exist (the
    middleware's threads raised with it); the heap frozen; spun by the same entry as the servo
    executable (`spin_until_shutdown`: our LeanExecutor, SIGINT ends it with status 0)."""
    from kinematics_node.ros.env import keep_discovery_local

    keep_discovery_local(int(os.environ["ROS_DOMAIN_ID"]))
    from geometry_msgs.msg import TwistStamped
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from kinematics_node.ros.node_log import log_lines
    from kinematics_node.ros.node_setup import freeze_heap
    from kinematics_node.ros.qos import (
        JOINT_STATES_QOS,
        NO_PUBLISHER_EVENTS,
        NO_SUBSCRIPTION_EVENTS,
    )
    from kinematics_node.ros.realtime import apply_thread_priority
    from kinematics_node.ros.servo import COMMAND_OUT_DEPTH, COMMAND_QOS
    from kinematics_node.ros.spin import spin_until_shutdown

    class Ticker(Node):
        def __init__(self) -> None:
            super().__init__("bench_ticker")
            group = ReentrantCallbackGroup()
            self._pub = self.create_publisher(
                Float64MultiArray,
                COMMAND_TOPIC if into_arm else TICKER_TOPIC,
                COMMAND_OUT_DEPTH,
                event_callbacks=NO_PUBLISHER_EVENTS,
            )
            for msg_type, topic, qos in (
                (JointState, "/joint_states", JOINT_STATES_QOS),
                (TwistStamped, TWIST_TOPIC, COMMAND_QOS),
            ):
                self.create_subscription(
                    msg_type,
                    topic,
                    lambda msg: None,
                    qos,
                    callback_group=group,
                    event_callbacks=NO_SUBSCRIPTION_EVENTS,
                )
            self._values = list(HOME) if into_arm else [0.0] * 6
            self.create_timer(PERIOD_S, self._tick, callback_group=group)
            said = apply_thread_priority(priority)
            log_lines(self.get_logger(), [said] if said is not None else [])
            freeze_heap()

        def _tick(self) -> None:
            msg = Float64MultiArray()  # a new message each cycle, as the servo's
            msg.data = self._values
            self._pub.publish(msg)

    sys.exit(spin_until_shutdown(Ticker, "ticker", ()))


def role_sleeper(priority: int, out: str) -> None:
    """The floor without ROS: a plain Python loop that sleeps to the next point of a 1 ms grid
    (time.sleep to absolute deadlines on the monotonic clock; a deadline already passed is
    skipped, as rcl's timer skips ticks) at SCHED_FIFO `priority` (0: default scheduling), and
    notes each wake-up's CLOCK_REALTIME [ns], until SIGINT; then writes them to `out`."""
    from kinematics_node.ros.realtime import apply_thread_priority

    stopping: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: stopping.append(signum))
    said = apply_thread_priority(priority)
    if said is not None and said[0] != "info":
        print(f"sleeper: {said[1]}", file=sys.stderr)
    nb._no_collections()
    period = int(PERIOD_S * 1e9)
    wakes: list[int] = []
    deadline = time.monotonic_ns() + period
    while not stopping:
        now = time.monotonic_ns()
        if now < deadline:
            time.sleep((deadline - now) * 1e-9)
        wakes.append(time.time_ns())
        deadline = next_deadline(deadline, time.monotonic_ns(), period)
    Path(out).write_text(json.dumps({"wakes": wakes}))


def role_sender(mode: str, seconds: float, out: str, echo: bool) -> None:
    """Twists on /servo/delta_twist_cmds, each stamped with its send time, for `seconds`:
    `mode` "trials": one every TRIAL_SPACING_S; "stream": at STREAM_RATE_HZ, the tool moving back
    and forth along x at STREAM_SPEED_M_S (reversing every 2 s). With `echo`, each twist goes to
    the echo beside the servo too, the same message right after or before (in turns). Writes the
    send times [ns]."""
    rclpy = nb._init_rclpy()
    from geometry_msgs.msg import TwistStamped

    node = rclpy.create_node("bench_twist_sender")
    pubs = [node.create_publisher(TwistStamped, TWIST_TOPIC, 10)]
    if echo:
        pubs.append(node.create_publisher(TwistStamped, ECHO_TWIST_TOPIC, 10))
    while any(pub.get_subscription_count() == 0 for pub in pubs):
        time.sleep(0.01)
    time.sleep(0.5)
    spacing = TRIAL_SPACING_S if mode == "trials" else 1.0 / STREAM_RATE_HZ
    msg = TwistStamped()
    msg.header.frame_id = "base_link"
    stamps: list[int] = []
    start = time.monotonic()
    next_at = start
    k = 0
    nb._no_collections()
    while time.monotonic() - start < seconds:
        now = time.monotonic()
        if now < next_at:
            time.sleep(next_at - now)
        if mode == "trials":
            msg.twist.linear.x = TRIAL_SPEED_M_S * (1.0 if k % 2 == 0 else -1.0)
        else:
            sign = 1.0 if int((next_at - start) // 2.0) % 2 == 0 else -1.0
            msg.twist.linear.x = STREAM_SPEED_M_S * sign
        ns = time.time_ns()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
        for pub in pubs if k % 2 == 0 else pubs[::-1]:
            pub.publish(msg)
        stamps.append(ns)
        k += 1
        next_at += spacing
    Path(out).write_text(json.dumps({"stamps": stamps}))
    node.destroy_node()
    rclpy.shutdown()


def role_receiver(
    out: str, status: bool, echo: bool, commands: bool = True, topic: str = COMMAND_TOPIC
) -> None:
    """Records (data, source timestamp, arrival) of every joint command (on `topic`: the
    ticker's, for its phase), with `echo` those of the echo beside the servo, and with `status`
    the servo's ~/status values with their arrival, until SIGINT (not `commands`: only the
    status); writes `<out>.ready` once matched."""
    stopping: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: stopping.append(signum))
    rclpy = nb._init_rclpy(rclpy_signals=False)
    from diagnostic_msgs.msg import DiagnosticStatus
    from rclpy.qos import QoSProfile
    from std_msgs.msg import Float64MultiArray

    from kinematics_node.ros.executor import LeanExecutor

    node = rclpy.create_node("bench_command_receiver")
    got: list[tuple[list[float], int, int]] = []
    got_echo: list[tuple[list[float], int, int]] = []
    statuses: list[tuple[int, dict[str, str]]] = []

    def recorder(bucket: list[tuple[list[float], int, int]]) -> Any:
        def record(msg: Any, info: Any) -> None:  # (two parameters: rclpy passes MessageInfo)
            bucket.append((list(msg.data), info["source_timestamp"], time.time_ns()))

        return record

    def on_status(msg: Any) -> None:
        statuses.append((time.time_ns(), {kv.key: kv.value for kv in msg.values}))

    deep = QoSProfile(depth=1000)
    subs = []
    if commands:
        subs.append(node.create_subscription(Float64MultiArray, topic, recorder(got), deep))
    if echo:
        subs.append(
            node.create_subscription(
                Float64MultiArray, ECHO_COMMAND_TOPIC, recorder(got_echo), deep
            )
        )
    if status:
        subs.append(node.create_subscription(DiagnosticStatus, STATUS_TOPIC, on_status, 100))
    executor = LeanExecutor()
    executor.add_node(node)
    nb._no_collections()
    stalls = nb._StallWatch()
    ready = False
    while not stopping:
        executor.spin_once(timeout_sec=0.05)
        if not ready and all(sub.get_publisher_count() > 0 for sub in subs):
            Path(out + ".ready").touch()
            ready = True
    Path(out).write_text(
        json.dumps(
            {
                "outputs": got,
                "echo_outputs": got_echo,
                "statuses": statuses,
                "worst_stall": stalls.worst,
            }
        )
    )
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown()


# ============================================================================ orchestration
def _child(args: list[str], env: dict[str, str]) -> subprocess.Popen:
    python = os.environ.get("KINEMATICS_ROS_PYTHON") or sys.executable
    return subprocess.Popen(
        [python, "-X", "faulthandler", "-W", "ignore", __file__, *args], env=env
    )


def _cpu_percent(
    measured: dict[str, subprocess.Popen[Any]], wait: Callable[[], object]
) -> dict[str, float]:
    """CPU of each measured process [% of one core] while `wait()` runs (the phase's window)."""
    cpu0 = {name: nb._cpu_seconds(p.pid) for name, p in measured.items()}
    wall0 = time.monotonic()
    wait()
    wall = time.monotonic() - wall0
    return {
        name: 100.0 * (nb._cpu_seconds(p.pid) - cpu0[name]) / wall for name, p in measured.items()
    }


def _start_sim_arm(
    description: str, priority: int, directory: Path, env: dict[str, str]
) -> subprocess.Popen[bytes]:
    """sim_arm at 1 kHz taking position commands, from HOME, at SCHED_FIFO `priority` (0: none)."""
    return start_node(
        "sim_arm",
        {
            "robot_description": description,
            "tip_link": "tool0",
            "rate": 1.0 / PERIOD_S,
            "command_mode": "position",
            "initial_positions": list(HOME),
            "thread_priority": priority,
        },
        directory,
        env,
    )


def run_phase(
    kind: str,
    seconds: float,
    env: dict[str, str],
    directory: Path,
    priorities: tuple[int, int] = (0, 0),
) -> dict[str, dict[str, Any]]:
    """One phase: `kind` "echo" (alone), "trials" (the servo, command to joint command, with the
    echo beside it), "stream" (the servo at 1 kHz), "unobserved" (the same, with the receiver
    taking only the servo's ~/status: the node's own count, without the receiver's 1 kHz load),
    "ticker" (the bare rclpy ticker in the servo's place, everything else as in "stream"),
    "ticker_arm" (the same, publishing into sim_arm's command topic) or
    "sleeper" (`run_sleeper_phase`); `priorities`: the thread_priority of the servo (and of the
    ticker or the sleeper in its place) and of the sim_arm. Returns {label: figures} (labels
    without the setting: `main` adds it)."""
    if kind == "sleeper":
        return run_sleeper_phase(seconds, env, directory, priorities)
    description = ROBOT.read_text(encoding="utf-8")
    if kind == "echo":
        system = [_child(["--role", "echo"], env)]
        measured = {"echo": system[0]}
    else:
        timeout = TRIAL_TIMEOUT_S if kind == "trials" else 0.1
        sim = _start_sim_arm(description, priorities[1], directory, env)
        servo = (
            _child(
                ["--role", "ticker", "--priority", str(priorities[0])]
                + (["--into-arm"] if kind == "ticker_arm" else []),
                env,
            )
            if kind in ("ticker", "ticker_arm")
            else start_node(
                "servo",
                {
                    "robot_description": description,
                    "tip_link": "tool0",
                    "period_s": PERIOD_S,
                    "command_timeout_s": timeout,
                    "thread_priority": priorities[0],
                },
                directory,
                env,
            )
        )
        system = [sim, servo]
        measured = {"ticker" if kind.startswith("ticker") else "servo": servo, "sim_arm": sim}
        if kind == "trials":
            system.append(_child(["--role", "echo", "--beside"], env))
            measured["echo"] = system[-1]
    try:
        time.sleep(4.0)  # start-up (URDF parse, discovery) is not what this measures
        for p in system:
            if p.poll() is not None:
                raise nb.HarnessFailure(f"a node of phase {kind} exited at start-up")
        recv_out, send_out = directory / f"{kind}-recv.json", directory / f"{kind}-send.json"
        ready = Path(str(recv_out) + ".ready")
        for path in (recv_out, send_out, ready):
            path.unlink(missing_ok=True)
        flags = (
            ([] if kind in ("echo", "ticker", "ticker_arm") else ["--status"])
            + (["--ticker"] if kind == "ticker" else [])
            + (["--beside"] if kind == "trials" else [])
        )
        flags += ["--status-only"] if kind == "unobserved" else []
        receiver = _child(["--role", "receiver", "--out", str(recv_out), *flags], env)
        deadline = time.monotonic() + 20.0
        while not ready.exists():
            if time.monotonic() > deadline or receiver.poll() is not None:
                receiver.kill()
                raise nb.HarnessFailure("the receiver did not match the node's publishers in 20 s")
            time.sleep(0.05)
        mode = "stream" if kind in ("stream", "unobserved", "ticker", "ticker_arm") else "trials"
        beside = ["--beside"] if kind == "trials" else []
        sender = _child(
            ["--role", "sender", "--mode", mode, "--seconds", str(seconds), "--out", str(send_out)]
            + beside,
            env,
        )
        time.sleep(0.5)
        cpu_percent = _cpu_percent(measured, sender.wait)
        time.sleep(0.5)
        receiver.send_signal(signal.SIGINT)
        receiver.wait(30)
        for role, process, out in (("sender", sender, send_out), ("receiver", receiver, recv_out)):
            if process.returncode != 0 or not out.exists():
                raise nb.HarnessFailure(f"the {role} failed (exit code {process.returncode})")
    finally:
        stop_nodes(system)
    sends = json.loads(send_out.read_text())["stamps"]
    got = json.loads(recv_out.read_text())
    outputs = [(data, source, arrival) for data, source, arrival in got["outputs"]]
    first = sends[0] + int(WARM_UP_S * 1e9) if sends else 0
    counted = [s for s in sends if s >= first]
    result: dict[str, Any] = {
        "twists_sent": len(counted),
        "cpu_percent": cpu_percent,
        "receiver_worst_stall_ms": float(got.get("worst_stall", math.nan)) * 1e3,
        "node_counts": node_counts(got.get("statuses", []), first, sends[-1] if sends else 0),
    }
    if kind == "echo":
        found, unanswered = echo_latencies(counted, outputs)
        result["latency"] = summarize_latency(found, unanswered)
        return {"echo, alone": result}
    if kind == "trials":
        found, counts = response_latencies(counted, outputs, int(PERIOD_S * 1e9))
        result["latency"] = summarize_latency(found, counts["unanswered"])
        result["sent_while_moving"] = counts["moving"]
        echo_outputs = [(d, src, arr) for d, src, arr in got["echo_outputs"]]
        found, unanswered = echo_latencies(counted, echo_outputs)
        beside = {k: v for k, v in result.items() if k not in ("latency", "sent_while_moving")}
        beside["cpu_percent"] = {"echo": result["cpu_percent"].pop("echo")}
        beside["latency"] = summarize_latency(found, unanswered)
        beside["node_counts"] = {}
        return {"servo, command to joint command": result, "echo, beside the servo": beside}
    if kind == "unobserved":
        return {"servo, 1 kHz streaming, unobserved": result}
    window = [src for _, src, _ in outputs if first <= src <= counted[-1]]
    result["on_time"] = on_time(window, int(PERIOD_S * 1e9))
    result["joint_commands"] = len(window)
    labels = {"ticker": TICKER_LABEL, "ticker_arm": TICKER_ARM_LABEL}
    return {labels.get(kind, "servo, 1 kHz streaming"): result}


def run_sleeper_phase(
    seconds: float, env: dict[str, str], directory: Path, priorities: tuple[int, int]
) -> dict[str, dict[str, Any]]:
    """The floor without ROS: sim_arm (thread_priority `priorities[1]`) and the sleeper
    (`role_sleeper`, at the servo's `priorities[0]`) for `seconds` after the start-up; no sender
    and no receiver (nothing to send to, nothing published), so the machine carries less than in
    the other phases. Its wake-ups after the warm-up are judged with `on_time`."""
    sim = _start_sim_arm(ROBOT.read_text(encoding="utf-8"), priorities[1], directory, env)
    out = directory / "sleeper.json"
    out.unlink(missing_ok=True)
    system = [sim]
    try:
        time.sleep(4.0)  # sim_arm's start-up, as in the other phases
        if sim.poll() is not None:
            raise nb.HarnessFailure("sim_arm exited at start-up")
        sleeper = _child(
            ["--role", "sleeper", "--priority", str(priorities[0]), "--out", str(out)], env
        )
        system.append(sleeper)
        time.sleep(0.5)
        measured = {"sleeper": sleeper, "sim_arm": sim}
        # the window (`sleeper_window`) ends before this does
        cpu_percent = _cpu_percent(measured, lambda: time.sleep(seconds + 0.5))
        sleeper.send_signal(signal.SIGINT)
        sleeper.wait(30)
        if sleeper.returncode != 0 or not out.exists():
            raise nb.HarnessFailure(f"the sleeper failed (exit code {sleeper.returncode})")
    finally:
        stop_nodes(system)
    wakes = json.loads(out.read_text())["wakes"]
    window = sleeper_window(wakes, WARM_UP_S, seconds - WARM_UP_S)
    return {
        SLEEPER_LABEL: {
            "twists_sent": 0,
            "cpu_percent": cpu_percent,
            "receiver_worst_stall_ms": math.nan,
            "node_counts": {},
            "on_time": on_time(window, int(PERIOD_S * 1e9)),
            "joint_commands": len(window),
            "counted_as": "wake-ups",
        }
    }


PHASES = (
    ("echo, alone", "echo"),
    ("servo and the echo beside it, command to joint command", "trials"),
    ("servo, 1 kHz streaming", "stream"),
    (TICKER_LABEL, "ticker"),
    (TICKER_ARM_LABEL, "ticker_arm"),
    (SLEEPER_LABEL, "sleeper"),
    ("servo, 1 kHz streaming, unobserved (its own count only)", "unobserved"),
)


def setting_name(priorities: tuple[int, int]) -> str:
    """How a phase label names a scheduling setting (servo, sim_arm thread_priority)."""
    servo, sim = priorities
    if servo == sim == 0:
        return "default scheduling"
    return f"SCHED_FIFO servo {servo or 'off'}, sim_arm {sim or 'off'}"


def parse_scheduling(text: str) -> list[tuple[int, int]]:
    """'0:0,40:50' -> [(0, 0), (40, 50)] (servo:sim_arm thread_priority pairs)."""
    settings = []
    for item in text.split(","):
        servo, _, sim = item.strip().partition(":")
        pair = (int(servo), int(sim or servo))
        if not all(0 <= p <= 99 for p in pair):
            raise ValueError(f"--scheduling: priorities are 0-99, got {item!r}")
        settings.append(pair)
    return settings


def report(results: dict[str, dict[str, Any]]) -> None:
    print(
        "| phase | twists | latency median / p99 / max [ms] | to publish median / p99 [ms] | CPU [% core] |"
    )
    print("|---|---|---|---|---|")
    for label, r in results.items():
        lat = r.get("latency")
        cpu = ", ".join(f"{k} {v:.0f}" for k, v in r["cpu_percent"].items())
        if lat is None:
            cells = "—", "—"
        else:
            cells = (
                f"{lat['median_ms']:.2f} / {lat['p99_ms']:.2f} / {lat['max_ms']:.2f} "
                f"({lat['count']} answered)",
                f"{lat['to_publish_median_ms']:.2f} / {lat['to_publish_p99_ms']:.2f}",
            )
        print(f"| {label} | {r['twists_sent']} | {cells[0]} | {cells[1]} | {cpu} |")
    print()
    for label, r in results.items():
        lat = r.get("latency")
        if lat is not None and lat["unanswered"]:
            print(f"{label}: {lat['unanswered']} twists unanswered (counted as slower than any)")
        if r.get("sent_while_moving"):
            print(
                f"{label}: {r['sent_while_moving']} twists sent while the arm still moved (not counted)"
            )
        if "on_time" in r:
            o = r["on_time"]
            print(
                f"{label}: {r['joint_commands']} {r.get('counted_as', 'joint commands')}; "
                f"{o['on_time']} of {o['slots']} 1 ms cycles on time ({100 * o['fraction']:.2f} %; the emptiest phase bin holds "
                f"{100 * o['phase_bin_share']:.3f} % of them)"
            )
        counts = r.get("node_counts") or {}
        if counts:
            print(
                f"{label}: the node's own count (~/status) over the phase: {counts['cycles']} "
                f"cycles, {counts.get('late_cycles', '?')} late (timer callback a period or "
                f"more after its tick), {counts.get('lost_periods', '?')} periods not made up; "
                f"its longest timer callback {counts.get('step_us_max', '?')} µs"
            )
        stall = r["receiver_worst_stall_ms"]
        print(
            f"{label}: "
            + (
                ""
                if math.isnan(stall)
                else f"the receiver's own process stalled up to {stall:.0f} ms; "
            )
            + f"the machine's load average {r['load_average'][0]:.1f} before the phase, "
            f"{r['load_average'][1]:.1f} after"
        )
    checks = target_checks(results)
    if checks:
        print()
        print("| issue 23's target | measured | met |")
        print("|---|---|---|")
        for target, measured, met in checks:
            print(f"| {target} | {measured} | {'yes' if met else '**no**'} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--role", default="main", help=argparse.SUPPRESS)
    parser.add_argument("--mode", default="trials", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--status", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--beside", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--status-only", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--ticker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--into-arm", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--priority", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--seconds", type=float, default=30.0, help="length of each phase [s]")
    parser.add_argument("--only", default="", help="run only the phases whose label contains this")
    parser.add_argument("--json", help="write every figure to this file")
    parser.add_argument(
        "--scheduling",
        default="0:0,40:50",
        help="thread_priority settings to compare, servo:sim_arm pairs (0 = default scheduling; "
        "default: 0:0,40:50, i.e. without and with SCHED_FIFO at moveit_servo's and "
        "controller_manager's defaults)",
    )
    args = parser.parse_args()
    if args.role == "echo":
        return role_echo(args.beside)
    if args.role == "sender":
        return role_sender(args.mode, args.seconds, args.out, args.beside)
    if args.role == "receiver":
        topic = TICKER_TOPIC if args.ticker else COMMAND_TOPIC
        return role_receiver(args.out, args.status, args.beside, not args.status_only, topic)
    if args.role == "ticker":
        return role_ticker(args.priority, args.into_arm)
    if args.role == "sleeper":
        return role_sleeper(args.priority, args.out)

    reason = unavailable_reason() or next(
        (f"the {n} executable is not built" for n in ("sim_arm", "servo") if not executable(n)),
        None,
    )
    if reason:
        sys.exit(f"servo_node_benchmark: cannot run the nodes here: {reason}")
    env = local_ros_env()
    env["PYTHONWARNINGS"] = "ignore"
    print(clean_dead_shared_memory(), file=sys.stderr)
    settings = parse_scheduling(args.scheduling)
    plan: list[tuple[str, str, tuple[int, int] | None]] = []
    for label, kind in PHASES:
        if kind == "echo":
            plan.append((label, kind, None))
        else:  # each setting in turn, phase by phase (module docstring)
            plan += [(label, kind, setting) for setting in settings]
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="servo_node_bench_") as tmp:
        directory = Path(tmp)
        for label, kind, setting in plan:
            if args.only not in label:
                continue
            suffix = "" if setting is None else f" [{setting_name(setting)}]"
            for attempt in (1, 2):  # a harness process that crashes gets one more chance
                try:
                    load_before = os.getloadavg()[0]
                    measured = run_phase(kind, args.seconds, env, directory, setting or (0, 0))
                    # the machine's load (1-minute average) around the phase, the harness's own
                    # processes (the nodes, the sender, the receiver) included
                    for figures in measured.values():
                        figures["load_average"] = (load_before, os.getloadavg()[0])
                    results.update(
                        {
                            name if name == "echo, alone" else name + suffix: figures
                            for name, figures in measured.items()
                        }
                    )
                    break
                except nb.HarnessFailure as exc:
                    if attempt == 2:
                        raise
                    print(f"  {label}{suffix}: {exc}; measuring the phase again", file=sys.stderr)
            print(f"  measured: {label}{suffix}", file=sys.stderr)
    report(results)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
