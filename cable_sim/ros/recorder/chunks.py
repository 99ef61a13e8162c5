"""Lean MCAP chunk builder: per message the recorder does one ``struct.pack`` and four appends.

The writer thread of :class:`~cable_sim.ros.recorder.writer.RunRecorder` adds every message as
an MCAP *Message* record (opcode 0x05): its packed head and its data are appended to the chunk's
buffer (a ``bytearray``: one small copy per message, spread over the writer's batches, instead of
one join of the whole chunk at its close, a copy of megabytes that holds the GIL), its
``(log_time, offset)`` to the channel's message index; when the chunk is closed (size limit or
flush period) :meth:`ChunkBuilder.close` compresses the buffer once (zstd / lz4; both release the
GIL) and packs the *Chunk* record (0x06) and one *MessageIndex* record (0x07) per channel. The mcap
package's ``Writer.add_message`` does the same through a dataclass per message and a
``BytesIO``-based builder, several microseconds of Python per message under the GIL (the time the
simulation thread loses while recording).

Record layouts (MCAP specification, little endian; every record is ``opcode u8, length u64,
body``):

- Message: ``channel_id u16, sequence u32, log_time u64, publish_time u64, data`` (rest of the
  record);
- Chunk: ``message_start_time u64, message_end_time u64, uncompressed_size u64,
  uncompressed_crc u32, compression (u32 length + UTF-8), records (u64 length + bytes)``;
- MessageIndex: ``channel_id u16, records (u32 byte length + (log_time u64, offset u64)...)``,
  offsets counted from the start of the uncompressed chunk records.

May import zstandard, lz4 and the standard library.
"""

from __future__ import annotations

import struct
import sys
import zlib
from array import array
from collections.abc import Callable

OP_MESSAGE = 0x05
OP_CHUNK = 0x06
OP_MESSAGE_INDEX = 0x07

#: Message record up to its data: opcode, record length, channel id, sequence, log/publish time.
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")
#: Bytes of a Message record's body before its data (the record length is this + len(data)).
MESSAGE_BODY_HEAD = 2 + 4 + 8 + 8
_CHUNK_HEAD = struct.Struct("<BQQQQI")  # opcode, length, start, end, uncompressed size, crc
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")
_MESSAGE_INDEX_HEAD = struct.Struct("<BQHI")  # opcode, length, channel id, byte length
_SEQUENCE_MASK = 0xFFFF_FFFF
_BIG_ENDIAN = sys.byteorder == "big"


#: zstd level of the chunks: level 1 compresses recordings (floats, frame names) as well as the
#: default level 3 (ratio 3.6 on a node recording at n = 80) at 1.5 times its speed.
ZSTD_LEVEL = 1


def compressor(kind: str) -> tuple[str, Callable[[bytes], bytes] | None]:
    """The Chunk record's ``compression`` name and the function that compresses chunk records.

    Compressed chunks carry their integrity check in the compressed frame (zstd: xxhash64
    content checksum, lz4: xxhash32 content checksum; verified by every decompressor), so their
    Chunk record leaves ``uncompressed_crc`` 0 ("not computed", as the MCAP specification
    allows) instead of spending a CRC-32 pass over the uncompressed bytes; uncompressed chunks
    get the CRC-32.

    Parameters
    ----------
    kind : {"zstd", "lz4", "none", ""}
        Requested compression.

    Returns
    -------
    name : str
        ``"zstd"``, ``"lz4"`` or ``""`` (uncompressed), as the MCAP specification names them.
    compress : callable or None
        ``bytes -> bytes`` (``None`` for uncompressed chunks).
    """
    if kind == "zstd":
        import zstandard

        return "zstd", zstandard.ZstdCompressor(level=ZSTD_LEVEL, write_checksum=True).compress
    if kind == "lz4":
        import lz4.frame

        def lz4_compress(data: bytes) -> bytes:
            return lz4.frame.compress(data, content_checksum=True)

        return "lz4", lz4_compress
    if kind in ("none", ""):
        return "", None
    raise ValueError(f"compression={kind!r}: allowed 'zstd', 'lz4', 'none'")


class ChannelState:
    """One recorded channel: id, next sequence number and its message index in the open chunk.

    Attributes
    ----------
    id : int
        MCAP channel id (1 .. 65535).
    topic : str
        Topic name.
    count : int
        Messages accepted so far (the next message's sequence number, modulo 2**32).
    entries : array of uint64
        ``log_time, offset`` pairs of the channel's messages in the open chunk.
    """

    __slots__ = ("id", "topic", "count", "entries")

    def __init__(self, channel_id: int, topic: str) -> None:
        if not 0 < channel_id <= 0xFFFF:
            raise ValueError(f"channel id {channel_id} outside 1 .. 65535")
        self.id = channel_id
        self.topic = topic
        self.count = 0
        self.entries = array("Q")


class ClosedChunk:
    """The bytes of a closed chunk and what its chunk index and the statistics need.

    Attributes
    ----------
    chunk : list of bytes
        The Chunk record, in pieces to be written in order (no copy of the compressed data).
    chunk_length : int
        Bytes of the Chunk record.
    message_indexes : bytes
        The MessageIndex records, one per channel, to be written right after the chunk.
    message_index_offsets : dict of int -> int
        Channel id -> offset of its MessageIndex record from the start of ``message_indexes``.
    channel_counts : dict of int -> int
        Channel id -> messages in the chunk.
    message_start_time, message_end_time : int
        Smallest and largest log time in the chunk [ns].
    compression : str
        ``"zstd"``, ``"lz4"`` or ``""``.
    compressed_size, uncompressed_size : int
        Bytes of the chunk's records as stored and before compression.
    messages : int
        Messages in the chunk.
    """

    __slots__ = ("chunk", "chunk_length", "message_indexes", "message_index_offsets",
                 "channel_counts", "message_start_time", "message_end_time", "compression",
                 "compressed_size", "uncompressed_size", "messages")

    def __init__(self, **kw: object) -> None:
        for k, v in kw.items():
            setattr(self, k, v)


class ChunkBuilder:
    """Message records of the open chunk and their per-channel message indexes.

    Parameters
    ----------
    chunk_size : int
        Uncompressed record bytes after which :meth:`add` reports the chunk full.
    compression : {"zstd", "lz4", "none"}
        Compression of the chunk records (see :func:`compressor`).
    """

    __slots__ = ("records", "channels", "chunk_size", "_name", "_compress")

    def __init__(self, chunk_size: int = 1 << 20, compression: str = "zstd") -> None:
        self._name, self._compress = compressor(compression)
        self.chunk_size = int(chunk_size)
        #: Message records of the open chunk, as they will be stored (uncompressed).
        self.records = bytearray()
        #: Channels with messages in the open chunk, in order of their first message.
        self.channels: list[ChannelState] = []

    @property
    def size(self) -> int:
        """Bytes of the records in the open chunk."""
        return len(self.records)

    @property
    def messages(self) -> int:
        """Messages in the open chunk."""
        return sum(len(ch.entries) for ch in self.channels) // 2

    def add(self, ch: ChannelState, data: bytes, log_time: int, publish_time: int) -> bool:
        """Append one Message record; True when the chunk has reached ``chunk_size`` bytes.

        Raises (and leaves the chunk unchanged) when a field does not fit its MCAP type
        (negative or >= 2**64 time) or ``data`` is not bytes-like.
        """
        if data.__class__ is not bytes:
            data = bytes(data)  # a snapshot of a mutable buffer; TypeError for a str
        records = self.records
        off = len(records)
        head = _MESSAGE_HEAD.pack(OP_MESSAGE, MESSAGE_BODY_HEAD + len(data), ch.id,
                                  ch.count & _SEQUENCE_MASK, log_time, publish_time)
        e = ch.entries
        if not e:
            self.channels.append(ch)
        e.append(log_time)
        e.append(off)
        records += head
        records += data
        ch.count += 1
        return len(records) >= self.chunk_size

    def close(self) -> ClosedChunk | None:
        """Pack the Chunk and MessageIndex records and empty the builder (None if no message)."""
        if not self.channels:
            return None
        raw = self.records  # no longer grown: discard() below gives the builder a new buffer
        if self._compress is None:
            stored, crc = raw, zlib.crc32(raw)
        else:  # the compressed frame carries its own content checksum (see compressor)
            stored, crc = self._compress(raw), 0
        name = self._name.encode()
        body_len = 8 + 8 + 8 + 4 + 4 + len(name) + 8 + len(stored)
        index = bytearray()
        offsets: dict[int, int] = {}
        counts: dict[int, int] = {}
        start, end = 1 << 64, 0
        for ch in self.channels:
            e = ch.entries
            times = e[0::2]
            start = min(start, min(times))
            end = max(end, max(times))
            if _BIG_ENDIAN:  # pragma: no cover - MCAP is little endian
                e.byteswap()
            pairs = e.tobytes()
            offsets[ch.id] = len(index)
            counts[ch.id] = len(e) // 2
            index += _MESSAGE_INDEX_HEAD.pack(OP_MESSAGE_INDEX, 2 + 4 + len(pairs), ch.id,
                                              len(pairs))
            index += pairs
            ch.entries = array("Q")
        head = (_CHUNK_HEAD.pack(OP_CHUNK, body_len, start, end, len(raw), crc)
                + _U32.pack(len(name)) + name + _U64.pack(len(stored)))
        closed = ClosedChunk(
            chunk=[head, stored], chunk_length=9 + body_len, message_indexes=bytes(index),
            message_index_offsets=offsets, channel_counts=counts, message_start_time=start,
            message_end_time=end, compression=self._name, compressed_size=len(stored),
            uncompressed_size=len(raw), messages=sum(counts.values()))
        self.discard()
        return closed

    def discard(self) -> list[ChannelState]:
        """Empty the builder without writing; returns the channels that had messages in it."""
        chans = self.channels
        for ch in chans:
            ch.entries = array("Q")
        self.records = bytearray()
        self.channels = []
        return chans
