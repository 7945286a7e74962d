"""ROS-free simulation: a kinematic arm simulator (`arm`), the robot descriptions bundled with the
package (`robots`) and `kinematics demo` run in one process (`demo`).

May import: `kinematics_node.core`, `kinematics_node.service` (the demo runs the node's
joint-state logic). Never rclpy or any ROS package, nor `ros` or `cli`.
"""
