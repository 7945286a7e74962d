"""End-to-end test of the installed package with launch_testing (runs only where ROS 2 is sourced
and this package is built: `colcon test --packages-select kinematics_service`, or
`launch_test test/launch/test_launch_integration.py`). Elsewhere it skips, saying why.

Starts launch/kinematics.launch.py with the UR5 of example-robot-data, publishes joint_states, and
checks ee_pose / ee_twist against the pure-Python core, the three services, and that a slow IK call
does not stall pose publishing (services and subscriptions in separate callback groups).
"""

from __future__ import annotations

import math
import sysconfig
import time
import unittest
from pathlib import Path

import pytest

pytest.importorskip(
    "launch_testing", reason="launch_testing is not installed: this test needs a sourced ROS 2"
)
rclpy = pytest.importorskip("rclpy", reason="rclpy is not installed: this test needs ROS 2")
srv = pytest.importorskip(
    "kinematics_service.srv",
    reason="kinematics_service interfaces are not built: colcon build, then source install/setup",
)

import launch_testing  # noqa: E402
import launch_testing.actions  # noqa: E402
import launch_testing.asserts  # noqa: E402
import numpy as np  # noqa: E402
from geometry_msgs.msg import PoseStamped, TwistStamped  # noqa: E402
from launch.launch_description_sources import PythonLaunchDescriptionSource  # noqa: E402
from launch_ros.substitutions import FindPackageShare  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

import launch  # noqa: E402
from kinematics_node.core import SerialChain  # noqa: E402
from kinematics_node.ros.env import keep_discovery_local  # noqa: E402

# Discovery on loopback, in a domain of this run's own, for this process and for the processes
# launch starts (they inherit this environment): set before rclpy starts.
keep_discovery_local()
from msg_adapters import jacobian_from_fields, matrix_from_pose  # noqa: E402

UR5 = (
    Path(sysconfig.get_paths()["purelib"])
    / "cmeel.prefix/share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
)
JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
Q = [0.3, -1.1, 1.4, -0.6, 0.8, 0.2]
QDOT = [0.1, -0.2, 0.3, 0.1, 0.2, -0.1]


@pytest.mark.launch_test
def generate_test_description():
    if not UR5.exists():
        pytest.skip(
            f"example-robot-data not installed ({UR5} missing): pip install example-robot-data"
        )
    include = launch.actions.IncludeLaunchDescription(
        PythonLaunchDescriptionSource(
            [FindPackageShare("kinematics_service"), "/launch/kinematics.launch.py"]
        ),
        launch_arguments={
            "description_file": str(UR5),
            "base_link": "base_link",
            "tip_link": "tool0",
        }.items(),
    )
    return launch.LaunchDescription([include, launch_testing.actions.ReadyToTest()])


class TestKinematicsNode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rclpy.init()
        cls.chain = SerialChain.from_urdf(UR5, "base_link", "tool0")

    @classmethod
    def tearDownClass(cls):
        rclpy.try_shutdown()

    def setUp(self):
        self.node = rclpy.create_node("kinematics_node_test_client")
        self.js_pub = self.node.create_publisher(JointState, "joint_states", 10)
        self.poses: list[PoseStamped] = []
        self.twists: list[TwistStamped] = []
        self.node.create_subscription(PoseStamped, "ee_pose", self.poses.append, 10)
        self.node.create_subscription(TwistStamped, "ee_twist", self.twists.append, 10)

    def tearDown(self):
        self.node.destroy_node()

    def _publish(self):
        msg = JointState()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.name = list(JOINTS)
        msg.position = list(Q)
        msg.velocity = list(QDOT)
        self.js_pub.publish(msg)

    def _spin_until(self, predicate, timeout=20.0):
        end = time.monotonic() + timeout
        while time.monotonic() < end and not predicate():
            self._publish()
            rclpy.spin_once(self.node, timeout_sec=0.05)
        return predicate()

    def _call(self, srv_type, name, request, timeout=20.0):
        client = self.node.create_client(srv_type, name)
        self.assertTrue(client.wait_for_service(timeout_sec=timeout), f"{name} not available")
        future = client.call_async(request)
        rclpy.spin_until_future_complete(self.node, future, timeout_sec=timeout)
        self.assertTrue(future.done(), f"{name} did not answer")
        return future.result()

    def test_pose_and_twist_are_published(self):
        self.assertTrue(self._spin_until(lambda: self.poses and self.twists), "no ee_pose/ee_twist")
        pose = self.poses[-1]
        self.assertEqual(pose.header.frame_id, "base_link")
        np.testing.assert_allclose(matrix_from_pose(pose.pose), self.chain.fk(Q), atol=1e-9)
        V = self.chain.jacobian(Q, "world") @ np.array(QDOT)
        t = self.twists[-1].twist
        np.testing.assert_allclose([t.angular.x, t.angular.y, t.angular.z], V[:3], atol=1e-9)
        np.testing.assert_allclose([t.linear.x, t.linear.y, t.linear.z], V[3:], atol=1e-9)

    def test_services(self):
        self._spin_until(lambda: self.poses)
        fk = srv.ComputeFK.Request()
        fk.joint_state.name = ["elbow_joint"]
        fk.joint_state.position = [0.5]
        resp = self._call(srv.ComputeFK, "compute_fk", fk)
        self.assertTrue(resp.success, resp.message)
        q = list(Q)
        q[2] = 0.5
        np.testing.assert_allclose(matrix_from_pose(resp.pose.pose), self.chain.fk(q), atol=1e-9)

        jac = srv.ComputeJacobian.Request()
        jac.joint_state.name = list(JOINTS)
        jac.joint_state.position = list(Q)
        resp = self._call(srv.ComputeJacobian, "compute_jacobian", jac)
        self.assertTrue(resp.success, resp.message)
        np.testing.assert_allclose(
            jacobian_from_fields(resp), self.chain.jacobian(Q, "world"), atol=1e-9
        )

        bad = srv.ComputeFK.Request()
        bad.joint_state.name = ["no_such_joint"]
        bad.joint_state.position = [0.0]
        resp = self._call(srv.ComputeFK, "compute_fk", bad)
        self.assertFalse(resp.success)
        self.assertIn("no_such_joint", resp.message)

        ik = srv.ComputeIK.Request()
        ik.target.header.frame_id = "base_link"
        ik.target.pose = resp_pose = self._call(srv.ComputeFK, "compute_fk", fk).pose.pose
        ik.timeout = 1.0
        resp = self._call(srv.ComputeIK, "compute_ik", ik)
        self.assertTrue(resp.success, resp.message)
        reached = self.chain.fk(np.array(resp.solution.position))
        np.testing.assert_allclose(reached, matrix_from_pose(resp_pose), atol=1e-4)

    def test_slow_ik_does_not_stall_pose_publishing(self):
        self._spin_until(lambda: self.poses)
        ik = srv.ComputeIK.Request()
        ik.target.header.frame_id = "base_link"
        # tool0 at (0, 0, 0.3) with the base's orientation puts the wrist centre on joint 1's
        # axis: inside the reach sphere yet unreachable, so the search uses its whole timeout
        # (a target beyond the reach sphere would be answered at once)
        ik.target.pose.position.z = 0.3
        ik.target.pose.orientation.w = 1.0
        ik.timeout = 2.0
        client = self.node.create_client(srv.ComputeIK, "compute_ik")
        self.assertTrue(client.wait_for_service(timeout_sec=10.0))
        future = client.call_async(ik)
        before = len(self.poses)
        end = time.monotonic() + 10.0
        while not future.done() and time.monotonic() < end:
            self._publish()
            rclpy.spin_once(self.node, timeout_sec=0.02)
        self.assertTrue(future.done())
        self.assertFalse(future.result().success)
        self.assertGreater(len(self.poses) - before, 10, "poses stalled during a 2 s IK call")
        self.assertTrue(math.isfinite(future.result().position_error))


@launch_testing.post_shutdown_test()
class TestShutdown(unittest.TestCase):
    def test_exit_codes(self, proc_info):
        launch_testing.asserts.assertExitCodes(proc_info)
