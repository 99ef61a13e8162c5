"""The mcap writer's summary bookkeeping: packed chunk indexes, chunks written outside it.

The recorder writes its message chunks itself (:mod:`.chunks`) and leaves the header, schemas,
channels, metadata and the summary section to the stock :class:`mcap.writer.Writer`: this module
is the one place that reaches into that writer's private state (its chunk index list and its
statistics record), so that its ``finish()`` writes a summary that covers those chunks.

May import mcap, the sibling module chunks and the standard library.
"""

from __future__ import annotations

from typing import Any

from mcap.records import ChunkIndex
from mcap.writer import Writer

from cable_sim.ros.recorder.chunks import ClosedChunk

_CHUNK_INDICES = "_Writer__chunk_indices"
_STATISTICS = "_Writer__statistics"


class _PackedRecords:
    """Append-only store of MCAP records kept as their serialised bytes.

    The mcap writer keeps one :class:`mcap.records.ChunkIndex` object (with a dict of message
    index offsets) per chunk until :meth:`Writer.finish` writes the summary: with a chunk per
    second (``flush_period``) that is about 1.5 kB of Python objects per second, the largest
    steady memory growth of an hour-long recording. Kept packed here it is the ~200 bytes the
    record takes in the file. Iterating yields one object whose ``write`` copies all the bytes.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self._n = 0

    def append(self, record: Any) -> None:
        from mcap.data_stream import RecordBuilder

        b = RecordBuilder()
        record.write(b)
        self._buf += b.end()
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def __iter__(self):
        if self._n:
            yield _RawRecords(bytes(self._buf))


class _RawRecords:
    """Already-serialised records, written as they are."""

    __slots__ = ("data",)

    def __init__(self, data: bytes) -> None:
        self.data = data

    def write(self, stream: Any) -> None:
        stream.write(self.data)


def _pack_chunk_indexes(writer: Writer) -> None:
    """Let ``writer`` keep its chunk indexes packed (see :class:`_PackedRecords`), if it can."""
    name = _CHUNK_INDICES
    if isinstance(getattr(writer, name, None), list) and not getattr(writer, name):
        setattr(writer, name, _PackedRecords())


def can_add_chunks(writer: Writer) -> bool:
    """True when ``writer`` (an unchunked :class:`mcap.writer.Writer`) has the chunk index list
    and statistics record :func:`add_chunk` updates (a future mcap release may not)."""
    stats = getattr(writer, _STATISTICS, None)
    return (hasattr(writer, _CHUNK_INDICES) and all(
        hasattr(stats, a) for a in ("message_count", "message_start_time", "message_end_time",
                                    "channel_message_counts", "chunk_count")))


def add_chunk(writer: Writer, chunk: ClosedChunk, chunk_start: int, index_start: int) -> None:
    """Account a chunk written to ``writer``'s stream outside it in the summary it will write.

    Parameters
    ----------
    writer : mcap.writer.Writer
        Unchunked writer whose ``finish()`` writes the summary (statistics, chunk indexes).
    chunk : ClosedChunk
        The chunk (see :meth:`.chunks.ChunkBuilder.close`).
    chunk_start, index_start : int
        File offsets of its Chunk record and of its first MessageIndex record.
    """
    getattr(writer, _CHUNK_INDICES).append(ChunkIndex(
        message_start_time=chunk.message_start_time, message_end_time=chunk.message_end_time,
        chunk_start_offset=chunk_start, chunk_length=chunk.chunk_length,
        message_index_offsets={cid: index_start + off
                               for cid, off in chunk.message_index_offsets.items()},
        message_index_length=len(chunk.message_indexes), compression=chunk.compression,
        compressed_size=chunk.compressed_size, uncompressed_size=chunk.uncompressed_size))
    st = getattr(writer, _STATISTICS)
    if st.message_count == 0:
        st.message_start_time = chunk.message_start_time
    else:
        st.message_start_time = min(st.message_start_time, chunk.message_start_time)
    st.message_end_time = max(st.message_end_time, chunk.message_end_time)
    for cid, n in chunk.channel_counts.items():
        st.channel_message_counts[cid] += n
    st.message_count += chunk.messages
    st.chunk_count += 1
