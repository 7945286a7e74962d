"""The live node, over DDS: a compute_fk request that leaves out joints takes them from
joint_states, and is refused, naming them, once those are older than joint_states_max_age; a
fresh joint_states message serves it again, and the answer says which joints it took and how old
they were (#32 item 2)."""

from __future__ import annotations

import re
import time

import numpy as np
from kinematics_service.srv import ComputeFK
from live_node import UR5E_JOINTS, ur5e_description, wait_until
from test_node_topics import Stream, joint_state, stamp_ns

from kinematics_node.core import SerialChain
from msg_adapters import matrix_from_pose

Q = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
#: The node's limit [s]: long enough that a fresh message is never refused on a busy machine.
MAX_AGE = 2.0


def _fk(client, names, positions):
    req = ComputeFK.Request()
    req.joint_state = joint_state(names, positions)
    return client.call(ComputeFK, "compute_fk", req)


def _ages(message: str) -> dict[str, float]:
    ages = {}
    for joints, age in re.findall(r"([\w, ]+) \(received ([\d.e+-]+) s ago\)", message):
        for joint in joints.split(", "):
            ages[joint.strip().rpartition(" ")[2]] = float(age)
    return ages


def test_fk_refuses_joints_from_old_joint_states_and_says_the_age_of_fresh_ones(start_node, client):
    node = start_node(
        robot_description=ur5e_description(), joint_states_max_age=MAX_AGE, ik__workers=1
    )
    stream = Stream(client)
    stream.connected(node)
    others = [j for j in UR5E_JOINTS if j != "elbow_joint"]

    stream.pub.publish(joint_state(UR5E_JOINTS, Q, stamp_ns=5_000_000_000))
    wait_until(lambda: any(stamp_ns(p) == 5_000_000_000 for p in stream.poses), 5, "a pose")
    time.sleep(MAX_AGE + 0.3)  # the joint_states stop
    resp = _fk(client, ["elbow_joint"], [0.5])
    assert not resp.success, resp.message
    assert f"joint_state leaves out {others}" in resp.message, resp.message
    assert f"older than joint_states_max_age ({MAX_AGE:g} s)" in resp.message
    ages = _ages(resp.message)
    assert set(ages) == set(others) and min(ages.values()) > MAX_AGE, resp.message

    stream.pub.publish(joint_state(UR5E_JOINTS, Q, stamp_ns=6_000_000_000))
    wait_until(lambda: any(stamp_ns(p) == 6_000_000_000 for p in stream.poses), 5, "a pose")
    resp = _fk(client, ["elbow_joint"], [0.5])
    assert resp.success, resp.message
    assert resp.message.startswith("ok; from joint_states: "), resp.message
    ages = _ages(resp.message)
    assert set(ages) == set(others) and max(ages.values()) <= MAX_AGE, resp.message
    q = Q.copy()
    q[2] = 0.5
    T = SerialChain.from_urdf(ur5e_description()).fk(q)
    np.testing.assert_allclose(matrix_from_pose(resp.pose.pose), T, atol=1e-9)
    assert node.alive(), node.log()
