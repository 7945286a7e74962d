"""`kinematics ros reach-markers MAP`: publish a reachability map as a MarkerArray (cubes coloured
by D, `jobs.maps.markers`) on /reachability_map, transient local, so that RViz or Foxglove started
later still gets it; stays up until Ctrl-C, or with --once until a subscriber has it. ROS is
imported inside the function only (`ros_commands` holds the arguments)."""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

from ..ros.client import RosClient, RosClientError


def reach_markers(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """Publish the map once, transient local (depth 1), and keep it offered."""
    from rclpy.duration import Duration
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from visualization_msgs.msg import MarkerArray

    from msg_adapters.markers import MarkerTypes

    from ..jobs.maps.markers import map_marker_array
    from .place import read_map

    reach_map = read_map(args.map)
    message = map_marker_array(reach_map, MarkerTypes.from_rclpy(), args.frame)
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    publisher = client.node.create_publisher(MarkerArray, args.topic, qos)
    publisher.publish(message)
    cubes = len(message.markers[0].points)
    frame = message.markers[0].header.frame_id
    topic = client.resolve(args.topic)
    if args.once:
        deadline = time.monotonic() + args.wait
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise RosClientError(f"no subscriber of {topic} within {args.wait:g} s")
            client.spin_once(0.05)
        publisher.wait_for_all_acked(Duration(seconds=args.wait))
        emit(f"{topic}: {cubes} cubes of {args.map} in {frame}, delivered")
        return 0
    emit(
        f"{topic}: {cubes} cubes of {args.map} in {frame}, transient local (late subscribers "
        "get it too); Ctrl-C ends"
    )
    try:
        while True:
            client.spin_once(0.2)
    except KeyboardInterrupt:
        return 0
