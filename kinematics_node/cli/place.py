"""`kinematics place MAP TASKS`: where to put the robot's base on the floor so that it reaches the
task poses, from a reachability map (`kinematics_node.jobs.maps.placement`), verified by IK with
the map's robot (a bundled one by the map's name, or --robot/--urdf).

Needs nothing beyond the core; matplotlib for --plot (the `demo` extra).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core import KinematicsError
from ..jobs.maps.reach_map import ReachMap

EXAMPLES = """examples:
  kinematics reach --robot ur5e --out ur5e.h5                  # the map first
  kinematics place ur5e.h5 stations.csv                        # verified with the map's robot
  kinematics place ur5e.h5 stations.csv --top 5 --plot place.png
  kinematics place my_arm.h5 stations.csv --urdf my_arm.urdf --tip tool0 --json

TASKS is a CSV file, one pose a line in the world frame: x,y,z [m],qx,qy,qz,qw (a header line
is allowed; quaternions are normalised). The base stands upright on the floor (z = 0); placements
are x, y on the map's grid and --yaw-steps yaws.
"""


class PlaceError(KinematicsError):
    """A usage problem of `kinematics place`, said in one line."""


def add_parser(commands: Any) -> None:
    """Add the `place` command to main.py's subcommands."""
    place = commands.add_parser(
        "place",
        help="base placement: where on the floor the robot reaches the task poses, from a map",
        description="Rank floor placements of the robot's base (x, y, yaw) by how many task\n"
        "poses the reachability map says they reach (Reuleaux's inverse reachability), then\n"
        "verify the best by IK on the task poses themselves and rank them by what IK reaches.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    place.add_argument("map", metavar="MAP", help="a reachability map (kinematics reach --out)")
    place.add_argument("tasks", metavar="TASKS", help="CSV: x,y,z,qx,qy,qz,qw per line")
    robot = place.add_mutually_exclusive_group()
    robot.add_argument(
        "--robot",
        metavar="NAME",
        help="bundled robot to verify with (default: the map's, when bundled)",
    )
    robot.add_argument("--urdf", metavar="FILE", help="URDF or xacro file to verify with")
    place.add_argument("--base", metavar="LINK", help="base link (default: the map's)")
    place.add_argument("--tip", metavar="LINK", help="tip link (default: the map's)")
    place.add_argument(
        "--top", type=_whole, default=10, metavar="N", help="placements shown (default: 10)"
    )
    place.add_argument(
        "--yaw-steps",
        type=_whole,
        default=36,
        metavar="N",
        help="yaws tried per position, 360/N degrees apart (default: 36)",
    )
    place.add_argument("--no-verify", action="store_true", help="rank by the map alone (no IK)")
    place.add_argument("--plot", metavar="FILE", help="a picture of the tasks and the placements")
    place.add_argument("--json", action="store_true", help="JSON output")


def _whole(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number ≥ 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number ≥ 1, got {text!r}")
    return value


def read_map(path: str | Path) -> ReachMap:
    """The map at `path` (`.h5` or `.npz` of `kinematics reach`)."""
    from ..jobs.maps.storage import MapFileError
    from ..jobs.maps.storage import read_map as read_stored

    p = Path(path)
    if not p.exists():
        raise PlaceError(f"no map at {str(path)!r} (make one with kinematics reach)")
    try:
        return read_stored(p)
    except MapFileError as exc:
        raise PlaceError(str(exc)) from None


def _chain(
    args: argparse.Namespace, reach_map: ReachMap, load_chain: Callable[[argparse.Namespace], Any]
) -> tuple[Any, str]:
    """The chain to verify with and, when there is none, why."""
    if args.no_verify:
        return None, "--no-verify"
    args.dh = None
    if not (args.robot or args.urdf):
        from ..sim.robots import available_robots

        if reach_map.robot not in available_robots():
            return None, (
                f"the map's robot {reach_map.robot!r} is not bundled: give --robot or --urdf"
            )
        args.robot = reach_map.robot
        args.base = args.base or reach_map.base_link
        args.tip = args.tip or reach_map.tip_link
    elif args.urdf:  # a file's own default chain may not be the map's: the map's links
        args.base = args.base or reach_map.base_link
        args.tip = args.tip or reach_map.tip_link
    return load_chain(args), ""


def run(
    args: argparse.Namespace,
    load_chain: Callable[[argparse.Namespace], Any],
    dump_json: Callable[[Any], str],
) -> int:
    """Run `kinematics place` with main.py's `load_chain` (the robot options) and `dump_json`;
    errors raise (main prints them as one line, status 1)."""
    from ..jobs.maps.placement import place_base, read_tasks

    if args.plot:
        from ..sim.demo import check_matplotlib, check_picture_path

        try:
            check_matplotlib()
            check_picture_path(args.plot)
        except ValueError as exc:
            raise PlaceError(str(exc).replace("--out", "--plot")) from None
    tasks = read_tasks(args.tasks)
    reach_map = read_map(args.map)
    chain, why = _chain(args, reach_map, load_chain)
    result = place_base(
        reach_map,
        tasks,
        chain,
        yaw_steps=args.yaw_steps,
        top=args.top,
        unverified_reason=why,
    )
    if args.json:
        print(dump_json(result.as_dict(args.top)))
    else:
        print(result.report(args.top))
    if args.plot:
        from ..jobs.maps.picture import draw_placement

        draw_placement(reach_map, result, tasks, args.plot, top=min(args.top, 5))
        print(f"picture: {args.plot}", file=sys.stderr if args.json else sys.stdout)
    return 0


__all__ = ["PlaceError", "add_parser", "read_map", "run"]
