"""`kinematics bag` beside a bare rosbags copy of the same recording, in one run.

The recording: joint_states of a 7-joint arm (the bundled Panda) at 1 kHz with positions and
velocities, its /robot_description, MCAP storage (default one hour: 3.6 million messages; --seconds
for less). Each run is a process of its own, alternated, timed whole (start-up included), with
its peak memory (ru_maxrss):

* copy: rosbags' Reader and Writer, every message read and written unchanged, one at a time: the
  least any tool that rewrites a recording in Python does;
* bag: `kinematics bag REC --out OUT --tip panda_hand_tcp` (pose, twist, /tf and /tf_static
  written), and the job's own split of its time (read, decode, kinematics, write).

Reported as the ratio bag / copy, the issue's target being at most 3x and under 2 minutes here.

    python -W ignore benchmarks/bag_benchmark.py [--seconds 3600] [--repeats 2] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

COPY = """
import sys
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
src, out = sys.argv[1], sys.argv[2]
with Reader(src) as reader, Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
    conns = {c.id: writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, rihs01=c.digest,
             offered_qos_profiles=c.ext.offered_qos_profiles) for c in reader.connections}
    for c, t, raw in reader.messages():
        writer.write(conns[c.id], t, raw)
import json, resource
print(json.dumps({"rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""

BAG = """
import json, sys
from pathlib import Path
from kinematics_node.jobs.recordings.job import BagOptions, process_recording
result = process_recording(Path(sys.argv[1]), Path(sys.argv[2]), BagOptions(tip_link="panda_hand_tcp"))
import resource
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"seconds": result.seconds, "posed": result.findings.posed, "rss_mb": rss}))
"""


def make_recording(path: Path, seconds: float) -> int:
    """A recording of `seconds` of 1 kHz joint_states (serialized by rosbags once, then the
    stamps and values of every message written into copies of those bytes)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from kinematics_node.core import SerialChain
    from kinematics_node.jobs.recordings.mcap_batches import write_rows
    from kinematics_node.sim.robots import robot_path

    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    text = robot_path("panda").read_text(encoding="utf-8")
    chain = SerialChain.from_urdf(text, None, "panda_hand_tcp")
    n = chain.dof
    count = int(seconds * 1000)
    template = T["sensor_msgs/msg/JointState"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=""
        ),
        name=list(chain.joint_names),
        position=np.full(n, 0.125),
        velocity=np.full(n, 0.25),
        effort=np.zeros(0),
    )
    raw = bytes(store.serialize_cdr(template, "sensor_msgs/msg/JointState"))
    at_pos = raw.find(np.full(n, 0.125).tobytes())
    at_vel = raw.find(np.full(n, 0.25).tobytes())
    epoch = 1_733_000_000 * 10**9
    mid = (chain.lower + chain.upper) / 2
    half = 0.45 * (chain.upper - chain.lower)
    w = 0.3 + 0.05 * np.arange(n)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        desc = writer.add_connection("/robot_description", "std_msgs/msg/String", typestore=store)
        writer.write(
            desc,
            epoch,
            store.serialize_cdr(T["std_msgs/msg/String"](data=text), "std_msgs/msg/String"),
        )
        js = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        for start in range(0, count, 50_000):
            k = np.arange(start, min(count, start + 50_000))
            t = k[:, None] * 1e-3
            rows = np.tile(np.frombuffer(raw, np.uint8), (len(k), 1))
            stamp = epoch + k * 1_000_000
            sec, nanosec = np.divmod(stamp, 10**9)
            rows[:, 4:8] = sec.astype("<i4")[:, None].view(np.uint8)
            rows[:, 8:12] = nanosec.astype("<u4")[:, None].view(np.uint8)
            q = mid + half * np.sin(w * t + np.arange(n))
            qd = half * w * np.cos(w * t + np.arange(n))
            rows[:, at_pos : at_pos + 8 * n] = q.astype("<f8").view(np.uint8)
            rows[:, at_vel : at_vel + 8 * n] = qd.astype("<f8").view(np.uint8)
            write_rows(writer, js, stamp + 50_000, rows)
    return count


def timed(script: str, src: Path, out: Path) -> tuple[float, dict]:
    """(wall seconds, what the script printed last as JSON) of `script` run as a process of its
    own (each reports its own peak RSS)."""
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    run = subprocess.run(
        [sys.executable, "-c", script, str(src), str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    wall = time.perf_counter() - t0
    if run.returncode:
        raise SystemExit(run.stderr)
    return wall, json.loads(run.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("--seconds", type=float, default=3600.0, help="recorded time at 1 kHz")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--keep", type=Path, help="keep the recording here (reused if present)")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bag_benchmark-"))
    src = args.keep or work / "recording"
    try:
        if not (src / "metadata.yaml").is_file():
            t0 = time.perf_counter()
            count = make_recording(src, args.seconds)
            print(f"recording: {count} joint_states ({time.perf_counter() - t0:.1f} s to write)")
        size = sum(p.stat().st_size for p in src.iterdir()) / 1e6
        print(f"input: {src} ({size:.0f} MB)")
        copies, bags, parts, rss_copy = [], [], [], []
        for _ in range(args.repeats):
            wall, out = timed(COPY, src, work / "copy")
            copies.append(wall)
            rss_copy.append(out["rss_mb"])
            wall, out = timed(BAG, src, work / "bag")
            bags.append(wall)
            parts.append(out)
        n = parts[0]["posed"]
        best_copy, best_bag = min(copies), min(bags)
        print(f"rosbags copy:    {best_copy:7.1f} s  ({best_copy / n * 1e6:.2f} us a joint_states)")
        print(f"kinematics bag:  {best_bag:7.1f} s  ({best_bag / n * 1e6:.2f} us a joint_states)")
        print(
            f"ratio bag / copy: {best_bag / best_copy:.2f}x (target <= 3x; runs: copy "
            f"{', '.join(f'{c:.1f}' for c in copies)} s, bag {', '.join(f'{b:.1f}' for b in bags)} s)"
        )
        split = min(parts, key=lambda p: sum(p["seconds"].values()))["seconds"]
        print(
            "the job's split: "
            + ", ".join(f"{k} {v:.1f} s ({v / n * 1e6:.2f} us)" for k, v in split.items())
        )
        print(
            f"peak RSS: bag {max(p['rss_mb'] for p in parts):.0f} MB, copy {max(rss_copy):.0f} MB"
        )
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
