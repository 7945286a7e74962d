"""The servo node live at a joint limit (issue 32 item 10): the built `sim_arm` (a Panda, position
command mode) and the servo at 500 Hz as processes of their own over real DDS, driven from this
process by a pure rotation about the tool's z axis through panda_joint7's limit.

What it shows: joint 7 goes to its limit and no further, the servo's status names it, and the
tool point (the core's forward kinematics of the joint_states sim_arm publishes) stays within
3 mm while the other joints take the rotation over. Measured: 0.06 mm in some runs, 2.1-2.2 mm
in others (the code before the share's braking: 1.2 mm in one run), so the live 0.1 mm is not
met every time yet.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import TwistStamped
from live_node import DOMAIN_ID, ROBOTS, Client, wait_until
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from servo_node_testing import servo_ready, values

from kinematics_node.core import SerialChain
from kinematics_node.ros.env import local_ros_env
from kinematics_node.ros.processes import log_tail, start_node, stop_nodes

pytest.importorskip("ruckig", reason="the servo's smoothing needs ruckig (extra 'servo')")

PANDA = ROBOTS / "panda.urdf"
BASE, TIP = "panda_link0", "panda_hand_tcp"
#: the Panda of the core's servo tests, joint 7 0.5 rad (1 s at 0.5 rad/s) before its upper
#: limit less the servo's 0.1 rad margin
START = [0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 2.8973 - 0.1 - 0.5]


@pytest.fixture(scope="module")
def rig(client: Client) -> Iterator[tuple[Client, list[Any], list[Any], Any]]:
    with tempfile.TemporaryDirectory(prefix="kinematics_servo_limit_") as tmp:
        env = local_ros_env(DOMAIN_ID)
        chain = {"robot_description_file": str(PANDA), "base_link": BASE, "tip_link": TIP}
        nodes = {
            "sim_arm": {
                "robot": "panda",
                "base_link": BASE,
                "tip_link": TIP,
                "rate": 500.0,
                "command_mode": "position",
                "initial_positions": START,
            },
            "servo": {**chain, "period_s": 0.002, "status_period": 0.05},
        }
        processes = [start_node(name, params, Path(tmp), env) for name, params in nodes.items()]
        states: list[Any] = client.collect(JointState, "joint_states")
        statuses: list[Any] = []
        client.node.create_subscription(
            DiagnosticStatus, "/servo/status", statuses.append, QoSProfile(depth=1000)
        )
        twist_pub = client.publisher(TwistStamped, "/servo/delta_twist_cmds")

        def logs() -> str:
            return "\n".join(f"--- {n}\n" + "\n".join(log_tail(Path(tmp), n, 40)) for n in nodes)

        try:
            wait_until(
                lambda: servo_ready(statuses, states, twist_pub),
                30.0,
                "the servo ready (status IDLE), joint_states flowing and our twists matched",
            )
        except AssertionError:
            stop_nodes(processes)
            raise AssertionError(f"the rig did not come up:\n{logs()}") from None
        yield client, states, statuses, twist_pub
        codes = stop_nodes(processes)
        assert codes == [0, 0], f"exit codes {codes}\n{logs()}"


def test_a_pure_rotation_through_joint_7s_limit_keeps_the_tool_point(rig):
    client, states, statuses, twist_pub = rig
    chain = SerialChain.from_urdf(PANDA, BASE, TIP)
    first = len(states)
    p0 = chain.fk(np.array(states[-1].position))[:3, 3]
    seen = len(statuses)
    start = time.monotonic()
    while time.monotonic() - start < 3.0:  # a joystick's stream of twists, 100 Hz
        msg = TwistStamped()
        msg.header.stamp = client.node.get_clock().now().to_msg()
        msg.header.frame_id = TIP
        msg.twist.angular.z = 0.5
        twist_pub.publish(msg)
        time.sleep(0.01)
    last_command = client.node.get_clock().now().nanoseconds
    time.sleep(0.5)  # the timeout's stop along the path
    received = list(states)[first:]
    q = np.array([m.position for m in received])
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in received])
    assert len(q) > 500, f"{len(q)} joint_states in 3.5 s"
    upper = chain.upper[-1] - 0.1
    assert q[:, -1].max() > upper - 1e-3, q[:, -1].max()  # joint 7 went to its limit
    assert q[:, -1].max() <= upper + 1e-9
    at_limit = [values(s).get("joints_at_limit", "") for s in list(statuses)[seen:]]
    assert any("panda_joint7" in names for names in at_limit), at_limit[-5:]
    moved = np.linalg.norm(chain.fk(q)[:, :3, 3] - p0, axis=1)
    commanded = stamps <= last_command  # sim_arm stamps with this machine's clock, as we do
    assert commanded.sum() > 500 and (~commanded).sum() > 50
    stop = moved[~commanded].max()
    # Issue 32's 0.1 mm while the twists come: 0.02-0.06 mm. It was 2-6 mm in half the runs
    # until sim_arm approached a position command out of one step's reach joint by joint (after a
    # gap in the servo's stream its joints caught up each at its own velocity limit, off the path)
    during = moved[commanded].max()
    assert during < 1e-4, f"the tool point moved {1e3 * during:.3f} mm while commanded"
    # and over the stop after the command timeout, the other joints carrying joint 7's share
    # (0.45 mm in one run before that stop asked them for a tenth of their limits, not half)
    assert stop < 1e-4, f"the tool point moved {1e3 * stop:.3f} mm in the stop"
