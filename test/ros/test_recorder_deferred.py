"""RunRecorder.write_deferred: messages encoded by the writer thread keep their place and bytes.

Expected values are what the test hands to the recorder (topics, log times) and the bytes its own
encoder function gives for each payload; the file is read back by the independent ``mcap`` package
and by ``rosbags``.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path

from mcap.reader import make_reader
from std_msgs.msg import Float64

from cable_sim.ros.recorder import RunRecorder, serialize

FLOAT64 = "std_msgs/msg/Float64"


def _float64(x: float) -> bytes:
    """CDR of std_msgs/Float64 (little-endian encapsulation header, then the double: CDR aligns
    from the end of the header), by hand."""
    return b"\x00\x01\x00\x00" + struct.pack("<d", x)


def _messages(path: Path) -> list[tuple]:
    with open(path, "rb") as f:
        return [(ch.topic, m.log_time, m.data, m.sequence)
                for _s, ch, m in make_reader(f).iter_messages(log_time_order=False)]


def test_deferred_messages_keep_their_place_and_bytes(tmp_path):
    calls: list[int] = []

    def encode(payloads, log_times):
        calls.append(len(payloads))
        return [_float64(p) for p in payloads]

    rec = RunRecorder(tmp_path / "d.mcap", chunk_size=5_000, flush_period=0.05)
    expected = []
    for i in range(3000):
        t = 1_000 + 10 * i
        if i % 3 == 0:
            rec.write_deferred("/tf_like", FLOAT64, encode, 0.25 * i, t)
            expected.append(("/tf_like", t, _float64(0.25 * i)))
        else:
            data = serialize(Float64(data=-1.0 * i))
            rec.write_serialized("/plain", FLOAT64, data, t)
            expected.append(("/plain", t, data))
        if i % 400 == 399:
            time.sleep(0.06)  # let the writer thread take a batch
    rec.close()
    assert (rec.stats["messages_written"], rec.stats["messages_dropped"]) == (3000, 0)
    got = _messages(rec.path)
    assert [(topic, t, data) for topic, t, data, _seq in got] == expected  # file order = queue order
    assert [s for topic, _t, _d, s in got if topic == "/tf_like"] == list(range(1000))
    assert sum(calls) == 1000 and len(calls) < 1000  # encoded in batches, each message once

    from rosbags.highlevel import AnyReader

    with AnyReader([rec.path]) as ar:
        values = [(c.topic, ar.deserialize(raw, c.msgtype).data) for c, _t, raw in ar.messages()]
    assert values == [(topic, 0.25 * i if topic == "/tf_like" else -1.0 * i)
                      for i, (topic, _t, _d) in enumerate(expected)]


def test_failed_encoding_is_counted_dropped_and_logged_the_rest_recorded(tmp_path):
    logs: list[str] = []

    def broken(payloads, log_times):
        raise RuntimeError("no bytes today")

    def short(payloads, log_times):
        return [_float64(p) for p in payloads[1:]]  # one message too few

    rec = RunRecorder(tmp_path / "f.mcap", logger=logs.append)
    good = serialize(Float64(data=2.0))
    rec.write_serialized("/a", FLOAT64, good, 10)
    rec.write_deferred("/b", FLOAT64, broken, 1.0, 20)
    rec.write_deferred("/c", FLOAT64, short, 1.0, 30)
    rec.write_serialized("/a", FLOAT64, good, 40)
    rec.close()
    st = rec.stats
    assert (st["messages_written"], st["messages_dropped"]) == (2, 2)
    assert st["errors"] == 2 and len(logs) == 2
    assert any("no bytes today" in m and "/b" in m for m in logs)
    assert [(topic, t, data) for topic, t, data, _s in _messages(rec.path)] == [
        ("/a", 10, good), ("/a", 40, good)]


def test_deferred_writes_after_close_and_beyond_the_queue_are_counted(tmp_path):
    logs: list[str] = []
    rec = RunRecorder(tmp_path / "q.mcap", max_queue=5, logger=logs.append)
    rec._poll = 10.0  # the writer thread sleeps (after its first poll wait): the queue fills  # noqa: SLF001
    time.sleep(2 * min(0.25, rec.flush_period / 4) + 0.1)
    encode = lambda payloads, _t: [_float64(p) for p in payloads]  # noqa: E731
    for i in range(8):
        rec.write_deferred("/a", FLOAT64, encode, float(i), 100 + i)
    assert rec.stats["messages_dropped"] == 3 and any("queue full" in m for m in logs)
    rec.close()
    rec.write_deferred("/a", FLOAT64, encode, 9.0, 200)
    st = rec.stats
    assert (st["messages_written"], st["messages_dropped"]) == (5, 4)
    assert [data for _topic, _t, data, _s in _messages(rec.path)] == [_float64(i) for i in range(5)]
