"""The servo in a process of its own, or inside the kinematics node's: which holds 1 kHz?

    make ros && . build/ros/env.sh
    python -W ignore benchmarks/servo_process_benchmark.py [--seconds 10] [--rounds 2] [--ik]

Issue 23 lets the servo node have its own executable or live inside the kinematics node, and asks
for the measured reason. Both layouts run here, alternately, under the same load:

* `sim_arm` (UR5e) publishing joint_states at 1 kHz and taking the servo's position commands;
* the kinematics node on those joint_states (ee_pose and ee_twist at 1 kHz); with --ik, also
  answering a client that calls compute_ik back to back (every third target unreachable: it
  costs its whole 50 ms timeout in an IK worker);
* the servo at a 1 ms period, jogged by a twist that turns in a circle (0.05 m/s), streamed at
  100 Hz, as a joystick does;
* layout "separate": the built `kinematics_node` and `servo` executables, two processes;
  layout "shared": one process building both nodes on one executor thread (our LeanExecutor,
  as the kinematics node's own process runs it), which is what "inside the kinematics node"
  amounts to: one Python thread, one GIL, for the pose path, the IK requests and the servo.

Reported per layout (the median over rounds): the share of the 1 ms ticks served by a cycle on
time (from the servo's own status: cycles; late_cycles, the timer callbacks that started a
period or more after their tick on the timer's grid, each of which made up the periods it skipped
before publishing; lost_periods, the periods not made up even so; step_us_max, its longest
timer callback), and the kinematics node's ee_pose: the share of joint_states answered and the
latency (arrival − stamp) median and p99, as this process receives them. The machine is shared: run it on a quiet one.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from kinematics_node.ros.env import (  # noqa: E402
    clean_dead_shared_memory,
    keep_discovery_local,
    local_ros_env,
    unavailable_reason,
)
from kinematics_node.ros.processes import start_node, stop_nodes  # noqa: E402

UR5E = ROOT / "config" / "robots" / "ur5e.urdf"
READY = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]  # launch/servo.launch.py's
CHAIN = {"robot_description_file": str(UR5E), "base_link": "base_link", "tip_link": "tool0"}
SERVO = {**CHAIN, "period_s": 0.001, "status_period": 0.25}
SIM = {
    "robot": "ur5e",
    "tip_link": "tool0",
    "rate": 1000.0,
    "command_mode": "position",
    "initial_positions": READY,
}
WARM_UP_S = 2.0


# ============================================================================ the shared process
def role_shared() -> None:
    """Both nodes in this process, on one LeanExecutor (as the kinematics node spins)."""
    import rclpy
    from rclpy.parameter import Parameter

    from kinematics_node.ros.executor import make_executor
    from kinematics_node.ros.kinematics import KinematicsNode
    from kinematics_node.ros.servo import ServoNode

    rclpy.init()

    def overrides(values: dict[str, Any]) -> list[Parameter]:
        return [Parameter(name, value=value) for name, value in values.items()]

    nodes = [
        KinematicsNode(parameter_overrides=overrides(CHAIN)),
        ServoNode(parameter_overrides=overrides(SERVO)),
    ]
    executor = make_executor("lean")
    for node in nodes:
        executor.add_node(node)
    try:
        executor.spin()
    except KeyboardInterrupt:
        pass
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()


# ============================================================================ the harness
class Client:
    """This process's rclpy node: jogs the servo, calls compute_ik, records ee_pose and status."""

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticStatus
        from geometry_msgs.msg import PoseStamped, TwistStamped
        from rclpy.qos import qos_profile_sensor_data

        from kinematics_node.ros.executor import make_executor

        self.rclpy = rclpy
        rclpy.init()
        self.node = rclpy.create_node("servo_process_benchmark")
        self.poses: list[tuple[float, float]] = []  # (arrival, stamp) [s], CLOCK_REALTIME
        self.statuses: list[tuple[float, dict[str, str]]] = []
        self.node.create_subscription(
            PoseStamped, "ee_pose", self._on_pose, qos_profile_sensor_data
        )
        self.node.create_subscription(DiagnosticStatus, "/servo/status", self._on_status, 100)
        self.twist_pub = self.node.create_publisher(TwistStamped, "/servo/delta_twist_cmds", 10)
        self.TwistStamped = TwistStamped
        self.executor = make_executor("lean")
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self.ik_answers = 0

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 - shutdown ends it
            pass

    def _on_pose(self, msg: Any) -> None:
        s = msg.header.stamp
        self.poses.append((time.time(), s.sec + s.nanosec * 1e-9))

    def _on_status(self, msg: Any) -> None:
        self.statuses.append((time.monotonic(), {kv.key: kv.value for kv in msg.values}))

    def jog(self, seconds: float) -> None:
        """Stream a twist turning in a circle (0.05 m/s, one turn in 4 s) at 100 Hz."""
        start = time.monotonic()
        while (t := time.monotonic() - start) < seconds:
            msg = self.TwistStamped()
            msg.header.stamp = self.node.get_clock().now().to_msg()
            msg.header.frame_id = "base_link"
            w = 2 * math.pi * t / 4.0
            msg.twist.linear.x, msg.twist.linear.y = 0.05 * math.cos(w), 0.05 * math.sin(w)
            self.twist_pub.publish(msg)
            time.sleep(0.01)

    def call_ik(self, stop: threading.Event) -> None:
        """compute_ik back to back, every third target out of reach."""
        import numpy as np
        from kinematics_service.srv import ComputeIK

        from kinematics_node.core import SerialChain
        from msg_adapters import MessageTypes, pose_stamped_from_matrix

        chain = SerialChain.from_urdf(UR5E, "base_link", "tool0")
        types = MessageTypes.from_rclpy()
        rng = np.random.default_rng(3)
        client = self.node.create_client(ComputeIK, "compute_ik")
        if not client.wait_for_service(timeout_sec=20.0):
            return
        k = 0
        while not stop.is_set():
            T = chain.fk(rng.uniform(-math.pi, math.pi, 6))
            if k % 3 == 2:
                T[:3, 3] *= 3.0  # out of reach
            request = ComputeIK.Request()
            request.target = pose_stamped_from_matrix(types, T, "base_link", types.Time())
            request.timeout = 0.05
            future = client.call_async(request)
            deadline = time.monotonic() + 2.0
            while not future.done() and time.monotonic() < deadline:
                time.sleep(0.001)
            self.ik_answers += 1
            k += 1

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self._thread.join(5.0)
        self.node.destroy_node()
        self.rclpy.try_shutdown()


def _counter(values: dict[str, str], key: str) -> int:
    return int(values.get(key, "0"))


def run_layout(
    layout: str, client: Client, seconds: float, directory: Path, env: Any, ik: bool
) -> dict:
    processes = []
    try:  # (a node started is stopped, even when the next one cannot start)
        processes.append(start_node("sim_arm", SIM, directory, env))
        if layout == "separate":
            processes.append(start_node("kinematics_node", CHAIN, directory, env))
            processes.append(start_node("servo", SERVO, directory, env))
        else:
            with (directory / "shared.log").open("wb") as log:
                processes.append(
                    subprocess.Popen(
                        [sys.executable, __file__, "--role", "shared"],
                        env=env,
                        stdout=log,
                        stderr=log,
                    )
                )
        # up when this layout's nodes speak (the client keeps what earlier layouts sent)
        up = len(client.statuses), len(client.poses)
        deadline = time.monotonic() + 30.0
        while not (len(client.statuses) > up[0] and len(client.poses) > up[1]):
            if time.monotonic() > deadline:
                raise SystemExit(f"{layout}: the nodes did not come up; logs in {directory}")
            time.sleep(0.1)
        stop = threading.Event()
        caller = threading.Thread(target=client.call_ik, args=(stop,), daemon=True)
        if ik:
            caller.start()
        jog = threading.Thread(target=client.jog, args=(WARM_UP_S + seconds,), daemon=True)
        jog.start()
        time.sleep(WARM_UP_S)
        s0, p0, t0 = len(client.statuses), len(client.poses), time.time()
        ik0 = client.ik_answers
        jog.join()
        stop.set()
        if ik:
            caller.join(3.0)
        t1 = time.time()
        statuses = client.statuses[s0:]
        poses = [p for p in client.poses[p0:] if t0 <= p[1] <= t1]
    finally:
        stop_nodes(processes)
    first, last = statuses[0][1], statuses[-1][1]
    cycles = _counter(last, "cycles") - _counter(first, "cycles")
    late = _counter(last, "late_cycles") - _counter(first, "late_cycles")
    lost = _counter(last, "lost_periods") - _counter(first, "lost_periods")
    latencies = sorted(arrival - stamp for arrival, stamp in poses)
    span = t1 - t0
    return {
        "cycles_per_s": cycles / span,
        # of the span's 1 ms ticks, those served by a cycle that came on time
        "on_time_pct": 100.0 * (cycles - late) / (span / SERVO["period_s"]),
        "lost_periods": lost,
        "step_us_max": max(int(v.get("step_us_max", "0")) for _, v in statuses),
        "ee_pose_pct": 100.0 * len(poses) / (1000.0 * span),
        "latency_median_ms": 1e3 * statistics.median(latencies) if latencies else math.nan,
        "latency_p99_ms": 1e3 * latencies[int(0.99 * (len(latencies) - 1))]
        if latencies
        else math.nan,
        "ik_answers_per_s": (client.ik_answers - ik0) / span,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--json", type=Path)
    parser.add_argument(
        "--ik", action="store_true", help="also call compute_ik back to back during each run"
    )
    parser.add_argument("--role", choices=["shared"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role == "shared":
        role_shared()
        return
    reason = unavailable_reason()
    if reason is not None:
        raise SystemExit(f"servo_process_benchmark: {reason}")
    print(clean_dead_shared_memory())
    load_before = " ".join(f"{x:.1f}" for x in os.getloadavg())
    domain = keep_discovery_local()
    env = local_ros_env(domain)
    client = Client()
    results: dict[str, list[dict]] = {"separate": [], "shared": []}
    try:
        with tempfile.TemporaryDirectory(prefix="servo_process_") as tmp:
            for r in range(args.rounds):
                for layout in ("separate", "shared") if r % 2 == 0 else ("shared", "separate"):
                    directory = Path(tmp) / f"{layout}{r}"
                    directory.mkdir()
                    out = run_layout(layout, client, args.seconds, directory, env, args.ik)
                    results[layout].append(out)
                    print(
                        f"round {r + 1} {layout:8s} "
                        + json.dumps({k: round(v, 2) for k, v in out.items()})
                    )
    finally:
        client.close()
    keys = list(results["separate"][0])
    load = ", compute_ik back to back" if args.ik else ""
    print(
        f"\nmedian of {args.rounds} rounds, {args.seconds:g} s each (servo at 1 kHz, "
        f"joint_states at 1 kHz{load}; load average before: {load_before}):"
    )
    print(f"{'':24s}{'separate':>12s}{'shared':>12s}")
    summary = {}
    for key in keys:
        row = [statistics.median(r[key] for r in results[layout]) for layout in results]
        summary[key] = dict(zip(results, row, strict=True))
        print(f"{key:24s}{row[0]:12.2f}{row[1]:12.2f}")
    if args.json:
        args.json.write_text(json.dumps({"rounds": results, "median": summary}, indent=2))


if __name__ == "__main__":
    main()
