"""The QoS of our nodes' topics, shared by the kinematics node and the servo (and what a node
that talks to them should match).

* `JOINT_STATES_QOS`: best effort (matches reliable and best-effort publishers, as the sensor-data
  profile does) with room for 100 samples: 100 ms at 1 kHz. The sensor-data profile keeps 5, so
  any 5 ms hiccup (another process's turn on a busy machine) dropped samples for good.
* `DESCRIPTION_QOS`: robot_description as robot_state_publisher publishes it (transient local,
  reliable): a node that starts later still gets the last one.
* `TF_QOS`, `TF_STATIC_QOS`: /tf and /tf_static as tf2_ros' broadcasters offer them (depth 100;
  /tf_static transient local, depth 1, so a listener that starts later gets it).
* `NO_PUBLISHER_EVENTS`, `NO_SUBSCRIPTION_EVENTS`: the entities that carry messages at up to 1 kHz
  go without rclpy's default QoS-event handlers: each adds two waitables that the executor sets
  up again on every turn (~10 µs a turn each, a turn per joint_states message and more;
  measured with an idle `spin_once`). They would only log an incompatible QoS, and there the
  other side logs it too: a joint_states subscription (best effort, volatile) is compatible with
  every publisher, and a subscriber that asks our publishers for more than they offer gets
  rclpy's (or rclcpp's) warning itself. The robot_description subscriptions keep them: there the
  warning explains a model that never loads.
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

try:  # Jazzy and later
    from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
except ImportError:  # pragma: no cover - Humble
    from rclpy.qos_event import PublisherEventCallbacks, SubscriptionEventCallbacks

JOINT_STATES_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
DESCRIPTION_QOS = QoSProfile(
    depth=1,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    reliability=ReliabilityPolicy.RELIABLE,
)
TF_QOS = QoSProfile(depth=100)
TF_STATIC_QOS = QoSProfile(
    depth=1,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    reliability=ReliabilityPolicy.RELIABLE,
)
NO_PUBLISHER_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
NO_SUBSCRIPTION_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)
