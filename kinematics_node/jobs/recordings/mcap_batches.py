"""Whole batches of serialized messages into a rosbag2 recording in MCAP storage, through rosbags'
own writer.

`rosbags.rosbag2.Writer.write` takes one message at a time, ~3 µs each in Python (a record built in
a BytesIO, its index entry appended). The recordings job writes three or four messages for every
joint_states it reads, millions of them, so `write_rows` builds the records of a whole batch at once
with numpy and hands them to the writer's pending chunk, with the index entries, counts and time
bounds that `Writer.write` would have kept, and closes chunks where it would have closed them. The
file is byte for byte the one that message-by-message writing gives (tested), and everything else
(schemas, channels, chunk index, summary, metadata.yaml) is rosbags' own code.

Hand-written for speed, on rosbags' MCAP writer's attributes (`storage.chunk`, `close_chunk`):
`write_rows` checks that they are there and otherwise falls back to `Writer.write`, message by
message, so a rosbags release that renames them gives the same file, only slower.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

#: rosbags' MCAP writer closes its pending chunk once it has grown past this many bytes, checked
#: after every message (rosbags.rosbag2.storage_mcap.McapWriter.write).
CHUNK_BYTES = 2**20

_MESSAGE_OP = 0x05
_RECORD_HEAD = 1 + 8 + 2 + 4 + 8 + 8  # opcode, length, channel id, sequence, log and publish time


def _batched(writer: Any) -> bool:
    storage = getattr(writer, "storage", None)
    chunk = getattr(storage, "chunk", None)
    return (
        chunk is not None
        and hasattr(storage, "close_chunk")
        and hasattr(storage, "channel_stats")
        and hasattr(chunk, "bio")
        and hasattr(chunk, "msgs")
        and getattr(writer, "compression_mode", None) is not None
        and writer.compression_mode.name in ("NONE", "STORAGE", "FILE")
    )


def write_rows(
    writer: Any, connection: Any, log_time_ns: NDArray[np.int64], rows: NDArray[np.uint8]
) -> None:
    """Write N messages of one connection: log times (N,) [ns] and their serialized bytes, one
    row of equal length each (N, L), in the order given, as N calls of `writer.write` would."""
    count = len(log_time_ns)
    if count == 0:
        return
    if not _batched(writer):
        for t, row in zip(log_time_ns.tolist(), rows, strict=True):
            writer.write(connection, t, row.tobytes())
        return
    storage = writer.storage
    size = rows.shape[1]
    record = np.dtype(
        [
            ("op", "u1"),
            ("length", "<u8"),
            ("channel", "<u2"),
            ("sequence", "<u4"),
            ("log_time", "<u8"),
            ("publish_time", "<u8"),
            ("data", "u1", (size,)),
        ]
    )
    assert record.itemsize == _RECORD_HEAD + size
    times = np.asarray(log_time_ns, dtype=np.int64)
    done = 0
    while done < count:
        chunk = storage.chunk
        at = chunk.bio.tell()
        # rosbags closes the chunk after the first message that takes it past CHUNK_BYTES
        room = max(CHUNK_BYTES - at, 0) // record.itemsize + 1
        take = min(room, count - done)
        part = slice(done, done + take)
        recs = np.empty(take, dtype=record)
        recs["op"] = _MESSAGE_OP
        recs["length"] = record.itemsize - 9
        recs["channel"] = connection.id
        recs["sequence"] = 0
        recs["log_time"] = times[part]
        recs["publish_time"] = times[part]
        recs["data"] = rows[part]
        chunk.bio.write(recs.tobytes())
        offsets = at + record.itemsize * np.arange(take)
        chunk.msgs[connection.id].extend(zip(times[part].tolist(), offsets.tolist(), strict=True))
        low, high = int(times[part].min()), int(times[part].max())
        chunk.message_start_time = min(low, chunk.message_start_time)
        chunk.message_end_time = max(high, chunk.message_end_time)
        storage.message_start_time = min(low, storage.message_start_time)
        storage.message_end_time = max(high, storage.message_end_time)
        storage.channel_stats[connection.id] += take
        writer.counts[connection.id] += take
        writer.min_timestamp = min(low, writer.min_timestamp)
        writer.max_timestamp = max(high, writer.max_timestamp)
        if chunk.bio.tell() > CHUNK_BYTES:
            storage.close_chunk()
        done += take
