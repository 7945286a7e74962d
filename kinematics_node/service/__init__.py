"""The kinematics node's behaviour on message objects, without rclpy: `kinematics.KinematicsService`
takes and returns ROS messages (rclpy's classes, or rosbags' in tests), with what only it uses:
the robot model held (`robot_model`, `description_file`), joint-state tracking (`ee_state`), the
node's parameters (`parameters`) and the IK worker processes (`ik_pool`); and the servo node's
behaviour, `servo.ServoService` (its parameters: `servo_parameters`).

May import: `kinematics_node.core`, `msg_adapters`. Never rclpy or any ROS package (its messages
come from the caller's `MessageTypes`), nor `sim`, `ros` or `cli`.
"""
