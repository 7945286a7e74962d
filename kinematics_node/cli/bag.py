"""`kinematics bag RECORDING... --out OUT`: forward kinematics of recorded joint_states, without ROS.

Each recording (a rosbag2 directory; a folder of them counts as each) becomes a new recording in
MCAP storage with everything copied and ee_pose, ee_twist, /tf and /tf_static added
(`kinematics_node.jobs.recordings`). One recording: OUT is the output recording. Several: OUT is a
folder, each output named after its input, and the recordings run on the local cores, one
process each, or with --scheduler on a Dask cluster (`jobs.tasks`; so does one recording).

Needs rosbags (`pip install 'kinematics_service[bags]'`); matplotlib for --plot; tqdm draws the
progress bar when installed and stderr is a terminal.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core import KinematicsError

INSTALL = "pip install 'kinematics_service[bags]'"

EXAMPLES = """examples:
  kinematics bag run1 --out run1-kinematics                 # the robot from its /robot_description
  kinematics bag run1 --out run1-kin --robot panda --tip panda_hand_tcp --csv run1.csv
  kinematics bag run1 --out run1-kin --urdf my_arm.urdf.xacro --plot run1.png
  kinematics bag runs/ --out runs-kinematics                # every recording in runs/

Open the output in Foxglove (3D panel: /tf; plots: /ee_pose, /ee_twist) or replay it with
ros2 bag play for RViz: the robot moves without robot_state_publisher.
"""


class BagError(KinematicsError):
    """A usage problem of `kinematics bag`, said in one line (main prints it, exit status 1)."""


def add_parser(commands: Any) -> None:
    """Add the `bag` command to main.py's subcommands."""
    bag = commands.add_parser(
        "bag",
        help="forward kinematics of a rosbag2 recording: ee_pose, ee_twist, /tf added",
        description="Read joint_states from rosbag2 recordings (sqlite3 or MCAP) and write new\n"
        "recordings (MCAP) with every message copied and ee_pose, ee_twist, /tf and /tf_static\n"
        "added, stamped like the joint_states; report the stream, singularities, joints near\n"
        "their limits and the tool's peak speed. No ROS installation needed (rosbags).",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    bag.add_argument(
        "recordings", nargs="+", metavar="RECORDING", help="rosbag2 directories or folders of them"
    )
    bag.add_argument(
        "--out", required=True, metavar="OUT", help="output recording (folder for several)"
    )
    robot = bag.add_mutually_exclusive_group()
    robot.add_argument(
        "--urdf",
        metavar="FILE",
        help="URDF or xacro file (default: the recording's /robot_description)",
    )
    robot.add_argument(
        "--robot", metavar="NAME", help="a bundled robot: ur5e, panda, iiwa14, scara, planar3r"
    )
    bag.add_argument("--base", metavar="LINK", help="base link (default: the root link)")
    bag.add_argument("--tip", metavar="LINK", help="tip link (default: the single leaf)")
    bag.add_argument(
        "--joint-states",
        default="/joint_states",
        metavar="TOPIC",
        help="joint_states topic (default: %(default)s)",
    )
    bag.add_argument(
        "--namespace", default="", metavar="NS", help="write /NS/ee_pose and /NS/ee_twist"
    )
    bag.add_argument(
        "--twist-frame", choices=("world", "body"), default="world", help="as the node's parameter"
    )
    bag.add_argument(
        "--csv", metavar="FILE", help="a table: one row per joint_states message (one recording)"
    )
    bag.add_argument(
        "--plot",
        metavar="FILE",
        help="a picture of the tool's path, speed and conditioning (one recording)",
    )
    bag.add_argument(
        "--singular-condition",
        type=float,
        default=100.0,
        metavar="K",
        help="condition number that counts as near a singularity (default: %(default)g)",
    )
    bag.add_argument(
        "--near-limit",
        type=float,
        default=0.05,
        metavar="D",
        help="distance to a position limit that counts as near [rad or m] (default: %(default)g)",
    )
    bag.add_argument("--force", action="store_true", help="replace existing outputs")
    bag.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the recordings on a Dask cluster (e.g. tcp://host:8786; needs "
        "'kinematics_service[dask]')",
    )
    bag.add_argument(
        "--jobs",
        type=int,
        default=0,
        metavar="N",
        help="processes for several recordings (default: the cores)",
    )


def add_record_demo_parser(commands: Any) -> None:
    """Add `record-demo` (a recording of the simulated arm, to try `bag` on) to the commands."""
    demo = commands.add_parser(
        "record-demo",
        help="write a rosbag2 recording of the simulated arm, to try kinematics bag on",
        description="Write a rosbag2 recording (MCAP) of a bundled robot's simulated demo motion:\n"
        "/joint_states with velocities at --rate and its /robot_description. No ROS needed.",
        epilog="example:\n  kinematics record-demo demo_run --robot ur5e --duration 60\n"
        "  kinematics bag demo_run --out demo_run-kinematics --plot demo_run.png",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    demo.add_argument("out", metavar="OUT", help="the recording to write (a new directory)")
    demo.add_argument("--robot", default="ur5e", help="a bundled robot (default: %(default)s)")
    demo.add_argument("--duration", type=float, default=60.0, help="seconds (default: %(default)g)")
    demo.add_argument(
        "--rate", type=float, default=1000.0, help="joint_states rate [Hz] (default: %(default)g)"
    )


def run_record_demo(args: argparse.Namespace) -> int:
    """Run `kinematics record-demo`."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise BagError(f"kinematics record-demo needs rosbags: {INSTALL}") from None
    from ..sim.recording import write_demo_recording

    count = write_demo_recording(Path(args.out), args.robot, args.duration, args.rate)
    print(
        f"{args.out}: {count} joint_states of the simulated {args.robot} over {args.duration:g} s"
    )
    return 0


def _description(args: argparse.Namespace) -> tuple[str | None, str]:
    if args.urdf:
        from ..service.description_file import read_description_file

        return read_description_file(args.urdf).xml, f"--urdf {args.urdf}"
    if args.robot:
        from ..sim.robots import robot_path

        return robot_path(args.robot).read_text(encoding="utf-8"), f"--robot {args.robot}"
    return None, ""


def _tip(args: argparse.Namespace) -> str | None:
    if args.tip is None and args.robot:
        from ..sim.robots import default_chain_links

        return default_chain_links(args.robot)[1]
    return args.tip


def run(args: argparse.Namespace) -> int:
    """Run `kinematics bag`; errors raise (main prints them as one line, exit status 1)."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise BagError(f"kinematics bag needs rosbags: {INSTALL}") from None
    from ..jobs.recordings.job import BagOptions, recordings_in

    for value, name in (
        (args.singular_condition, "--singular-condition"),
        (args.near_limit, "--near-limit"),
    ):
        if not value > 0 or value == float("inf"):
            raise BagError(f"{name} {value}: expected a finite number > 0")
    sources = recordings_in([Path(p) for p in args.recordings])
    if not sources:
        raise BagError(
            f"no rosbag2 recording (a directory with metadata.yaml) in {args.recordings}"
        )
    text, where = _description(args)
    options = BagOptions(
        description=text,
        description_source=where,
        base_link=args.base,
        tip_link=_tip(args),
        joint_states=args.joint_states,
        namespace=args.namespace,
        twist_frame=args.twist_frame,
        force=args.force,
        csv=None if args.csv is None else Path(args.csv),
        singular_condition=args.singular_condition,
        near_limit=args.near_limit,
    )
    if args.plot:
        from ..sim.demo import check_matplotlib, check_picture_path

        try:
            check_matplotlib()
            check_picture_path(args.plot)
        except ValueError as exc:
            raise BagError(str(exc)) from None
    out = Path(args.out)
    first = Path(args.recordings[0])
    if len(args.recordings) == 1 and ((first / "metadata.yaml").is_file() or not first.is_dir()):
        if args.scheduler is None:
            return _one(sources[0], out, options, args.plot)
        if args.plot:
            raise BagError("--plot draws in this process: give it without --scheduler")
        return _on_cluster([(sources[0].resolve(), out.resolve(), options)], args.scheduler)
    if args.csv or args.plot:
        raise BagError("--csv and --plot take one recording; give them with one RECORDING")
    return _many(sources, out, options, args.jobs or os.cpu_count() or 1, args.scheduler)


def _progress(label: str) -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """A progress bar on a terminal (tqdm where installed), else nothing."""
    if not sys.stderr.isatty():
        return None, lambda: None
    try:
        from tqdm import tqdm
    except ImportError:
        return None, lambda: None
    bar = tqdm(total=0, unit="msg", unit_scale=True, desc=label, leave=False, file=sys.stderr)

    def update(done: int, total: int) -> None:
        bar.total = total or None
        bar.n = done
        bar.refresh()

    return update, bar.close


def _one(source: Path, out: Path, options: Any, plot: str | None) -> int:
    from ..jobs.recordings.job import process_recording

    update, close = _progress(source.name)
    try:
        result = process_recording(source, out, options, progress=update)
    finally:
        close()
    print(result.report())
    if plot:
        from ..jobs.recordings.picture import draw

        draw(result, Path(plot))
        print(f"picture: {plot}")
    return 0


def _task(job: tuple[Path, Path, Any]) -> str:
    """One recording, in a process or on a Dask worker of its own: its report."""
    from ..jobs.recordings.job import process_recording

    source, out, options = job
    return process_recording(source, out, options).report()


def _many(sources: list[Path], folder: Path, options: Any, jobs: int, scheduler: str | None) -> int:
    names = [s.name for s in sources]
    if len(set(names)) != len(names):
        raise BagError(f"two recordings share a name, and outputs are named after them: {names}")
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    # absolute paths: a Dask worker may run in another directory
    work = [(s.resolve(), (folder / s.name).resolve(), options) for s in sources]
    try:
        return _on_cluster(work, scheduler, jobs)
    except KinematicsError:  # nothing ran (no Dask, no scheduler): leave no empty folder
        if created and not any(folder.iterdir()):
            folder.rmdir()
        raise


def _on_cluster(
    work: list[tuple[Path, Path, Any]], scheduler: str | None, jobs: int | None = None
) -> int:
    """Each (recording, output, options) as a task: on the local cores, or on Dask."""
    from ..jobs.tasks import run_tasks

    failed = 0
    for outcome in run_tasks(_task, work, scheduler=scheduler, processes=jobs):
        if outcome.error is None:
            print(outcome.result, flush=True)
            continue
        failed += 1
        why = " ".join(str(outcome.error).split()) or type(outcome.error).__name__
        print(f"kinematics: error: {outcome.item[0]}: {why}", file=sys.stderr, flush=True)
    if failed:
        print(f"kinematics: {failed} of {len(work)} recordings failed", file=sys.stderr)
    return 1 if failed else 0
