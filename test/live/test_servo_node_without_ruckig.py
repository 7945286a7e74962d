"""The servo node live without Ruckig (issue 32 item 7), over real DDS: the built `sim_arm` and
`servo` as processes of their own, the servo's Python unable to import ruckig (a `ruckig.py` that
raises ImportError comes first on its PYTHONPATH, as where Ruckig is not installed: a workspace set
up with rosdep). The arm follows a twist, checked on sim_arm's joint_states through the chain's
forward kinematics; ~/status names the acceleration-limited smoother; the log says once what is
missing and how to install it. Short on purpose (a few seconds of motion)."""

from __future__ import annotations

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
from servo_node_testing import servo_ready, values

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
        client.node.create_subscription(
            DiagnosticStatus, "/servo/status", statuses.append, QoSProfile(depth=1000)
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
        try:
            v = np.array([0.0, 0.03, 0.03])
            start = client.node.get_clock().now().nanoseconds * 1e-9
            while client.node.get_clock().now().nanoseconds * 1e-9 - start < 1.5:
                msg = TwistStamped()
                msg.header.stamp = client.node.get_clock().now().to_msg()
                msg.header.frame_id = "base_link"
                msg.twist.linear.y, msg.twist.linear.z = float(v[1]), float(v[2])
                twist_pub.publish(msg)
                time.sleep(0.01)
            end = client.node.get_clock().now().nanoseconds * 1e-9
            time.sleep(0.8)  # the timeout and the stop
        finally:
            codes = stop_nodes(processes)
        told = logs()
        assert codes == [0, 0], f"exit codes {codes}\n{told}"
        index = [list(states[-1].name).index(n) for n in chain.joint_names]
        rows = [(_stamp(m), np.array(m.position)[index]) for m in list(states)]
        # the tool moved along the twist once the ramp (0.4 s) was over, at about its speed
        after = [(t, q) for t, q in rows if start + 0.6 <= t <= end]
        assert len(after) >= 20, told
        p = chain.fk(np.array([q for _, q in after]))[:, :3, 3]
        moved = p[-1] - p[0]
        assert np.dot(moved, v) / (np.linalg.norm(moved) * np.linalg.norm(v)) > 0.99, (moved, told)
        span = after[-1][0] - after[0][0]
        assert np.linalg.norm(moved) / span == pytest.approx(np.linalg.norm(v), rel=0.3), told
        # ~/status names the smoother; the log says once what is missing and how to install it
        named = {values(s).get("smoother") for s in statuses}
        assert named == {"acceleration-limited (no Ruckig)"}, named
        servo_log = (directory / "servo.log").read_text(encoding="utf-8", errors="replace")
        assert servo_log.count("Ruckig is not installed") == 1, servo_log
        assert "--break-system-packages ruckig" in servo_log, servo_log
        assert "settings do not fit" not in servo_log, servo_log
