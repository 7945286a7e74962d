"""The `kinematics` command line: `main` (its commands, `kinematics = kinematics_node.cli.main:main`),
`ros_commands` (`kinematics ros`, talking to a running node) and `chain_cache` (parsed robot
descriptions cached between runs).

May import every other layer, but rclpy and ROS packages only inside the functions that run a
ROS command: `kinematics --help`, `fk`, `ik` and the rest start without ROS, and quickly.
"""
