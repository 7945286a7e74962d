"""The servo node live without Ruckig (issue 32 item 7), over real DDS: the built `sim_arm` and
`servo` as processes of their own, the servo's Python unable to import ruckig (a `ruckig.py` that
raises ImportError comes first on its PYTHONPATH, as where Ruckig is not installed: a workspace set
up with rosdep). The arm follows a twist, checked on sim_arm's joint_states through the chain's
forward kinematics, at the twist's speed where the servo could serve the twists (on a machine
too loaded for that it says so itself, and the speed is not judged: skipped, saying why, as
test_servo_demo_live does); ~/status names the acceleration-limited smoother; the log says once
what is missing and how to install it. Short on purpose (a few seconds of motion)."""

from __future__ import annotations

import gc
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import TwistStamped
from live_node import DOMAIN_ID, UR5E, Client, wait_until
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from servo_node_testing import servo_held_up, servo_ready, values, velocity

from kinematics_node.core import SerialChain
from kinematics_node.ros.env import local_ros_env
from kinematics_node.ros.processes import log_tail, start_node, stop_nodes

READY = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]
CHAIN = {"robot_description_file": str(UR5E), "base_link": "base_link", "tip_link": "tool0"}
#: what an `import ruckig` meets where Ruckig is not installed
NO_RUCKIG = "raise ImportError(\"No module named 'ruckig' (hidden by the test)\")\n"


def _stamp(msg: Any) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def test_without_ruckig_the_arm_follows_a_twist_and_the_servo_says_what_is_missing(
    client: Client,
):
    chain = SerialChain.from_urdf(UR5E, "base_link", "tool0")
    with tempfile.TemporaryDirectory(prefix="kinematics_no_ruckig_") as tmp:
        directory = Path(tmp)
        blocker = directory / "hide"
        blocker.mkdir()
        (blocker / "ruckig.py").write_text(NO_RUCKIG, encoding="utf-8")
        env = local_ros_env(DOMAIN_ID)
        servo_env = dict(env)
        servo_env["PYTHONPATH"] = os.pathsep.join(
            p for p in (str(blocker), env.get("PYTHONPATH", "")) if p
        )
        sim = {
            "robot": "ur5e",
            "tip_link": "tool0",
            "rate": 100.0,
            "command_mode": "position",
            "initial_positions": READY,
        }
        servo = {**CHAIN, "period_s": 0.004, "status_period": 0.05}
        processes = [
            start_node("sim_arm", sim, directory, env),
            start_node("servo", servo, directory, servo_env),
        ]
        statuses: list[Any] = []
        arrivals: list[float] = []  # [s, ROS clock], one per status

        def take_status(msg: Any) -> None:
            arrivals.append(client.node.get_clock().now().nanoseconds * 1e-9)
            statuses.append(msg)

        client.node.create_subscription(
            DiagnosticStatus, "/servo/status", take_status, QoSProfile(depth=1000)
        )
        states = client.collect(JointState, "joint_states", sensor=True)
        twist_pub = client.publisher(TwistStamped, "/servo/delta_twist_cmds")

        def logs() -> str:
            return "\n".join(
                f"--- {name}\n" + "\n".join(log_tail(directory, name, 40))
                for name in ("sim_arm", "servo")
            )

        try:
            wait_until(
                lambda: servo_ready(statuses, states, twist_pub),
                30.0,
                "the servo ready (status IDLE), joint_states flowing and our twists matched",
            )
        except AssertionError:
            stop_nodes(processes)
            raise AssertionError(f"the servo did not come up without Ruckig:\n{logs()}") from None
        # No cyclic GC here while the twists go: this session's client holds every message the
        # live tests collected, and a full collection stops the twists for about the servo's
        # 0.1 s command timeout (test_servo_node measured 94-129 ms)
        gc.collect()
        gc.disable()
        sent: list[float] = []
        try:
            v = np.array([0.0, 0.03, 0.03])
            start = client.node.get_clock().now().nanoseconds * 1e-9
            while client.node.get_clock().now().nanoseconds * 1e-9 - start < 1.5:
                msg = TwistStamped()
                msg.header.stamp = client.node.get_clock().now().to_msg()
                msg.header.frame_id = "base_link"
                msg.twist.linear.y, msg.twist.linear.z = float(v[1]), float(v[2])
                twist_pub.publish(msg)
                sent.append(time.monotonic())
                time.sleep(0.01)
            end = client.node.get_clock().now().nanoseconds * 1e-9
            time.sleep(0.8)  # the timeout and the stop
        finally:
            gc.enable()
            codes = stop_nodes(processes)
        told = logs()
        assert codes == [0, 0], f"exit codes {codes}\n{told}"
        gap = float(np.diff(sent).max())
        said = [
            (t - start, values(s).get("code_name"), s.message)
            for t, s in zip(list(arrivals), list(statuses), strict=False)
            if start <= t
        ]
        story = "\n".join(
            f"  {t:+.3f} s {code}: {message}"
            for i, (t, code, message) in enumerate(said)
            if i == 0 or code != said[i - 1][1]
        )
        loop = {k: values(statuses[-1]).get(k) for k in ("cycles", "late_cycles", "lost_periods")}
        told = (
            f"the twists' longest gap {gap * 1e3:.0f} ms; the servo's loop {loop}; it said:\n"
            f"{story}\n{told}"
        )
        # ~/status names the smoother; the log says once what is missing and how to install it
        named = {values(s).get("smoother") for s in statuses}
        assert named == {"acceleration-limited (no Ruckig)"}, named
        servo_log = (directory / "servo.log").read_text(encoding="utf-8", errors="replace")
        assert servo_log.count("Ruckig is not installed") == 1, servo_log
        assert "--break-system-packages ruckig" in servo_log, servo_log
        assert "settings do not fit" not in servo_log, servo_log
        # The speed is judged where the servo could serve the twists; on a machine too loaded
        # for that it says so itself (`servo_held_up`). Measured beside four busy loops on 2
        # cores (Kilted): 0.031 m/s of 0.042 with 113 periods lost and two stale twists; 0.041-
        # 0.043 m/s with 1-33 lost in the other runs.
        held_up = servo_held_up(arrivals, statuses, start, end, servo["period_s"])
        if held_up is not None:
            pytest.skip(
                f"the twists did not reach the servo in time or it fell behind ({held_up}; "
                f"their longest gap here {gap * 1e3:.0f} ms): the speed not judged"
            )
        index = [list(states[-1].name).index(n) for n in chain.joint_names]
        rows = [(_stamp(m), np.array(m.position)[index]) for m in list(states)]
        # the tool moved along the twist once the ramp (0.4 s) was over, at about its speed: the
        # median over 0.15 s windows, as in test_servo_node (a process held up costs a window)
        after = [(t, q) for t, q in rows if start + 0.6 <= t <= end]
        assert len(after) >= 20, told
        p = chain.fk(np.array([q for _, q in after]))[:, :3, 3]
        fit = velocity(np.array([t for t, _ in after]), p)
        assert np.dot(fit, v) / (np.linalg.norm(fit) * np.linalg.norm(v)) > 0.99, (fit, told)
        assert np.linalg.norm(fit) == pytest.approx(np.linalg.norm(v), rel=0.3), (fit, told)
