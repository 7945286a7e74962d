"""A reachability map as a visualization_msgs/MarkerArray, without rclpy (duck-typed classes).

One CUBE_LIST marker (namespace "reachability", id 0) in the map's base frame: a cube of edge
`resolution` at each voxel centre with D > 0, coloured by the reachability index D
(`index_colours`: red at D → 0, yellow at 50 %, green at 100 %, the node's condition colours read
the other way round: green is good) and half transparent, the more the lower D, so that the
dexterous core shows through the thin shell of low D around it. The pose is the identity, the
stamp zero (RViz then draws it with the latest transform of the frame), lifetime zero (forever).
`kinematics reach --markers` writes it into an MCAP file and `kinematics ros reach-markers`
publishes it, transient local.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .markers import MarkerTypes, marker

NAMESPACE = "reachability"
#: Opacity of a cube at D → 0 and at D = 100 % (linear between).
ALPHA_LOW, ALPHA_HIGH = 0.15, 0.75
_CUBE_LIST = 6  # visualization_msgs/Marker.CUBE_LIST


def index_colours(index: ArrayLike) -> NDArray[np.float64]:
    """(N, 4) RGBA of reachability indices D [%] (N,): red → yellow (50 %) → green (100 %),
    alpha from `ALPHA_LOW` to `ALPHA_HIGH`."""
    d = np.clip(np.asarray(index, dtype=np.float64) / 100.0, 0.0, 1.0)
    r = np.clip(2.0 * (1.0 - d), 0.0, 1.0)
    g = np.clip(2.0 * d, 0.0, 1.0) * (1.0 - 0.2 * d)  # a darker green at the top, read on white
    b = np.zeros_like(d)
    a = ALPHA_LOW + (ALPHA_HIGH - ALPHA_LOW) * d
    return np.stack([r, g, b, a], axis=-1)


def reach_map_markers(
    types: MarkerTypes,
    centres: ArrayLike,
    index: ArrayLike,
    resolution: float,
    frame_id: str,
    stamp_sec: int = 0,
    stamp_nanosec: int = 0,
) -> Any:
    """visualization_msgs/MarkerArray of a map (module docstring): voxel `centres` (M, 3) [m] in
    `frame_id` and their reachability indices D (M,) [%]; only voxels with D > 0 are drawn."""
    c = np.asarray(centres, dtype=np.float64)
    d = np.asarray(index, dtype=np.float64)
    keep = d > 0.0
    c, rgba = c[keep], index_colours(d[keep])
    edge = float(resolution)
    cubes = marker(
        types,
        frame_id,
        (stamp_sec, stamp_nanosec),
        0,
        _CUBE_LIST,
        types.Pose(
            position=types.Point(x=0.0, y=0.0, z=0.0),
            orientation=types.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
        ),
        [edge, edge, edge],
        (1.0, 1.0, 1.0, 1.0),
        [types.Point(x=x, y=y, z=z) for x, y, z in c.tolist()],
        [types.ColorRGBA(r=r, g=g, b=b, a=a) for r, g, b, a in rgba.tolist()],
        ns=NAMESPACE,
    )
    return types.MarkerArray(markers=[cubes])
