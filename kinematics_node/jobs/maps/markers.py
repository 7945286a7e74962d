"""A reachability map as an MCAP file that Foxglove and RViz (through `ros2 bag play`) open: one
visualization_msgs/MarkerArray (`msg_adapters.reach_markers`: cubes coloured by D) on
/reachability_map, offered transient local (depth 1), so that a player latches it for late
subscribers as robot_state_publisher's /robot_description is.

The file is one rosbag2 MCAP file written by rosbags (the `bags` extra, as `kinematics bag`):
Jazzy's message definitions, the QoS in the channel's metadata and rosbag2's own metadata record,
so `ros2 bag play FILE.mcap` plays it and Foxglove shows it in a 3D panel.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from msg_adapters.markers import MarkerTypes
from msg_adapters.reach_markers import reach_map_markers

from ...core.exceptions import KinematicsError
from ..recordings.job import latched_qos
from .reach_map import ReachMap

TOPIC = "/reachability_map"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
INSTALL = "pip install 'kinematics_service[bags]'"


class MarkersError(KinematicsError):
    """The markers file cannot be written (one line)."""


def map_marker_array(reach_map: ReachMap, types: MarkerTypes, frame_id: str | None = None) -> Any:
    """The map's MarkerArray built from message classes `types` (`msg_adapters.markers.
    MarkerTypes`: rclpy's or a rosbags typestore's), in `frame_id` (default: its base link)."""
    return reach_map_markers(
        types,
        reach_map.centres,
        reach_map.index,
        reach_map.resolution,
        frame_id or reach_map.base_link,
    )


def write_map_markers(
    reach_map: ReachMap, path: str | Path, topic: str = TOPIC, frame_id: str | None = None
) -> int:
    """Write the map's MarkerArray to the MCAP file `path` (module docstring); the number of
    cubes (voxels with D > 0).

    Raises:
        MarkersError: rosbags is missing, `path` exists, or its folder does not.
    """
    try:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise MarkersError(f"the map's markers need rosbags: {INSTALL}") from None
    out = Path(path)
    if out.exists():
        raise MarkersError(f"{out} exists: give a new file name for the markers")
    if not out.parent.is_dir():
        raise MarkersError(f"{out.parent} is not a folder: cannot write the markers there")
    store = get_typestore(Stores.ROS2_JAZZY)
    message = map_marker_array(reach_map, MarkerTypes.from_typestore(store), frame_id)
    data = store.serialize_cdr(message, MARKER_ARRAY)
    with tempfile.TemporaryDirectory(dir=out.parent, prefix=f".{out.stem}-") as folder:
        bag = Path(folder) / "markers"
        writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
        writer.open()
        try:
            connection = writer.add_connection(
                topic, MARKER_ARRAY, typestore=store, offered_qos_profiles=latched_qos()
            )
            writer.write(connection, time.time_ns(), data)
        finally:
            writer.close()
        shutil.move(str(bag / "markers.mcap"), str(out))
    return len(message.markers[0].points)
