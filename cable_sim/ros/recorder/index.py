"""Packed per-chunk indexes of the mcap writer (bounded memory over hour-long recordings).

May import mcap and the standard library.
"""

from __future__ import annotations

from typing import Any

from mcap.writer import Writer


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
    name = "_Writer__chunk_indices"
    if isinstance(getattr(writer, name, None), list) and not getattr(writer, name):
        setattr(writer, name, _PackedRecords())
