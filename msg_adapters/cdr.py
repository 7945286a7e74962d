"""Batches of ROS 2 messages ↔ numpy arrays, in CDR: the bytes a rosbag2 recording holds.

A recording of an hour at 1 kHz holds 3.6 million joint_states. Deserialising each into a message
object (rosbags: ~15–30 µs) and serialising each answer again costs more than the whole job may
take, so these functions read and write the bytes of whole batches at once:

* `decode_joint_states`: serialized sensor_msgs/JointState → groups of rows that share one layout
  (the same joint names, the same sequence lengths), each with its stamps and its positions,
  velocities and efforts as (k, n) arrays. A recording's messages almost always share one layout,
  so that is one strided view of the batch; a message laid out otherwise is read on its own.
* `pose_stamped_cdr`, `twist_stamped_cdr`, `tf_message_cdr`: arrays → serialized
  geometry_msgs/PoseStamped, geometry_msgs/TwistStamped and tf2_msgs/TFMessage, one row of bytes
  per message. The layout of a message whose strings are fixed is fixed too: one template row is
  built, repeated, and the stamps and floats are written into their columns.

The format is XCDR1 as ROS 2 writes it (rmw_fastrtps, rosbag2): a 4-byte encapsulation header
(0x00 0x01: little endian; 0x00 0x00: big endian), then the fields in order, each primitive aligned
to its size counted from the end of that header, strings as a uint32 length (with the terminating
NUL) and the bytes, sequences as a uint32 count and the elements. The tests check every function
byte for byte against rosbags' serializer and deserializer, an implementation nobody here wrote.

Hand-written for speed (the recordings job's budget is ~16 µs a message in all; see
docs/performance.md); nothing here imports ROS or rosbags.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from kinematics_node.core.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The encapsulation headers of little- and big-endian CDR.
LITTLE_ENDIAN = b"\x00\x01\x00\x00"
BIG_ENDIAN = b"\x00\x00\x00\x00"


# ------------------------------------------------------------------------------------- reading
@dataclass(frozen=True)
class JointStateGroup:
    """Messages of a batch that share one layout.

    Attributes:
        rows: their indices in the batch, ascending (k,).
        names: the joint names they carry, in message order.
        stamp_ns: header stamps [ns] (k,), sec · 10⁹ + nanosec (0 where unset).
        position, velocity, effort: (k, len(names)) each, or (k, 0) where the messages carry none.
    """

    rows: IntArray
    names: tuple[str, ...]
    stamp_ns: IntArray
    position: FloatArray
    velocity: FloatArray
    effort: FloatArray


@dataclass(frozen=True)
class _JointStateLayout:
    """Where one serialized JointState keeps its fields (byte offsets into the whole message)."""

    size: int
    big_endian: bool
    names: tuple[str, ...]
    position: tuple[int, int]  # offset, count
    velocity: tuple[int, int]
    effort: tuple[int, int]

    def skeleton(self) -> list[tuple[int, int]]:
        """The byte ranges [start, end) that are neither the stamp nor floats: what must equal
        this message's bytes for another message of the same size to share its layout."""
        holes = [(4, 12)] + [(o, o + 8 * n) for o, n in (self.position, self.velocity, self.effort)]
        ranges, at = [], 0
        for start, end in holes:
            if start > at:
                ranges.append((at, start))
            at = max(at, end)
        if at < self.size:
            ranges.append((at, self.size))
        return ranges


class _Cursor:
    """Reads CDR fields in order from one message, checking every bound."""

    def __init__(self, data: bytes) -> None:
        if len(data) < 4 or data[:4] not in (LITTLE_ENDIAN, BIG_ENDIAN):
            raise InvalidInputError(
                f"not a CDR message: the first bytes are {bytes(data[:4])!r}, "
                "not a CDR encapsulation header"
            )
        self.data = data
        self.big_endian = data[:4] == BIG_ENDIAN
        self.order = ">" if self.big_endian else "<"
        self.at = 4

    def align(self, size: int) -> None:
        self.at += -(self.at - 4) % size

    def take(self, size: int, what: str) -> int:
        start = self.at
        if start + size > len(self.data):
            raise InvalidInputError(
                f"CDR message ends at byte {len(self.data)}, inside {what} (bytes {start}-"
                f"{start + size})"
            )
        self.at += size
        return start

    def uint32(self, what: str) -> int:
        self.align(4)
        start = self.take(4, what)
        return int.from_bytes(self.data[start : start + 4], "big" if self.big_endian else "little")

    def string(self, what: str) -> str:
        length = self.uint32(f"the length of {what}")
        start = self.take(length, what)
        raw = bytes(self.data[start : start + length])
        if length == 0 or raw[-1] != 0:
            raise InvalidInputError(f"CDR string {what} is not NUL-terminated")
        try:
            return raw[:-1].decode()
        except UnicodeDecodeError as exc:
            raise InvalidInputError(f"CDR string {what} is not UTF-8: {exc}") from None

    def float64s(self, what: str) -> tuple[int, int]:
        count = self.uint32(f"the length of {what}")
        if count:
            self.align(8)
        return self.take(8 * count, what), count


def _joint_state_layout(data: bytes) -> _JointStateLayout:
    """Walk one serialized JointState (header, name[], position[], velocity[], effort[])."""
    cur = _Cursor(data)
    cur.take(8, "the header stamp")
    cur.string("header.frame_id")
    names = tuple(cur.string(f"name[{i}]") for i in range(cur.uint32("the length of name")))
    position = cur.float64s("position")
    velocity = cur.float64s("velocity")
    effort = cur.float64s("effort")
    return _JointStateLayout(len(data), cur.big_endian, names, position, velocity, effort)


def decode_string(data: bytes) -> str:
    """The text of a serialized std_msgs/String (a recording's /robot_description)."""
    return _Cursor(data).string("data")


def _floats(block: NDArray[np.uint8], offset: int, count: int, big_endian: bool) -> FloatArray:
    columns = block[:, offset : offset + 8 * count]
    return np.ascontiguousarray(columns).view(">f8" if big_endian else "<f8").astype(np.float64)


def decode_joint_states(messages: Sequence[bytes]) -> list[JointStateGroup]:
    """Serialized sensor_msgs/JointState messages → groups of rows that share a layout.

    Every message belongs to exactly one group; groups come in the order of their first rows.

    Raises:
        InvalidInputError: a message that is not a JointState in CDR (truncated, a bad header or
            string), naming its index in the batch.
    """
    sizes = np.fromiter((len(m) for m in messages), dtype=np.int64, count=len(messages))
    groups: list[JointStateGroup] = []
    left = np.ones(len(messages), dtype=bool)
    for size in np.unique(sizes):
        rows = np.flatnonzero((sizes == size) & left)
        block = np.frombuffer(b"".join([messages[int(i)] for i in rows]), dtype=np.uint8)
        block = block.reshape(len(rows), int(size))
        pending = np.arange(len(rows))
        while pending.size:
            first = int(rows[pending[0]])
            try:
                layout = _joint_state_layout(messages[first])
            except InvalidInputError as exc:
                raise InvalidInputError(f"joint_states message {first}: {exc}") from None
            candidates = block if pending.size == len(rows) else block[pending]
            same = np.ones(pending.size, dtype=bool)
            for start, end in layout.skeleton():
                same &= (candidates[:, start:end] == candidates[0, start:end]).all(axis=1)
            members, pending = pending[same], pending[~same]
            mine = candidates if same.all() else candidates[same]
            order = ">" if layout.big_endian else "<"
            sec = np.ascontiguousarray(mine[:, 4:8]).view(order + "i4")[:, 0].astype(np.int64)
            nanosec = np.ascontiguousarray(mine[:, 8:12]).view(order + "u4")[:, 0]
            groups.append(
                JointStateGroup(
                    rows=rows[members],
                    names=layout.names,
                    stamp_ns=sec * 1_000_000_000 + nanosec.astype(np.int64),
                    position=_floats(mine, *layout.position, layout.big_endian),
                    velocity=_floats(mine, *layout.velocity, layout.big_endian),
                    effort=_floats(mine, *layout.effort, layout.big_endian),
                )
            )
        left[rows] = False
    groups.sort(key=lambda g: int(g.rows[0]))
    return groups


# ------------------------------------------------------------------------------------- writing
class CdrTemplate:
    """One little-endian message's bytes, with named places for its per-message fields.

    `rows(count)` gives `count` copies as a structured array whose fields (unaligned, at the
    places marked) take the stamps and floats in one strided assignment each.
    """

    def __init__(self) -> None:
        self.buf = bytearray(LITTLE_ENDIAN)
        self.fields: dict[str, tuple[np.dtype, int]] = {}

    def align(self, size: int) -> None:
        self.buf.extend(b"\0" * (-(len(self.buf) - 4) % size))

    def uint32(self, value: int) -> None:
        self.align(4)
        self.buf.extend(int(value).to_bytes(4, "little"))

    def string(self, text: str) -> None:
        raw = text.encode() + b"\0"
        self.uint32(len(raw))
        self.buf.extend(raw)

    def int32(self, value: int) -> None:
        self.align(4)
        self.buf.extend(int(value).to_bytes(4, "little", signed=True))

    def boolean(self, value: bool) -> None:
        self.buf.extend(b"\x01" if value else b"\x00")

    def empty_sequence(self) -> None:
        """A sequence of no elements (its count, 0, and nothing after it)."""
        self.uint32(0)

    def constant_float64s(self, values: Sequence[float]) -> None:
        """float64 fields that are the same in every message."""
        self.align(8)
        self.buf.extend(np.asarray(values, dtype="<f8").tobytes())

    def float32s(self, field: str, count: int) -> None:
        """Room for `count` consecutive float32 fields."""
        self.align(4)
        self.fields[field] = (np.dtype(("<f4", (count,))), len(self.buf))
        self.buf.extend(bytes(4 * count))

    def stamp(self, field: str) -> None:
        """Room for a builtin_interfaces/Time (int32 sec, uint32 nanosec, written as int32)."""
        self.align(4)
        self.fields[field] = (np.dtype(("<i4", (2,))), len(self.buf))
        self.buf.extend(bytes(8))

    def float64s(self, field: str, count: int) -> None:
        """Room for `count` consecutive float64 fields."""
        self.align(8)
        self.fields[field] = (np.dtype(("<f8", (count,))), len(self.buf))
        self.buf.extend(bytes(8 * count))

    def rows(self, count: int) -> NDArray[np.void]:
        dtype = np.dtype(
            {
                "names": list(self.fields),
                "formats": [f for f, _ in self.fields.values()],
                "offsets": [o for _, o in self.fields.values()],
                "itemsize": len(self.buf),
            }
        )
        # bytes * count repeats by doubling memcpy: ~10x faster than broadcasting the row
        return np.frombuffer(bytearray(bytes(self.buf) * count), dtype=dtype)


def stamps(stamp_ns: IntArray) -> NDArray[np.int32]:
    """(N,) stamps [ns] → (N, 2) builtin_interfaces/Time fields (sec, nanosec as int32 bits)."""
    stamp = np.asarray(stamp_ns, dtype=np.int64)
    sec, nanosec = np.divmod(stamp, 1_000_000_000)
    if stamp.size and (sec.min() < -(2**31) or sec.max() >= 2**31):
        raise InvalidInputError("a stamp does not fit builtin_interfaces/Time (int32 seconds)")
    pair = np.empty((stamp.shape[0], 2), dtype="<i4")
    pair[:, 0] = sec
    pair[:, 1] = nanosec.astype(np.uint32).view(np.int32)
    return pair


def as_bytes(rows: NDArray[np.void]) -> NDArray[np.uint8]:
    return rows.view(np.uint8).reshape(rows.shape[0], rows.dtype.itemsize)


def _stamped_vectors(
    stamp_ns: IntArray, frame_id: str, first: FloatArray, second: FloatArray
) -> NDArray[np.uint8]:
    template = CdrTemplate()
    template.stamp("stamp")
    template.string(frame_id)
    template.float64s("first", first.shape[-1])
    template.float64s("second", second.shape[-1])  # contiguous with the first: both 8-aligned
    rows = template.rows(len(stamp_ns))
    rows["stamp"] = stamps(stamp_ns)
    rows["first"] = first
    rows["second"] = second
    return as_bytes(rows)


def pose_stamped_cdr(
    stamp_ns: IntArray, frame_id: str, position: FloatArray, quaternion_xyzw: FloatArray
) -> NDArray[np.uint8]:
    """geometry_msgs/PoseStamped, one row of bytes per message: (N,) stamps [ns], positions
    (N, 3) [m] and quaternions (N, 4) ordered (x, y, z, w) as the message is."""
    return _stamped_vectors(stamp_ns, frame_id, position, quaternion_xyzw)


def twist_stamped_cdr(
    stamp_ns: IntArray, frame_id: str, linear: FloatArray, angular: FloatArray
) -> NDArray[np.uint8]:
    """geometry_msgs/TwistStamped, one row of bytes per message: (N,) stamps [ns], linear (N, 3)
    [m/s] and angular (N, 3) [rad/s] velocities (the message's order: linear first)."""
    return _stamped_vectors(stamp_ns, frame_id, linear, angular)


def joint_state_cdr(
    stamp_ns: IntArray,
    names: Sequence[str],
    position: FloatArray,
    velocity: FloatArray | None = None,
    effort: FloatArray | None = None,
    frame_id: str = "",
) -> NDArray[np.uint8]:
    """sensor_msgs/JointState, one row of bytes per message: (N,) stamps [ns], the joint names,
    positions (N, n) and, when given, velocities and efforts (N, n) (else empty sequences)."""
    n = len(names)
    template = CdrTemplate()
    template.stamp("stamp")
    template.string(frame_id)
    template.uint32(n)
    for name in names:
        template.string(name)
    fields = [("position", position), ("velocity", velocity), ("effort", effort)]
    for field, values in fields:
        count = 0 if values is None else n
        template.uint32(count)
        if count:
            template.float64s(field, count)
    rows = template.rows(len(stamp_ns))
    rows["stamp"] = stamps(stamp_ns)
    for field, values in fields:
        if values is not None:
            rows[field] = values
    return as_bytes(rows)


def tf_message_cdr(
    stamp_ns: IntArray,
    parents: Sequence[str],
    children: Sequence[str],
    translation: FloatArray,
    rotation_xyzw: FloatArray,
) -> NDArray[np.uint8]:
    """tf2_msgs/TFMessage of K transforms, one row of bytes per message: (N,) stamps [ns], the K
    (parent, child) frame names, translations (N, K, 3) [m] and rotations (N, K, 4) (x, y, z, w).
    Every transform of a message carries its stamp."""
    if len(parents) != len(children):
        raise InvalidInputError(f"{len(parents)} parent frames for {len(children)} child frames")
    template = CdrTemplate()
    template.uint32(len(children))
    for k, (parent, child) in enumerate(zip(parents, children, strict=True)):
        template.stamp(f"stamp{k}")
        template.string(parent)
        template.string(child)
        template.float64s(f"translation{k}", 3)
        template.float64s(f"rotation{k}", 4)
    rows = template.rows(len(stamp_ns))
    times = stamps(stamp_ns)
    for k in range(len(children)):
        rows[f"stamp{k}"] = times
        rows[f"translation{k}"] = translation[:, k]
        rows[f"rotation{k}"] = rotation_xyzw[:, k]
    return as_bytes(rows)
