"""Recordings: rosbag2 in, rosbag2 out, with no ROS installation (rosbags, an optional extra).

`kinematics bag` reads joint_states from a recording and writes a new recording in MCAP storage
with every input message copied and the end effector's pose, twist and the chain's /tf added,
computed in batches by the core (docs/recordings.md). ROS-free: imports the core, msg_adapters
and service, never rclpy.
"""
