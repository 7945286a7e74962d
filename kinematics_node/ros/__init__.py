"""The rclpy side: the nodes (`kinematics`: the kinematics node, `servo`: the servo node, `sim_arm`:
the simulated arm), their process entry (`early_stop`: a stop signal while they start;
`executables`: arguments and --help before ROS starts; `spin`: run until shutdown), what they share
(`node_setup`: parameters declared from their tables, the heap frozen; `qos`: their topics' QoS;
`node_log`: their log lines) and their executor (`executor`, with `deferred` and `mailbox`), ROS
clients (`client` for `kinematics ros`, `live_demo` for `kinematics demo`) and the ROS processes we
start (`env`: their environment; `processes`: starting and stopping them).

May import: `kinematics_node.core`, `msg_adapters`, `kinematics_node.service`,
`kinematics_node.sim`, rclpy and ROS packages. Never `cli`. This file imports nothing, and
`early_stop` (only the standard library), `executables`, `client`, `env`, `processes`, `node_log`,
`deferred` and `mailbox` import no rclpy at import time: the installed executables' --help and the
command line use them without ROS.
"""
