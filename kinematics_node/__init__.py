"""Kinematics for ROS 2 and plain Python, in layers (each imports only from the layers above it
in this list; test/test_import_graph.py keeps it so):

* `kinematics_node.core`: the math and the robot model (numpy, scipy, yourdfpy). The library API.
* `msg_adapters` (a package of its own): ROS messages <-> core types, duck-typed.
* `kinematics_node.service`: what the kinematics node does, on message objects, without rclpy.
* `kinematics_node.sim`: a simulated arm, the bundled robots and the demo, without ROS.
* `kinematics_node.ros`: the rclpy wiring: the nodes, their executor and start-up, ROS clients.
* `kinematics_node.cli`: the `kinematics` command line (ROS only once a command needs it).

Nothing is imported here, so that ``import kinematics_node.core`` loads the core alone.
"""
