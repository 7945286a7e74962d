"""`kinematics demo` with ROS 2: the simulated arm and the kinematics node as real processes.

Starts the package's `sim_arm` (publishing joint_states) and `kinematics_node` executables, with
DDS discovery kept on loopback in a domain of the demo's own. This process listens on ee_pose,
ee_twist and joint_states for the run, then calls compute_fk, compute_jacobian and compute_ik over
DDS, prints a short live summary and draws the picture from what arrived (`demo.plot`).
`kinematics_node.sim.demo` is the in-process fallback where ROS 2 is not available.
"""

from __future__ import annotations

import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ..core.model import middle_of_limits
from ..sim.demo import DemoRun, movable_manipulability, plot
from ..sim.robots import default_chain_links, load_robot, robot_path
from .env import keep_discovery_local, local_ros_env
from .processes import log_tail, start_node, stop_nodes


def run_live(robot: str, duration: float, rate: float, stream: TextIO) -> tuple[DemoRun, list[str]]:
    """Run the processes for `duration` [s] with joint_states at `rate` [Hz]; returns what
    arrived (as a `DemoRun`) and the summary lines."""
    domain = keep_discovery_local()
    env = local_ros_env(domain)
    base, tip = default_chain_links(robot)
    chain = load_robot(robot)
    description = robot_path(robot).read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory(prefix="kinematics_demo_") as tmp:
        directory = Path(tmp)
        print(
            f"starting sim_arm ({robot}, {rate:g} Hz) and kinematics_node in ROS domain "
            f"{domain} (discovery on loopback)",
            file=stream,
        )
        processes = []
        try:  # (a node started is stopped, even when the next one cannot start)
            processes.append(
                start_node("sim_arm", {"robot": robot, "rate": float(rate)}, directory, env)
            )
            chain_params = {"robot_description": description, "base_link": base, "tip_link": tip}
            processes.append(start_node("kinematics_node", chain_params, directory, env))
            run, lines = _listen_and_call(chain, robot, duration, stream)
        finally:
            codes = stop_nodes(processes)
        lines.append(f"both processes stopped on SIGINT with exit codes {codes}")
        for name, code in zip(("sim_arm", "kinematics_node"), codes, strict=True):
            if code != 0:  # say why, before the log goes with the temporary directory
                tail = log_tail(directory, name)
                lines.extend([f"{name} exited with {code}; the end of its log:", *tail])
    return run, lines


def _listen_and_call(
    chain: Any, robot: str, duration: float, stream: TextIO
) -> tuple[DemoRun, list[str]]:
    import rclpy
    from geometry_msgs.msg import PoseStamped, TwistStamped
    from kinematics_service.srv import ComputeFK, ComputeIK, ComputeJacobian
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    from msg_adapters import jacobian_from_fields, matrix_from_pose

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("kinematics_demo", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    poses: list[tuple[float, Any, float]] = []
    twists: list[tuple[float, Any]] = []
    states: dict[float, list[float]] = {}
    qos = QoSProfile(depth=1000)

    def stamp(msg: Any) -> float:
        return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9

    node.create_subscription(
        PoseStamped, "ee_pose", lambda m: poses.append((stamp(m), m, time.time())), qos
    )
    node.create_subscription(TwistStamped, "ee_twist", lambda m: twists.append((stamp(m), m)), qos)

    def on_joint_state(m: Any) -> None:
        by_name = dict(zip(m.name, m.position, strict=False))
        if all(j in by_name for j in chain.joint_names):
            states[stamp(m)] = [by_name[j] for j in chain.joint_names]

    node.create_subscription(JointState, "joint_states", on_joint_state, qos)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    lines: list[str] = []
    try:
        clients: dict[str, Any] = {
            "fk": node.create_client(ComputeFK, "compute_fk"),
            "jac": node.create_client(ComputeJacobian, "compute_jacobian"),
            "ik": node.create_client(ComputeIK, "compute_ik"),
        }
        t_start = time.monotonic()
        # (each subscription of ours is matched on its own: ee_pose can arrive before the first
        # joint_states does, and the services are called on a configuration of joint_states)
        while not (poses and states):
            if time.monotonic() - t_start > 60:
                raise RuntimeError(
                    f"within 60 s: {len(poses)} ee_pose and {len(states)} joint_states naming "
                    "the chain's joints arrived, where both are needed; see the processes' logs"
                )
            time.sleep(0.05)
        print(
            f"first ee_pose after {time.monotonic() - t_start:.1f} s; listening for {duration:g} s",
            file=stream,
        )
        poses.clear()
        twists.clear()
        time.sleep(duration)
        got_poses, got_twists = list(poses), list(twists)

        def call(key: str, request: Any) -> Any:
            assert clients[key].wait_for_service(timeout_sec=10.0)
            future = clients[key].call_async(request)
            done = threading.Event()
            future.add_done_callback(lambda _: done.set())
            t0 = time.perf_counter()
            if not done.wait(10.0):
                raise RuntimeError(f"no answer from {key} within 10 s")
            return future.result(), (time.perf_counter() - t0) * 1e3

        # The services, on the last configuration that arrived
        if not got_poses:
            raise RuntimeError(f"no ee_pose arrived in the {duration:g} s listened")
        last_stamp = max(
            (s for s in list(states) if s <= got_poses[-1][0]), default=min(list(states))
        )
        q_last = np.array(states[last_stamp])
        fk = ComputeFK.Request()
        fk.joint_state.name = list(chain.joint_names)
        fk.joint_state.position = [float(v) for v in q_last]
        fk_resp, fk_ms = call("fk", fk)
        fk_err = np.abs(matrix_from_pose(fk_resp.pose.pose) - chain.fk(q_last)).max()
        jac = ComputeJacobian.Request()
        jac.joint_state = fk.joint_state
        jac_resp, jac_ms = call("jac", jac)
        jac_err = np.abs(jacobian_from_fields(jac_resp) - chain.jacobian(q_last, "world")).max()
        ik = ComputeIK.Request()
        ik.target = fk_resp.pose
        mid = middle_of_limits(chain.lower, chain.upper)
        ik.seed.name = list(chain.joint_names)
        ik.seed.position = [float(v) for v in mid]
        ik.timeout = 0.1
        ik_resp, ik_ms = call("ik", ik)
    finally:
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)

    # What arrived, as the picture's data
    matched = [(s, m, arr) for s, m, arr in got_poses if s in states]
    t = np.array([s for s, _, _ in matched])
    q = np.array([states[s] for s, _, _ in matched])
    p_tip = np.array([matrix_from_pose(m.pose)[:3, 3] for _, m, _ in matched])
    speed_of = {
        s: np.linalg.norm([m.twist.linear.x, m.twist.linear.y, m.twist.linear.z])
        for s, m in got_twists
    }
    speed = np.array([speed_of.get(s, np.nan) for s in t])
    latency = np.array([arr - s for s, _, arr in matched]) * 1e3
    w, rank = movable_manipulability(chain, q)
    reached = chain.fk(np.array(ik_resp.solution.position)) if ik_resp.success else None
    run = DemoRun(
        chain=chain,
        t=t - t[0],
        q=q,
        p_tip=p_tip,
        speed_tip=speed,
        manipulability=w,
        manipulability_rank=rank,
        ik_rows=[
            (
                float(t[-1] - t[0]),
                bool(ik_resp.success),
                ik_resp.position_error,
                ik_resp.orientation_error,
                ik_ms,
            )
        ],
        ik_targets=matrix_from_pose(fk_resp.pose.pose)[None, :3, 3],
    )
    fk_check = np.abs(p_tip - chain.fk(q)[:, :3, 3]).max()
    lines += [
        f"robot {robot}: {chain.dof} joints, chain {chain.base_link} → {chain.tip_link}",
        f"received over DDS in {duration:g} s: {len(got_poses)} ee_pose, {len(got_twists)} "
        f"ee_twist ({len(got_poses) / duration:.0f} Hz); pose latency from the joint_states "
        f"stamp: median {np.median(latency):.2f} ms",
        f"every ee_pose equals the core's FK of its joint_states to {fk_check:.1e} m",
        f"compute_fk: {'ok' if fk_resp.success else fk_resp.message} in {fk_ms:.1f} ms "
        f"(vs the core: {fk_err:.1e})",
        f"compute_jacobian: {'ok' if jac_resp.success else jac_resp.message} in {jac_ms:.1f} ms "
        f"(vs the core: {jac_err:.1e}; manipulability {jac_resp.manipulability:.4f})",
        "compute_ik (the last pose, seeded at the middle of the limits): "
        + (
            f"solved in {ik_ms:.1f} ms, position error {ik_resp.position_error:.1e} m, "
            f"orientation error {ik_resp.orientation_error:.1e} rad"
            if ik_resp.success and reached is not None
            else f"FAILED: {ik_resp.message}"
        ),
    ]
    return run, lines


def main(robot: str, out: Path, duration: float, rate: float, stream: TextIO | None = None) -> int:
    """The live demo: summary on `stream`, picture at `out` (already checked by the caller)."""
    stream = sys.stdout if stream is None else stream
    run, lines = run_live(robot, duration, rate, stream)
    print("\n".join(lines), file=stream)
    plot(run, out, robot)
    print(f"picture (from the ee_pose/ee_twist messages) written to {out.resolve()}", file=stream)
    return 0
