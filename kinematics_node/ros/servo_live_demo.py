"""`kinematics servo-demo` with ROS 2: the simulated arm, the kinematics node and the servo node as
real processes, the square and the spin sent as TwistStamped over DDS.

Starts the package's `sim_arm` (UR5e, taking position commands as ros2_control's
forward_position_controller does, starting at the square's first corner), `kinematics_node`
(publishing ee_pose) and `servo` (period 1/rate), with DDS discovery kept on loopback in a domain
of the demo's own. This process sends the script's twists (`servo_demo.SquarePlan`) on
/servo/delta_twist_cmds, as a joystick would, and records joint_states, ee_pose, the servo's joint
commands and its ~/status; the figures and the picture come from what arrived
(`servo_demo.figures`, `servo_demo.plot`). `kinematics_node.sim.servo_demo` is the in-process
version where ROS 2 is not available.
"""

from __future__ import annotations

import dataclasses
import gc
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..core.servo import ServoConfig, ServoLimits
from ..sim import servo_demo
from ..sim.robots import default_chain_links, load_robot, robot_path
from .env import executable, keep_discovery_local, local_ros_env
from .env import unavailable_reason as node_unavailable_reason
from .processes import log_tail, start_node, stop_nodes

PROCESSES = ("sim_arm", "kinematics_node", "servo")
COMMAND_TOPIC = "/forward_position_controller/commands"  # the servo's and the arm's default
TWIST_TOPIC = "/servo/delta_twist_cmds"
STATUS_TOPIC = "/servo/status"
MAX_TWIST_RATE = 100.0  # [Hz] the twists are sent at the servo's rate, at most this (a joystick's)
READY_TIMEOUT_S = 60.0


def unavailable_reason() -> str | None:
    """Why the demo cannot run on the real nodes from this process (None when it can)."""
    reason = node_unavailable_reason()
    if reason is not None:
        return reason
    for name in PROCESSES:
        if executable(name) is None:
            return f"the {name} executable is not found: run `make ros`, then . build/ros/env.sh"
    return None


def run_live(rate: float, stream: TextIO) -> servo_demo.ServoDemoRun:
    """Run the processes and the script with the servo at `rate` [Hz]; returns what arrived."""
    domain = keep_discovery_local()
    env = local_ros_env(domain)
    chain = load_robot(servo_demo.ROBOT)
    base, tip = default_chain_links(servo_demo.ROBOT)
    plan = servo_demo.plan_square(chain)
    config = servo_demo.servo_config(rate)
    description = robot_path(servo_demo.ROBOT).read_text(encoding="utf-8")
    robot = {"robot_description": description, "base_link": base, "tip_link": tip}
    with tempfile.TemporaryDirectory(prefix="kinematics_servo_demo_") as tmp:
        directory = Path(tmp)
        print(
            f"starting sim_arm ({servo_demo.ROBOT}, {rate:g} Hz, position commands), "
            f"kinematics_node and servo (every {1e3 / rate:g} ms) in ROS domain {domain} "
            "(discovery on loopback)",
            file=stream,
        )
        params: dict[str, dict[str, Any]] = {
            "sim_arm": {
                "robot": servo_demo.ROBOT,
                "tip_link": tip,
                "rate": float(rate),
                "command_mode": "position",
                "initial_positions": [float(v) for v in plan.q_start],
            },
            "kinematics_node": robot,
            "servo": {**robot, "period_s": config.period_s},
        }
        processes = []
        try:  # (a node started is stopped, even when the next one cannot start)
            for name in PROCESSES:
                processes.append(start_node(name, params[name], directory, env))
            run = _drive_and_record(chain, plan, config, stream)
        finally:
            codes = stop_nodes(processes)
        notes = [f"the three processes stopped on SIGINT with exit codes {codes}"]
        for name, code in zip(PROCESSES, codes, strict=True):
            if code != 0:  # say why, before the log goes with the temporary directory
                tail = log_tail(directory, name)
                notes.extend([f"{name} exited with {code}; the end of its log:", *tail])
    return dataclasses.replace(run, notes=run.notes + tuple(notes))


def loop_counts(statuses: list[tuple[float, dict[str, str]]], t_start: float) -> str:
    """The servo's own loop counters (~/status: cycles, late_cycles, lost_periods) from the last
    status before `t_start` [s] to the last one received, in words."""
    with_counts = [(t, v) for t, v in statuses if "cycles" in v]
    before = [v for t, v in with_counts if t < t_start]
    if not with_counts or with_counts[-1][0] < t_start:
        return "no counters received"
    base, last = (before[-1] if before else {}), with_counts[-1][1]

    def delta(key: str) -> str:
        if key not in last:
            return "?"
        return str(int(last[key]) - int(base.get(key, 0)))

    return (
        f"{delta('cycles')} cycles, {delta('late_cycles')} late (started a period or more "
        f"after their tick; the periods they skipped made up), {delta('lost_periods')} periods "
        "lost"
    )


def _stamp(msg: Any) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def _drive_and_record(
    chain: Any, plan: servo_demo.SquarePlan, config: ServoConfig, stream: TextIO
) -> servo_demo.ServoDemoRun:
    period_s = config.period_s
    import rclpy
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import PoseStamped, TwistStamped
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from msg_adapters import matrix_from_pose

    from .executor import make_executor

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("kinematics_servo_demo", context=context)
    executor = make_executor("lean", context=context)  # (half rclpy's CPU per message)
    executor.add_node(node)
    qos = QoSProfile(depth=1000)
    poses: list[tuple[float, Any]] = []
    states: dict[float, list[float]] = {}
    # (arrival [s], positions, publication sequence number, publication time [s])
    commands: list[tuple[float, list[float], int, float]] = []
    statuses: list[tuple[float, dict[str, str]]] = []
    node.create_subscription(PoseStamped, "ee_pose", lambda m: poses.append((_stamp(m), m)), qos)

    def on_joint_state(m: Any) -> None:
        by_name = dict(zip(m.name, m.position, strict=False))
        if all(j in by_name for j in chain.joint_names):
            states[_stamp(m)] = [by_name[j] for j in chain.joint_names]

    def on_status(m: Any) -> None:
        values = {kv.key: kv.value for kv in m.values}
        values["_message"] = m.message
        statuses.append((time.time(), values))  # (arrival [s])

    def on_command(m: Any, info: Any) -> None:  # (two parameters: rclpy passes MessageInfo)
        commands.append(
            (
                time.time(),
                list(m.data),
                info["publication_sequence_number"],
                info["source_timestamp"] * 1e-9,
            )
        )

    node.create_subscription(JointState, "joint_states", on_joint_state, qos)
    # (rclpy passes MessageInfo to a callback of two parameters; its stubs know one)
    node.create_subscription(Float64MultiArray, COMMAND_TOPIC, on_command, qos)  # type: ignore[arg-type]
    node.create_subscription(DiagnosticStatus, STATUS_TOPIC, on_status, qos)
    twist_pub = node.create_publisher(TwistStamped, TWIST_TOPIC, 10)
    sent: list[tuple[float, np.ndarray]] = []
    msg = TwistStamped()
    msg.header.frame_id = chain.base_link

    def send(now_ns: int, twist: np.ndarray) -> None:
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now_ns, 1_000_000_000)
        msg.twist.angular.x, msg.twist.angular.y, msg.twist.angular.z = (
            float(v) for v in twist[:3]
        )
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in twist[3:])
        twist_pub.publish(msg)

    send_period = max(period_s, 1.0 / MAX_TWIST_RATE)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        t0 = time.monotonic()
        ready = False
        while not ready:
            if time.monotonic() - t0 > READY_TIMEOUT_S:
                raise RuntimeError(
                    f"the nodes were not ready within {READY_TIMEOUT_S:g} s (ee_pose: "
                    f"{len(poses)} arrived, joint_states naming the chain's joints: "
                    f"{len(states)}, servo status: {statuses[-1][1] if statuses else 'none'})"
                )
            time.sleep(0.05)
            codes = [s.get("code_name") for _, s in statuses]
            # (each subscription of ours is matched on its own: ee_pose and the servo's status
            # can arrive before the first joint_states does)
            ready = (
                bool(poses) and bool(states) and any(c not in (None, "NOT_READY") for c in codes)
            )
        q_now = np.array(states[max(states)])
        print(
            f"nodes ready after {time.monotonic() - t0:.1f} s (the arm at the first corner to "
            f"{np.abs(q_now - plan.q_start).max():.1e} rad); sending the script's twists on "
            f"{TWIST_TOPIC} at {1.0 / send_period:g} Hz for {plan.commands_s:g} s",
            file=stream,
        )
        # sent from this thread on a schedule of its own (the executor's thread takes the
        # messages), each twist the script's at its send time. No cyclic GC meanwhile: with
        # the messages recorded so far, a full collection took 94-129 ms, and the twists
        # stopped for as long (longer than the servo's 0.1 s timeout on a slower machine)
        gc.collect()
        gc.disable()
        start = time.time()
        next_at = time.monotonic()
        while True:
            now_ns = time.time_ns()
            twist = plan.twist(now_ns * 1e-9 - start)
            if twist is None:
                break
            send(now_ns, twist)
            sent.append((now_ns * 1e-9 - start, twist))
            next_at = max(next_at + send_period, time.monotonic())
            time.sleep(max(0.0, next_at - time.monotonic()))
        time.sleep(plan.settle_s + 0.2)
    finally:
        gc.enable()
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)

    t_start = start
    # from the last sample before the first twist (the arm at rest where the script starts)
    matched = [(s, m) for s, m in poses if s >= t_start - 2 * period_s and s in states]
    if len(matched) < 10:
        raise RuntimeError(f"only {len(matched)} ee_pose with their joint_states arrived")
    t_tool = np.array([s for s, _ in matched]) - t_start
    q_tool = np.array([states[s] for s, _ in matched])
    T_tool = np.array([matrix_from_pose(m.pose) for _, m in matched])
    kept = [c for c in commands if c[0] >= t_start]
    q_cmd = np.array([c[1] for c in kept])
    sequence = np.array([c[2] for c in kept], dtype=np.int64)
    published = np.array([c[3] for c in kept]) - t_start
    lost = int((np.diff(sequence) - 1).clip(0).sum()) if len(sequence) else 0
    if len(q_cmd) < 10:
        raise RuntimeError(f"only {len(q_cmd)} joint commands from the servo arrived")
    fk_gap = float(np.abs(T_tool[:, :3, 3] - chain.fk(q_tool)[:, :3, 3]).max())
    seen = [s.get("code_name", "?") for arrival, s in statuses if arrival >= t_start]
    codes_seen = [c for i, c in enumerate(seen) if i == 0 or c != seen[i - 1]]
    loop = loop_counts(statuses, t_start)
    # a stop in mid-script: what the servo said, and whether the twists themselves had a gap
    sent_at = np.array([t for t, _ in sent])
    gap_ms = float(np.diff(sent_at).max() * 1e3) if len(sent_at) > 1 else 0.0
    stops = [
        s["_message"]
        for arrival, s in statuses
        if arrival >= t_start
        and s.get("code_name") in ("TIMEOUT_STOP", "COMMAND_STALE")
        and arrival - t_start < plan.commands_s
    ]
    mid = f"; in mid-script it said: {stops[0]}" if stops else ""
    notes = (
        f"received over DDS: {len(matched)} ee_pose (every one equals the core's FK of its "
        f"joint_states to {fk_gap:.1e} m), {len(q_cmd)} joint commands from the servo "
        f"({lost} lost on the way, by their sequence numbers)",
        f"servo status along the way: {' → '.join(codes_seen) or 'none received'}; its loop "
        f"meanwhile (its ~/status): {loop}",
        f"twists sent: {len(sent)}, the longest gap between two {gap_ms:.0f} ms{mid}",
    )
    t_twist = np.array([t for t, _ in sent])
    twists = np.array([w for _, w in sent]).reshape(-1, 6)
    return servo_demo.ServoDemoRun(
        chain=chain,
        limits=ServoLimits.from_chain(chain, config),
        plan=plan,
        period_s=period_s,
        q_command=q_cmd,
        t_tool=t_tool,
        q_tool=q_tool,
        p_tool=T_tool[:, :3, 3],
        R_tool=T_tool[:, :3, :3],
        t_twist=t_twist,
        twist=twists,
        status_counts={},
        where=f"the servo node at {1.0 / period_s:g} Hz over DDS, the simulated arm and the "
        "kinematics node as processes",
        notes=notes,
        command_sequence=sequence,
        command_time=published,
    )


def main(out: Path, rate: float, stream: TextIO | None = None) -> int:
    """The live demo: summary on `stream`, picture at `out` (already checked by the caller)."""
    stream = sys.stdout if stream is None else stream
    run = run_live(rate, stream)
    fig = servo_demo.figures(run)
    print(servo_demo.summary(run, fig), file=stream)
    servo_demo.plot(run, fig, out)
    print(f"picture (from the messages that arrived) written to {out.resolve()}", file=stream)
    return 0
