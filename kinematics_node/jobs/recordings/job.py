"""One recording in, one recording out: `kinematics bag RECORDING --out OUT`.

The input (a rosbag2 directory, sqlite3 or MCAP storage, any version rosbags reads) is read once,
in log-time order, a batch of `BATCH` messages at a time, so memory stays bounded whatever its
length. Every message is written to the output unchanged (bytes, log time, topic, type, QoS
metadata); the joint_states of each batch are decoded together (`msg_adapters.cdr`), turned into
the chain's motion (`joint_motion`) and the end effector's messages (`outputs`), and written in
batches (`mcap_batches`). The output is a new rosbag2 recording in MCAP storage, written to a
temporary directory beside OUT and renamed to OUT only when complete: a refusal or a crash leaves
no partial output, and the input is only ever read.

Refusals (`RecordingError`, one line each): not a recording (or a truncated or corrupt one), no
joint_states topic (listing the topics it has), chain joints never present (naming them), a
description that does not parse, an output that exists (without `force`).
"""

from __future__ import annotations

import csv
import math
import os
import shutil
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from msg_adapters.cdr import decode_joint_states, decode_string

from ...core import KinematicsError, SerialChain
from ...core.joint_transforms import JointTransforms
from ...core.urdf import RobotDescription
from .joint_motion import Counts, JointMotion, Motion
from .mcap_batches import write_rows
from .outputs import (
    MARKERS_TYPE,
    POSE_TYPE,
    TF_TYPE,
    TWIST_TYPE,
    Computed,
    Conditioning,
    EndEffector,
    Markers,
    Written,
    conditioning,
)
from .report import Findings

#: Messages read per batch: ~20 MB of joint_states of a 7-joint arm and what they give.
BATCH = 20_000

JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
STRING_TYPE = "std_msgs/msg/String"


class RecordingError(KinematicsError):
    """A recording that cannot be processed, said in one line."""


@dataclass(frozen=True)
class BagOptions:
    """What `process_recording` computes and writes.

    Attributes:
        description: URDF/xacro text of the robot; None: the recording's /robot_description.
        description_source: where `description` came from, for the report.
        base_link, tip_link: the chain's ends (None: as the node chooses them).
        joint_states: the joint_states topic (a leading "/" may be left out).
        namespace: a namespace for the added ee_pose and ee_twist ("" : /ee_pose, /ee_twist).
        twist_frame: "world" or "body", as the node's parameter.
        force: replace an existing output.
        csv: a table of every posed joint_states message (None: none).
        conditioning_rate_hz: how often the report samples the conditioning (its SVD costs ~9 µs
            a sample; the CSV has every row).
        singular_condition: condition number above which the arm is near a singularity.
        near_limit: distance [rad or m] to a position limit reported as near.
        markers_rate_hz: how often (per second of log time) the node's manipulability markers
            are written, on <namespace>/kinematics_node/markers, the topic the node publishes
            them on (0: none); coloured red from `singular_condition` on.
    """

    description: str | None = None
    description_source: str = ""
    base_link: str | None = None
    tip_link: str | None = None
    joint_states: str = "/joint_states"
    namespace: str = ""
    twist_frame: Literal["world", "body"] = "world"
    force: bool = False
    csv: Path | None = None
    conditioning_rate_hz: float = 100.0
    singular_condition: float = 100.0
    near_limit: float = 0.05
    markers_rate_hz: float = 10.0


@dataclass
class BagResult:
    """What a run did: the output, counts per added topic, the findings and the timings."""

    output: Path
    chain: SerialChain
    description_source: str
    counts: Counts
    findings: Findings
    written: dict[str, int] = field(default_factory=dict)
    copied: int = 0
    seconds: dict[str, float] = field(default_factory=dict)

    def report(self) -> str:
        chain = self.chain
        lines = [
            f"{self.output}: {self.copied} messages copied, "
            + ", ".join(f"{n} on {topic}" for topic, n in self.written.items()),
            f"robot: {self.description_source}; chain {chain.base_link} -> {chain.tip_link} "
            f"({chain.dof} joints)",
            self.findings.text(self.counts),
        ]
        return "\n".join(lines)


def _topic(name: str) -> str:
    return name if name.startswith("/") else "/" + name


def _open_reader(path: Path) -> Any:
    from rosbags.rosbag2 import Reader

    if not path.exists():
        raise RecordingError(f"{path}: no such file or directory")
    if path.is_file():
        raise RecordingError(
            f"{path} is a file: give the recording's directory (the one with metadata.yaml)"
        )
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags' ReaderError, or what a corrupt file raises inside it
        raise RecordingError(f"{path} is not a readable rosbag2 recording: {_line(exc)}") from None
    return reader


def _line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) < 300 else text[:297] + "..."


def _description(reader: Any, options: BagOptions) -> tuple[str, str]:
    if options.description is not None:
        return options.description, options.description_source
    connections = [
        c
        for c in reader.connections
        if c.topic == "/robot_description" and c.msgtype == STRING_TYPE
    ]
    for _, _, raw in reader.messages(connections=connections):
        return decode_string(raw), "the recording's /robot_description"
    raise RecordingError(
        "the recording has no /robot_description: give the robot with --urdf FILE or --robot NAME"
    )


def _chain(text: str, source: str, options: BagOptions) -> tuple[SerialChain, JointTransforms]:
    """The chain and the transforms of its links' joints (/tf, /tf_static), from one parse."""
    try:
        description = RobotDescription(text)
        chain = SerialChain.from_spec(description.chain_spec(options.base_link, options.tip_link))
        return chain, JointTransforms.of_links(description, chain.link_names)
    except KinematicsError as exc:
        raise RecordingError(f"the robot description ({source}) was refused: {exc}") from None


def _joint_state_connections(reader: Any, topic: str) -> list[Any]:
    found = [c for c in reader.connections if c.topic == topic and c.msgtype == JOINT_STATE_TYPE]
    if not found:
        topics = sorted({(c.topic, c.msgtype) for c in reader.connections})
        listed = ", ".join(f"{t} ({m})" for t, m in topics) or "none"
        raise RecordingError(
            f"the recording has no {topic} of type {JOINT_STATE_TYPE}; its topics: {listed}"
        )
    return found


class _Output:
    """The output recording: copies of the input's connections and the added topics."""

    def __init__(self, path: Path, reader: Any, added: dict[str, str]):
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        self.writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.store = get_typestore(Stores.ROS2_JAZZY)
        self.copy: dict[int, Any] = {}
        for c in reader.connections:
            self.copy[c.id] = self._connection(c)
        self.added: dict[str, Any] = {}
        for topic, msgtype in added.items():
            existing = [c for c in self.copy.values() if c.topic == topic]
            same = [c for c in existing if c.msgtype == msgtype]
            if same:  # the recording has /tf of its own: ours joins it
                self.added[topic] = same[0]
            elif existing:
                raise RecordingError(
                    f"the recording has {topic} of type {existing[0].msgtype}, where "
                    f"{msgtype} would be added: give --namespace"
                )
            else:
                self.added[topic] = self.writer.add_connection(
                    topic, msgtype, typestore=self.store, offered_qos_profiles=_qos(topic)
                )

    def _connection(self, c: Any) -> Any:
        ext = c.ext
        qos = list(getattr(ext, "offered_qos_profiles", []) or [])
        fmt = getattr(ext, "serialization_format", "cdr")
        if c.msgdef.data and c.digest:
            return self.writer.add_connection(
                c.topic,
                c.msgtype,
                msgdef=c.msgdef.data,
                rihs01=c.digest,
                serialization_format=fmt,
                offered_qos_profiles=qos,
            )
        if c.msgtype in self.store.types:  # an older recording without definitions
            return self.writer.add_connection(
                c.topic,
                c.msgtype,
                typestore=self.store,
                serialization_format=fmt,
                offered_qos_profiles=qos,
            )
        raise RecordingError(
            f"{c.topic} has type {c.msgtype}, whose definition the recording does not hold and "
            "rosbags does not know: it cannot be copied"
        )

    def rows(self, topic: str, written: Written) -> None:
        write_rows(self.writer, self.added[topic], written.log_time_ns, written.rows)

    def close(self) -> None:
        self.writer.close()


def _qos(topic: str) -> list[Any]:
    """Offered QoS metadata of an added topic: /tf_static transient local (as
    robot_state_publisher offers it, so a player latches it), the rest volatile, reliable."""
    return latched_qos() if topic == "/tf_static" else _offered(latched=False)


def latched_qos() -> list[Any]:
    """rosbags' QoS metadata of a transient-local publisher of depth 1 (a latched topic)."""
    return _offered(latched=True)


def _offered(latched: bool) -> list[Any]:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    never = QosTime(sec=2147483647, nsec=4294967295)  # rosbag2's "infinite" duration
    return [
        Qos(
            history=QosHistory.KEEP_LAST,
            depth=1 if latched else 100,
            reliability=QosReliability.RELIABLE,
            durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
            deadline=never,
            lifespan=never,
            liveliness=QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=never,
            avoid_ros_namespace_conventions=False,
        )
    ]


def _batches(reader: Any, size: int) -> Iterator[list[tuple[Any, int, bytes]]]:
    batch: list[tuple[Any, int, bytes]] = []
    try:
        for message in reader.messages():
            batch.append(message)
            if len(batch) >= size:
                yield batch
                batch = []
    except RecordingError:
        raise
    except Exception as exc:  # a truncated or corrupt file fails part-way
        raise RecordingError(f"the recording could not be read to its end: {_line(exc)}") from None
    if batch:
        yield batch


def _copy(output: _Output, batch: list[tuple[Any, int, bytes]]) -> None:
    """Every message of the batch, unchanged; equal-size runs of one connection in one go."""
    groups: dict[tuple[int, int], list[int]] = {}
    for i, (c, _, raw) in enumerate(batch):
        groups.setdefault((c.id, len(raw)), []).append(i)
    for (cid, size), members in groups.items():
        connection = output.copy[cid]
        if len(members) == 1 or size == 0:
            for i in members:
                output.writer.write(connection, batch[i][1], batch[i][2])
            continue
        times = np.fromiter((batch[i][1] for i in members), dtype=np.int64, count=len(members))
        rows = np.frombuffer(b"".join([batch[i][2] for i in members]), dtype=np.uint8)
        write_rows(output.writer, connection, times, rows.reshape(len(members), size))


def _sampled(log_ns: NDArray[np.int64], rate_hz: float, last: int) -> NDArray[np.int64]:
    """Indices of the first row in each 1/rate bin of log time not yet sampled (bins after
    `last`, the previous batch's last bin)."""
    if rate_hz <= 0 or not log_ns.size:
        return np.zeros(0, dtype=np.int64)
    bins = (log_ns // int(1e9 / rate_hz)).astype(np.int64)
    first = np.flatnonzero(np.concatenate(([True], bins[1:] != bins[:-1])))
    return first[bins[first] > last]


class _Table:
    """The --csv table: one row per posed joint_states message."""

    def __init__(self, path: Path, chain: SerialChain):
        self.file = path.open("w", newline="", encoding="utf-8")
        self.out = csv.writer(self.file)
        self.chain = chain
        names = chain.joint_names
        self.out.writerow(
            ["log_time_s", "stamp_s"]
            + [f"q_{n}" for n in names]
            + [f"qdot_{n}" for n in names]
            + ["x", "y", "z", "qx", "qy", "qz", "qw"]
            + ["wx", "wy", "wz", "vx", "vy", "vz"]
            + ["manipulability", "condition_number", "min_singular_value"]
            + ["limit_distance", "limit_joint"]
        )

    def add(self, motion: Motion, computed: Computed, c: Conditioning) -> None:
        chain = self.chain
        room = np.minimum(motion.q - chain.lower, chain.upper - motion.q)
        nearest = np.argmin(np.where(np.isfinite(room), room, np.inf), axis=1)
        distance = room[np.arange(len(nearest)), nearest]
        block = np.column_stack(
            (
                motion.log_time_ns * 1e-9,
                motion.stamp_ns * 1e-9,
                motion.q,
                motion.qdot,
                computed.T[:, :3, 3],
                computed.quaternion,
                computed.V,
                c.manipulability,
                c.condition_number,
                c.min_singular_value,
                distance,
            )
        )
        names = [
            chain.joint_names[k] if math.isfinite(d) else ""
            for k, d in zip(nearest.tolist(), distance.tolist(), strict=True)
        ]
        for values, name in zip(block.tolist(), names, strict=True):
            self.out.writerow([repr(v) for v in values] + [name])

    def close(self) -> None:
        self.file.close()


def process_recording(
    source: Path,
    out: Path,
    options: BagOptions,
    progress: Callable[[int, int], None] | None = None,
) -> BagResult:
    """Read the recording `source`, write `out` (see the module docstring); return what it did.

    Args:
        progress: called with (messages read so far, messages in the recording) after each batch.

    Raises:
        RecordingError: one of the refusals of the module docstring; nothing is left at `out`.
    """
    source, out = Path(source), Path(out)
    if out.exists() and not options.force:
        raise RecordingError(f"{out} exists: give --force to replace it")
    if out.resolve() == source.resolve():
        raise RecordingError(f"{out} is the input: the input is never modified")
    if not out.parent.is_dir():
        raise RecordingError(f"{out}: its folder {out.parent} does not exist")
    reader = _open_reader(source)
    # written as <OUT's folder>/.<OUT>.partial-<pid>/<OUT's name>, so that the recording's file
    # is named after OUT (rosbags names it after its directory) when it is moved into place
    partial = out.with_name(f".{out.name}.partial-{os.getpid()}")
    staging = partial / out.name
    table_staging = (
        None
        if options.csv is None
        else options.csv.with_name(f".{options.csv.name}.partial-{os.getpid()}")
    )
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir()
    try:
        result = _run(reader, source, staging, table_staging, options, progress)
        if out.exists():
            shutil.rmtree(out) if out.is_dir() else out.unlink()
        staging.rename(out)
        if table_staging is not None and options.csv is not None:
            table_staging.replace(options.csv)
        result.output = out
        return result
    finally:
        reader.close()
        shutil.rmtree(partial, ignore_errors=True)
        if table_staging is not None:
            table_staging.unlink(missing_ok=True)


def _run(
    reader: Any,
    source: Path,
    staging: Path,
    table_path: Path | None,
    options: BagOptions,
    progress: Callable[[int, int], None] | None,
) -> BagResult:
    timings = {"read": 0.0, "decode": 0.0, "kinematics": 0.0, "write": 0.0}
    text, where = _description(reader, options)
    chain, transforms = _chain(text, where, options)
    topic = _topic(options.joint_states)
    joint_state_ids = {c.id for c in _joint_state_connections(reader, topic)}
    ns = _topic(options.namespace).rstrip("/") if options.namespace else ""
    pose_topic, twist_topic = f"{ns}/ee_pose", f"{ns}/ee_twist"
    markers_topic = f"{ns}/kinematics_node/markers"
    ee = EndEffector(chain, transforms, options.twist_frame)
    added = {pose_topic: POSE_TYPE, twist_topic: TWIST_TYPE, "/tf": TF_TYPE}
    if ee.static_children:
        added["/tf_static"] = TF_TYPE
    if options.markers_rate_hz > 0:
        added[markers_topic] = MARKERS_TYPE
    output = _Output(staging, reader, added)
    markers = Markers(chain, options.singular_condition)
    table = None if table_path is None else _Table(table_path, chain)
    motion = JointMotion(chain.joint_names, chain.continuous.tolist())
    findings = Findings(chain, options.singular_condition, options.near_limit)
    written = dict.fromkeys(added, 0)
    total = int(getattr(reader, "message_count", 0) or 0)
    read = copied = 0
    last_bin = last_marker_bin = -1
    static_done = False
    try:
        t0 = time.perf_counter()
        for batch in _batches(reader, BATCH):
            t1 = time.perf_counter()
            timings["read"] += t1 - t0
            states = [i for i, (c, _, _) in enumerate(batch) if c.id in joint_state_ids]
            try:
                groups = decode_joint_states([batch[i][2] for i in states])
            except KinematicsError as exc:
                raise RecordingError(f"{topic}: {exc}") from None
            log_ns = np.fromiter((batch[i][1] for i in states), dtype=np.int64, count=len(states))
            t2 = time.perf_counter()
            timings["decode"] += t2 - t1
            m = motion.advance(groups, log_ns)
            c = ee.messages(m)
            sampled = _sampled(m.log_time_ns, options.conditioning_rate_hz, last_bin)
            if table is not None:  # every row's conditioning; the report samples it
                every = conditioning(m.log_time_ns, c.J)
                table.add(m, c, every)
                cond = every.take(sampled)
            else:
                cond = conditioning(m.log_time_ns[sampled], c.J[sampled])
            if sampled.size:
                last_bin = int(
                    m.log_time_ns[sampled[-1]] // int(1e9 / options.conditioning_rate_hz)
                )
            findings.add(m, c, sampled, cond)
            t3 = time.perf_counter()
            timings["kinematics"] += t3 - t2
            _copy(output, batch)
            if not static_done and m.rows.size:
                static = ee.static_tf(int(m.log_time_ns[0]), int(m.stamp_ns[0]))
                if static is not None:
                    output.rows("/tf_static", static)
                    written["/tf_static"] += 1
                static_done = True
            for name, w in ((pose_topic, c.pose), (twist_topic, c.twist), ("/tf", c.tf)):
                output.rows(name, w)
                written[name] += len(w.log_time_ns)
            if options.markers_rate_hz > 0:
                rows = _sampled(m.log_time_ns, options.markers_rate_hz, last_marker_bin)
                if rows.size:
                    last_marker_bin = int(
                        m.log_time_ns[rows[-1]] // int(1e9 / options.markers_rate_hz)
                    )
                drawn = markers.messages(m, c, rows)
                output.rows(markers_topic, drawn)
                written[markers_topic] += len(drawn.log_time_ns)
            t0 = time.perf_counter()
            timings["write"] += t0 - t3
            read += len(batch)
            copied += len(batch)
            if progress is not None:
                progress(read, total)
        missing = [n for n in chain.joint_names if n not in _seen(motion)]
        if missing:
            raise RecordingError(
                f"{topic} never names the chain's joints {missing} "
                f"(chain {chain.base_link} -> {chain.tip_link}): nothing to compute"
            )
        t3 = time.perf_counter()
        output.close()
        timings["write"] += time.perf_counter() - t3
    except BaseException:
        output.writer.abort() if hasattr(output.writer, "abort") else None
        if table is not None:
            table.close()
        raise
    if table is not None:
        table.close()
    findings.finish()
    return BagResult(
        output=staging,
        chain=chain,
        description_source=where,
        counts=motion.counts,
        findings=findings,
        written=written,
        copied=copied,
        seconds=timings,
    )


def _seen(motion: JointMotion) -> set[str]:
    return {n for n, q in zip(motion.joint_names, motion.last_q, strict=True) if q == q}


def recordings_in(paths: Sequence[Path]) -> list[Path]:
    """The recordings named by `paths`: each a recording's directory, or a folder of them."""
    found: list[Path] = []
    for p in paths:
        if (p / "metadata.yaml").is_file() or not p.is_dir():
            found.append(p)
        else:
            found += sorted(d for d in p.iterdir() if (d / "metadata.yaml").is_file())
    return found
