"""`write_rows` gives, byte for byte, the recording that rosbags' `Writer.write` gives message by
message: the same chunks, index, summary and metadata.yaml."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kinematics_node.jobs.recordings.mcap_batches import CHUNK_BYTES, write_rows

rosbag2 = pytest.importorskip("rosbags.rosbag2", reason="pip install rosbags")
typesys = pytest.importorskip("rosbags.typesys", reason="pip install rosbags")
STORE = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)


def _record(path: Path, batches, batched: bool) -> None:
    with rosbag2.Writer(path, version=9, storage_plugin=rosbag2.StoragePlugin.MCAP) as writer:
        connections = {}
        for topic, times, rows in batches:
            if topic not in connections:
                connections[topic] = writer.add_connection(
                    topic, "std_msgs/msg/String", typestore=STORE
                )
            if batched:
                write_rows(writer, connections[topic], times, rows)
            else:
                for t, row in zip(times.tolist(), rows, strict=True):
                    writer.write(connections[topic], t, row.tobytes())


def _batches(rng: np.random.Generator):
    """Batches of several topics and sizes, some larger than a chunk, interleaved in time."""
    out, t = [], 10**18
    for k, (topic, count, size) in enumerate(
        [("/a", 3, 40), ("/b", 9000, 200), ("/a", 1, 40), ("/c", 20000, 64), ("/b", 500, 200)]
    ):
        times = t + np.sort(rng.integers(0, 10**9, size=count))
        out.append((topic, times, rng.integers(0, 256, size=(count, size), dtype=np.uint8)))
        t += 10**8 * (k % 2)
    return out


def test_batched_writing_is_byte_for_byte_the_per_message_recording(tmp_path):
    batches = _batches(np.random.default_rng(1))
    assert sum(len(t) * (r.shape[1] + 31) for _, t, r in batches) > 3 * CHUNK_BYTES
    _record(tmp_path / "one_by_one" / "bag", batches, batched=False)
    _record(tmp_path / "batched" / "bag", batches, batched=True)
    for name in ("bag.mcap", "metadata.yaml"):
        mine = (tmp_path / "batched" / "bag" / name).read_bytes()
        assert mine == (tmp_path / "one_by_one" / "bag" / name).read_bytes(), name


def test_what_is_written_in_batches_reads_back_in_time_order(tmp_path):
    batches = _batches(np.random.default_rng(2))
    _record(tmp_path / "bag", batches, batched=True)
    with rosbag2.Reader(tmp_path / "bag") as reader:
        got = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
    want = sorted(
        (
            (topic, int(t), row.tobytes())
            for topic, ts, rs in batches
            for t, row in zip(ts, rs, strict=True)
        ),
        key=lambda m: m[1],
    )
    assert sorted(got, key=lambda m: (m[1], m[0], m[2])) == sorted(
        want, key=lambda m: (m[1], m[0], m[2])
    )
    assert [t for _, t, _ in got] == sorted(t for _, t, _ in got)
