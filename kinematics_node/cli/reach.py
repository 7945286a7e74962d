"""`kinematics reach --robot NAME | --urdf FILE --out MAP.h5`: a reachability map of a chain.

The job is `kinematics_node.jobs.maps.build.build_map`: voxels over the chain's reach, N tool
orientations at each, in chunks on the local cores or with --scheduler on a Dask cluster,
written to MAP.h5 (Reuleaux's layout; h5py, `pip install 'kinematics_service[maps]'`) chunk by
chunk, with MAP.npz beside it. Run the same command again after an interruption: the chunks
done are kept. A progress bar (tqdm) on a terminal; a summary at the end.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core import KinematicsError

EXAMPLES = """examples:
  kinematics reach --robot ur5e --out ur5e.h5                      # 5 cm, 50 orientations
  kinematics reach --robot ur5e --resolution 0.025 --out ur5e-2.5cm.h5
  kinematics reach --urdf my_arm.urdf --tip tool0 --directions 100 --rolls 4 --out arm.h5
  kinematics reach --robot iiwa14 --out iiwa.h5 --scheduler tcp://10.0.0.5:8786   # Dask

Interrupted (Ctrl-C)? Run the same command again: the chunks done are kept. MAP.h5 has
Reuleaux's /Spheres and /Poses (its RViz and base placement plugins read them), our arrays in
/KinematicsService; MAP.npz beside it holds the same arrays.
"""


class ReachError(KinematicsError):
    """A usage problem of `kinematics reach`, said in one line (main prints it, exit status 1)."""


def _resolution(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a finite length > 0 [m]")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number ≥ 1")
    return value


def add_parser(commands: Any) -> None:
    """Add the `reach` command to main.py's subcommands."""
    reach = commands.add_parser(
        "reach",
        help="a reachability map of a chain (Reuleaux's HDF5 layout), on local cores or Dask",
        description="Map where a chain's tool reaches and in which orientations: voxels over its\n"
        "reach, tool orientations spread over the sphere of approach directions at each, solved\n"
        "by batched IK (closed form where the arm has one). Per voxel: Reuleaux's reachability\n"
        "index D (share of orientations reached x 100), the best manipulability, the number of\n"
        "solutions. Chunks of voxels run on the local cores or on a Dask cluster; the file is\n"
        "written chunk by chunk and an interrupted map resumes.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    robot = reach.add_mutually_exclusive_group(required=True)
    robot.add_argument("--urdf", metavar="FILE", help="URDF or xacro file")
    robot.add_argument(
        "--robot", metavar="NAME", help="a bundled robot: ur5e, panda, iiwa14, scara, planar3r"
    )
    reach.add_argument("--base", metavar="LINK", help="base link (default: the root link)")
    reach.add_argument("--tip", metavar="LINK", help="tip link (default: the single leaf)")
    reach.add_argument(
        "--resolution",
        type=_resolution,
        default=0.05,
        metavar="M",
        help="voxel edge [m] (default: %(default)g)",
    )
    reach.add_argument(
        "--directions",
        type=_count,
        default=50,
        metavar="N",
        help="approach directions per voxel (default: %(default)d, Reuleaux's)",
    )
    reach.add_argument(
        "--rolls",
        type=_count,
        default=1,
        metavar="N",
        help="rotations about each approach direction (default: %(default)d)",
    )
    reach.add_argument(
        "--out", required=True, metavar="MAP", help="MAP.h5 (with MAP.npz beside it) or MAP.npz"
    )
    reach.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the chunks on a Dask cluster (e.g. tcp://host:8786; needs "
        "'kinematics_service[dask]')",
    )
    reach.add_argument(
        "--processes",
        type=_count,
        metavar="N",
        help="local processes (default: the cores; not with --scheduler)",
    )
    reach.add_argument(
        "--chunk-voxels",
        type=_count,
        default=None,
        metavar="N",
        help="voxels per task (default: 2048; a resumed map keeps its own)",
    )
    reach.add_argument(
        "--force", action="store_true", help="start again over an existing MAP made otherwise"
    )
    reach.add_argument(
        "--plot", metavar="FILE", help="a picture: slices through the map coloured by D"
    )
    reach.add_argument(
        "--markers",
        metavar="FILE",
        help="an MCAP file with the map as a MarkerArray (cubes coloured by D) for Foxglove and "
        "RViz (needs 'kinematics_service[bags]')",
    )


def _robot(args: argparse.Namespace) -> Any:
    """The chain to map; the library's errors about links and files in this command's words."""
    from ..core.exceptions import RobotDescriptionError, UnknownNameError
    from ..jobs.maps.build import MapRobot

    try:
        if args.robot:
            from ..sim.robots import default_chain_links, robot_path

            text = robot_path(args.robot).read_text(encoding="utf-8")
            base, tip = default_chain_links(args.robot)
            return MapRobot.from_text(args.robot, text, args.base or base, args.tip or tip)
        from ..service.description_file import read_description_file

        text = read_description_file(args.urdf).xml
        return MapRobot.from_text(Path(args.urdf).stem, text, args.base, args.tip)
    except UnknownNameError as exc:
        flags = [f for f, v in (("--base", args.base), ("--tip", args.tip)) if v == exc.name]
        if exc.kind != "link" or not flags:
            raise
        raise ReachError(f"{flags[0]}: {exc}") from None
    except RobotDescriptionError as exc:
        raise ReachError(str(exc).replace("robot_description_file", "--urdf")) from None


def _progress() -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """A progress bar of chunks on a terminal (tqdm where installed), else nothing."""
    if not sys.stderr.isatty():
        return None, lambda: None
    try:
        from tqdm import tqdm
    except ImportError:
        return None, lambda: None
    bar = tqdm(total=0, unit="chunk", desc="reach", leave=False, file=sys.stderr)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return update, bar.close


def _chunk_voxels(args: argparse.Namespace, out: Path) -> int:
    """--chunk-voxels, else the one of the map being resumed, else the default."""
    from ..jobs.maps.build import CHUNK_VOXELS
    from ..jobs.maps.storage import stored_chunk_voxels

    if args.chunk_voxels is not None:
        return int(args.chunk_voxels)
    if out.suffix.lower() != ".npz" and out.is_file() and not args.force:
        stored = stored_chunk_voxels(out)  # None: the job says what is wrong with the file
        if stored is not None:
            return stored
    return CHUNK_VOXELS


def run(args: argparse.Namespace) -> int:
    """Run `kinematics reach`; errors raise (main prints them as one line, exit status 1)."""
    from ..jobs.maps.build import MapInterrupted, build_map

    out = Path(args.out)
    if args.scheduler and args.processes:
        raise ReachError("--processes is for the local cores: give it without --scheduler")
    _check_outputs(args)
    robot = _robot(args)
    update, close = _progress()
    try:
        run_ = build_map(
            robot,
            out,
            args.resolution,
            args.directions,
            args.rolls,
            scheduler=args.scheduler,
            processes=args.processes,
            chunk_voxels=_chunk_voxels(args, out),
            force=args.force,
            progress=update,
        )
    except MapInterrupted as exc:
        print(f"kinematics: {exc}", file=sys.stderr)
        return 130  # 128 + SIGINT
    finally:
        close()  # the bar goes before the lines that follow
    print(summary(run_))
    if args.plot:
        from ..jobs.maps.picture import draw_map

        draw_map(run_.reach_map, args.plot)
        print(f"picture written to {args.plot}")
    if args.markers:
        from ..jobs.maps.markers import write_map_markers

        write_map_markers(run_.reach_map, args.markers)
        print(f"markers (/reachability_map) written to {args.markers}")
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """--plot and --markers refused before the map is made, not after (matplotlib or rosbags
    missing, a folder that does not exist, markers over an existing file)."""
    if args.plot:
        from ..sim.demo import check_matplotlib, check_picture_path

        try:
            check_matplotlib()
            check_picture_path(args.plot)
        except ValueError as exc:
            raise ReachError(str(exc).replace("--out", "--plot")) from None
    if args.markers:
        markers = Path(args.markers)
        try:
            import rosbags  # noqa: F401
        except ImportError:
            raise ReachError(
                "--markers needs rosbags: pip install 'kinematics_service[bags]'"
            ) from None
        if markers.exists():
            raise ReachError(f"--markers: {markers} exists: give a new file name")
        if not markers.parent.is_dir():
            raise ReachError(f"--markers: {markers.parent} is not a folder")


def summary(run: Any) -> str:
    """The lines printed at the end: the map's size, reach, time and where it went."""
    m = run.reach_map
    M, K = m.reached.shape
    reachable = 100.0 * float(m.reached.mean()) if m.reached.size else 0.0
    some = int((m.reached.any(axis=1)).sum())
    rate = run.problems / run.seconds if run.seconds > 0 else float("nan")
    kept = f" ({run.kept} of {run.chunks} chunks kept from before)" if run.kept else ""
    solved = (
        f"solved {run.problems} IK problems in {run.seconds:.1f} s ({rate:,.0f} /s){kept}"
        if run.problems
        else f"nothing left to solve: {run.chunks} of {run.chunks} chunks were done"
    )
    files = f"{run.out}" + (
        f" and {run.out.with_suffix('.npz')}" if run.out.suffix.lower() != ".npz" else ""
    )
    return "\n".join(
        [
            f"{m.robot} {m.base_link} -> {m.tip_link}: {M} voxels of {m.resolution:g} m x {K} "
            f"orientations ({m.directions} directions x {m.rolls} rolls), {m.method}",
            f"reachable: {reachable:.1f} % of the {M * K} poses; {some} voxels with D > 0",
            solved,
            f"wrote {files}",
        ]
    )
