"""The recorder's own chunk builder (cable_sim.ros.recorder.chunks) writes valid, indexed MCAP.

Every expected value is what the test handed to :class:`RunRecorder` (topics, log times, bytes);
the file is read back by the independent ``mcap`` package (indexed reader, streaming reader and
its record decoders) and by ``rosbags``, never by the code under test.
"""

from __future__ import annotations

import io
import random
import time
from pathlib import Path

import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk, Message, MessageIndex
from mcap.stream_reader import StreamReader, get_chunk_data_stream
from std_msgs.msg import Float64, String

from cable_sim.ros.recorder import RunRecorder, recover, serialize

TOPICS = {  # topic -> type name, message factory (payload sizes vary with i)
    "/a": ("std_msgs/msg/Float64", lambda i: Float64(data=0.5 * i)),
    "/b": ("std_msgs/msg/String", lambda i: String(data="x" * (i % 97) + str(i))),
    "/c/deep": ("std_msgs/msg/String", lambda i: String(data=str(i) * (1 + i % 300))),
}


def _record(path: Path, n: int, *, seed: int = 0, **kw) -> tuple[RunRecorder, list[tuple]]:
    """Record ``n`` messages on random topics with increasing log times; return the recorder and
    the written ``(topic, log_time, publish_time, bytes)`` in order."""
    rng = random.Random(seed)
    rec = RunRecorder(path, {"run": {"k": "v"}}, logger=lambda _m: None, **kw)
    written = []
    t = 1_000_000_000
    for i in range(n):
        topic = rng.choice(sorted(TOPICS))
        tname, make = TOPICS[topic]
        data = serialize(make(i))
        t += rng.randint(1, 10_000_000)
        pt = t + rng.randint(0, 1000)
        rec.write_serialized(topic, tname, data, t, pt)
        written.append((topic, t, pt, data))
        if i % 500 == 499:
            time.sleep(0.002)  # let the writer thread run as a real loop would
    return rec, written


def _mcap_messages(path: Path) -> list[tuple]:
    with open(path, "rb") as f:
        r = make_reader(f)
        return [(ch.topic, m.log_time, m.publish_time, m.data, m.sequence)
                for _s, ch, m in r.iter_messages(log_time_order=True)]


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_independent_readers_get_every_message_in_order(tmp_path, compression):
    rec, written = _record(tmp_path / "r.mcap", 5000, compression=compression,
                           chunk_size=20_000, flush_period=0.05)
    rec.close()
    assert rec.stats["messages_written"] == len(written)
    assert rec.stats["messages_dropped"] == 0
    seq: dict[str, int] = {}
    expected = []
    for topic, t, pt, data in written:
        expected.append((topic, t, pt, data, seq.get(topic, 0)))
        seq[topic] = seq.get(topic, 0) + 1
    assert _mcap_messages(rec.path) == expected

    from rosbags.highlevel import AnyReader

    with AnyReader([rec.path]) as ar:
        got = [(c.topic, t, bytes(raw)) for c, t, raw in ar.messages()]
        types = {c.topic: c.msgtype for c in ar.connections}
    assert got == [(topic, t, data) for topic, t, _pt, data in written]
    assert types == {topic: tname for topic, (tname, _f) in TOPICS.items()}


def test_summary_statistics_and_message_indexes_match_the_messages(tmp_path):
    rec, written = _record(tmp_path / "s.mcap", 4000, chunk_size=8_000, flush_period=0.05)
    rec.add_metadata("late", {"a": "b"})
    rec.close()
    with open(rec.path, "rb") as f:
        r = make_reader(f)
        summary = r.get_summary()
        metadata = {m.name: m.metadata for m in r.iter_metadata()}
    assert summary is not None
    st = summary.statistics
    topic_of = {cid: ch.topic for cid, ch in summary.channels.items()}
    counts = {topic: sum(1 for w in written if w[0] == topic) for topic in TOPICS}
    assert st.message_count == len(written)
    assert {topic_of[cid]: n for cid, n in st.channel_message_counts.items()} == counts
    assert st.message_start_time == written[0][1]
    assert st.message_end_time == written[-1][1]
    assert st.channel_count == len(TOPICS)
    assert st.schema_count == 2
    assert st.chunk_count == len(summary.chunk_indexes) > 10
    assert metadata == {"run": {"k": "v"}, "late": {"a": "b"}}

    # every chunk, decoded by the mcap package, and its message indexes point at its messages
    with open(rec.path, "rb") as f:
        records = list(StreamReader(f, emit_chunks=True).records)
    chunk_at = {ci.chunk_start_offset: ci for ci in summary.chunk_indexes}
    n_indexed = 0
    raw = b""
    chunk_times = []
    for rec_ in records:
        if isinstance(rec_, Chunk):
            stream, length = get_chunk_data_stream(rec_, validate_crc=True)
            raw = stream.read(length)
            assert length == rec_.uncompressed_size
            chunk_times.append((rec_.message_start_time, rec_.message_end_time))
        elif isinstance(rec_, MessageIndex):
            for log_time, offset in rec_.records:
                s = ReadDataStream(io.BytesIO(raw[offset:]))
                assert s.read1() == 0x05
                m = Message.read(s, s.read8())
                assert (m.channel_id, m.log_time) == (rec_.channel_id, log_time)
                n_indexed += 1
    assert n_indexed == len(written)
    assert chunk_times == [(ci.message_start_time, ci.message_end_time)
                           for ci in sorted(chunk_at.values(), key=lambda c: c.chunk_start_offset)]


def test_file_cut_inside_a_chunk_is_recovered_with_every_closed_chunk(tmp_path):
    """A file cut in the middle of a chunk (SIGKILL while writing it): recover() keeps exactly
    the messages of the chunks that are complete before the cut, including all flushed ones."""
    rec, first = _record(tmp_path / "k.mcap", 1500, seed=1, flush_period=0.1, chunk_size=30_000)
    time.sleep(0.5)  # flushed and fsync'ed: guaranteed to survive a kill
    flushed_size = rec.path.stat().st_size
    more_rec = []
    t0 = first[-1][1]
    for i in range(1500):
        data = serialize(Float64(data=float(i)))
        rec.write_serialized("/a", "std_msgs/msg/Float64", data, t0 + 1000 * (i + 1))
        more_rec.append(("/a", t0 + 1000 * (i + 1), data))
    rec.close()
    written = [(w[0], w[1], w[3]) for w in first] + more_rec
    full = rec.path.read_bytes()
    with open(rec.path, "rb") as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes,
                        key=lambda c: c.chunk_start_offset)
    late = [c for c in chunks if c.chunk_start_offset >= flushed_size]
    assert len(late) >= 2
    cut_chunk = late[len(late) // 2]
    cut = cut_chunk.chunk_start_offset + cut_chunk.chunk_length // 2
    closed_end = max(c.message_end_time for c in chunks
                     if c.chunk_start_offset + c.chunk_length <= cut)
    expected = [w for w in written if w[1] <= closed_end]
    assert 1500 < len(expected) < len(written)

    cut_file = tmp_path / "cut.mcap"
    cut_file.write_bytes(full[:cut])
    out = tmp_path / "recovered.mcap"
    info = recover(cut_file, out)
    assert info["truncated"]
    assert info["messages"] == len(expected)
    assert [(m[0], m[1], m[3]) for m in _mcap_messages(out)] == expected


def test_bad_message_is_dropped_and_counted_and_the_rest_recorded(tmp_path):
    logs: list[str] = []
    rec = RunRecorder(tmp_path / "b.mcap", logger=logs.append)
    good = serialize(Float64(data=2.0))
    rec.write_serialized("/a", "std_msgs/msg/Float64", good, 10)
    rec.write_serialized("/a", "std_msgs/msg/Float64", good, -5)  # not a valid MCAP time
    rec.write_serialized("/a", "std_msgs/msg/Float64", "not bytes", 20)  # type: ignore[arg-type]
    rec.write_serialized("/n", "no_pkg/msg/Nothing", good, 25)  # no message definition
    rec.write_serialized("/a", "std_msgs/msg/Float64", good, 30)
    rec.close()
    st = rec.stats
    assert (st["messages_written"], st["messages_dropped"]) == (2, 3)
    assert st["errors"] == 3 and len(logs) == 3
    assert [(m[0], m[1], m[3]) for m in _mcap_messages(rec.path)] == [
        ("/a", 10, good), ("/a", 30, good)]
    assert rec.message_counts == {"/a": 2}
