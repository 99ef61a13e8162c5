"""Recovery of a truncated recording (e.g. after SIGKILL) into a complete, indexed MCAP file.

May import mcap and the sibling module definitions.
"""

from __future__ import annotations

import collections
import os
from collections.abc import Callable, Iterable
from typing import Any

from mcap.writer import CompressionType, Writer

from cable_sim.ros.recorder.definitions import LIBRARY, PROFILE


def scan_records(path: str | os.PathLike[str]) -> tuple[list, Exception | None]:
    """Every record a streaming reader gets from ``path`` before it stops, and why it stopped.

    Returns
    -------
    records : list
        MCAP records (chunks expanded into schemas, channels and messages) in file order.
    error : Exception or None
        The error that ended the read early (``None`` if the file is complete).
    """
    from mcap.stream_reader import StreamReader

    records: list = []
    err: Exception | None = None
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, skip_magic=False, emit_chunks=False).records:
                records.append(rec)
        except Exception as exc:  # noqa: BLE001 - truncated tail: keep what was read
            err = exc
    return records, err


def recover(
    path_in: str | os.PathLike[str], path_out: str | os.PathLike[str],
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Rewrite a truncated recording (e.g. after SIGKILL) as a complete, indexed MCAP file.

    Every schema, channel, metadata record and message that a streaming reader decodes before
    the damaged tail is copied (same ids, timestamps and bytes); the summary is rebuilt.

    Returns
    -------
    dict
        ``messages``, ``channels``, ``metadata``, ``truncated`` (bool), ``error`` (str).
    """
    from mcap.records import Channel, Message, Metadata, Schema

    records, err = scan_records(path_in)
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    n_msg = n_meta = 0
    header_profile = PROFILE
    for r in records:
        if type(r).__name__ == "Header":
            header_profile = r.profile or PROFILE
            break
    out = Writer(str(path_out), compression=CompressionType.ZSTD)
    out.start(profile=header_profile, library=LIBRARY + " (recovered)")
    for r in records:
        if isinstance(r, Schema):
            if r.id not in schemas:
                schemas[r.id] = out.register_schema(r.name, r.encoding, r.data)
        elif isinstance(r, Channel):
            if r.id not in channels:
                channels[r.id] = out.register_channel(
                    r.topic, r.message_encoding, schemas.get(r.schema_id, 0), dict(r.metadata))
        elif isinstance(r, Metadata):
            out.add_metadata(r.name, dict(r.metadata))
            n_meta += 1
        elif isinstance(r, Message):
            cid = channels.get(r.channel_id)
            if cid is None:
                continue
            out.add_message(cid, r.log_time, r.data, r.publish_time, r.sequence)
            n_msg += 1
            if progress and n_msg % 100_000 == 0:
                progress(f"recover: {n_msg} messages")
    out.finish()
    return {"messages": n_msg, "channels": len(channels), "metadata": n_meta,
            "truncated": err is not None, "error": "" if err is None else repr(err)}


def iter_topics(records: Iterable[Any]) -> dict[str, int]:
    """Message count per topic in a list of records from :func:`scan_records`."""
    from mcap.records import Channel, Message

    topic = {}
    counts: dict[str, int] = collections.defaultdict(int)
    for r in records:
        if isinstance(r, Channel):
            topic[r.id] = r.topic
        elif isinstance(r, Message):
            counts[topic.get(r.channel_id, "?")] += 1
    return dict(counts)
