"""Recordings never destroy each other (issue 9, item 3).

- Two nodes of the default scene started at the same instant in one folder with distinct
  namespaces write two distinct, complete MCAP files, each with its own messages.
- A node given an existing ``record_path`` leaves that file untouched and records to a new name,
  which it logs and reports in its diagnostics.
- :class:`RunRecorder` never opens an existing file for writing (unit level).

The node runs as the installed console script in a subprocess (``ros_util.start_node``: default
SIGINT/SIGTERM handling); every process is killed and reaped in ``finally``.
"""

from __future__ import annotations

import os
import re
import subprocess
import threading
from collections.abc import Callable
from pathlib import Path

import pytest
from ros_util import isolate_ros, kill_and_reap, node_code_path, start_node
from std_msgs.msg import Float64

from cable_sim.ros.recorder import RunRecorder

DOMAIN = isolate_ros()
JS_COUNT = 151  # joint states at 50 Hz over t = 0 .. 3 s inclusive (duration 3 s)


def _node(*params: str, ros_args: tuple[str, ...] = ()) -> Callable[[Path], subprocess.Popen]:
    """A starter of the installed node on the default scene (fast, 3 s, exit at the end)."""

    def start(cwd: Path) -> subprocess.Popen:
        return start_node("mooring_line", "clock_mode:=fast", "duration:=3.0", "exit_at_end:=true",
                          *params, ros_args=ros_args, domain=DOMAIN, cwd=cwd,
                          env=dict(os.environ, PYTHONUNBUFFERED="1", **node_code_path()))
    return start


def _run_all(starters: list[Callable[[Path], subprocess.Popen]], cwd: Path,
             timeout: float = 180.0) -> list[tuple[int, str]]:
    """Start every node at the same instant, wait for all; kill and reap in any case.

    Each node is started and waited for by its own thread: the thread that starts a process must
    outlive it (``ros_util.popen`` asks Linux to kill the child when its starting thread ends).
    """
    procs: list[subprocess.Popen | None] = [None] * len(starters)
    outs: list[str] = [""] * len(starters)
    errors: list[BaseException] = []
    go = threading.Barrier(len(starters))

    def run(i: int) -> None:
        go.wait()
        procs[i] = starters[i](cwd)
        try:
            outs[i], _ = procs[i].communicate(timeout=timeout)
        except BaseException as exc:  # noqa: BLE001 - re-raised in the test's thread
            errors.append(exc)
            kill_and_reap(procs[i])

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(starters))]
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        if errors:
            raise errors[0]
        return [(p.returncode, o) for p, o in zip(procs, outs, strict=True)]
    finally:
        for p in procs:
            if p is not None:
                kill_and_reap(p)


def _read_rosbags(path: Path) -> tuple[dict[str, int], dict[str, dict[str, str]]]:
    """Message count per topic (every message deserialised by rosbags) and the MCAP metadata."""
    from mcap.reader import make_reader
    from rosbags.highlevel import AnyReader

    counts: dict[str, int] = {}
    with AnyReader([path]) as r:
        for c, _, raw in r.messages():
            r.deserialize(raw, c.msgtype)
            counts[c.topic] = counts.get(c.topic, 0) + 1
    with open(path, "rb") as f:
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return counts, meta


def _logged_path(out: str, cwd: Path) -> Path:
    m = re.search(r"recording to (\S+\.mcap)", out)
    assert m, out
    p = Path(m.group(1))
    return p if p.is_absolute() else cwd / p


def test_two_nodes_started_together_record_to_distinct_complete_files(tmp_path):
    results = _run_all([_node(ros_args=("-r", "__ns:=/leg1")), _node(ros_args=("-r", "__ns:=/leg2"))],
                       tmp_path)
    for code, out in results:
        assert code == 0, out
    files = sorted((tmp_path / "runs").glob("*.mcap"))
    assert len(files) == 2, files
    for leg, (_, out) in zip(("leg1", "leg2"), results, strict=True):
        path = _logged_path(out, tmp_path)
        assert path.resolve() in {f.resolve() for f in files}, (path, files)
        assert re.fullmatch(rf"mooring_line_{leg}\.cable_sim_node_\d{{8}}-\d{{6}}-\d{{6}}\.mcap", path.name)
        counts, meta = _read_rosbags(path)
        other = "leg2" if leg == "leg1" else "leg1"
        assert counts.get(f"/{leg}/joint_states") == JS_COUNT, counts
        assert counts.get(f"/{leg}/fairlead_tension", 0) > 0, counts
        assert not any(t.startswith(f"/{other}/") for t in counts), counts
        assert meta["run"]["node"] == f"/{leg}/cable_sim_node", meta["run"]


def test_node_never_overwrites_an_existing_record_path(tmp_path):
    path = tmp_path / "run.mcap"
    original = b"not a recording: must survive\n" * 100
    path.write_bytes(original)
    [(code, out)] = _run_all([_node(f"record_path:={path}")], tmp_path)
    assert code == 0, out
    assert path.read_bytes() == original
    new = tmp_path / "run-1.mcap"
    assert "already exists" in out and str(new) in out, out
    assert _logged_path(out, tmp_path) == new
    counts, _ = _read_rosbags(new)
    assert counts.get("/joint_states") == JS_COUNT, counts


def test_recorder_never_opens_an_existing_file(tmp_path):
    path = tmp_path / "x.mcap"
    original = bytes(range(256)) * 40
    path.write_bytes(original)
    (tmp_path / "x-1.mcap").write_bytes(b"also taken")
    logs: list[str] = []
    with RunRecorder(path, logger=logs.append) as rec:
        for i in range(50):
            rec.write("/x", Float64(data=float(i)), i)
    assert path.read_bytes() == original
    assert (tmp_path / "x-1.mcap").read_bytes() == b"also taken"
    assert rec.path == tmp_path / "x-2.mcap" and rec.requested_path == path
    assert rec.stats["path"] == str(tmp_path / "x-2.mcap")
    assert any("x.mcap already exists" in m and "x-2.mcap" in m for m in logs), logs
    counts, _ = _read_rosbags(rec.path)
    assert counts == {"/x": 50}


def test_recorders_racing_for_one_name_get_distinct_files(tmp_path):
    path = tmp_path / "same.mcap"
    n = 6
    go = threading.Barrier(n)
    recs: list[RunRecorder] = []
    lock = threading.Lock()

    def make(i: int) -> None:
        go.wait()
        r = RunRecorder(path, logger=lambda _m: None)
        r.write("/who", Float64(data=float(i)), 1)
        with lock:
            recs.append(r)

    threads = [threading.Thread(target=make, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in recs:
        r.close()
    assert len({r.path for r in recs}) == n
    for r in recs:
        assert _read_rosbags(r.path)[0] == {"/who": 1}


def test_directory_path_is_still_an_error(tmp_path):
    from cable_sim.ros.recorder import RecorderError

    with pytest.raises(RecorderError, match="it is a directory"):
        RunRecorder(tmp_path)


def test_packed_chunk_indexes_give_the_stock_writers_bytes(tmp_path, monkeypatch):
    """The recorder keeps the mcap writer's per-chunk indexes packed (bounded memory over long
    runs); the file must be byte for byte what the unmodified writer produces."""
    from cable_sim.ros.recorder import writer

    def record(path: Path) -> RunRecorder:
        rec = RunRecorder(path, {"m": {"k": "v"}}, chunk_size=2000, logger=lambda _m: None)
        for i in range(3000):
            rec.write(f"/t{i % 5}", Float64(data=float(i)), i)
        rec.close()
        return rec

    packed = record(tmp_path / "packed.mcap")
    assert len(packed._writer._Writer__chunk_indices) > 20  # many chunks: the index matters
    monkeypatch.setattr(writer, "_pack_chunk_indexes", lambda _w: None)
    stock = record(tmp_path / "stock.mcap")
    assert isinstance(stock._writer._Writer__chunk_indices, list)
    assert packed.path.read_bytes() == stock.path.read_bytes()
    from mcap.reader import make_reader

    with open(packed.path, "rb") as f:  # the indexed reader uses the chunk indexes
        r = make_reader(f)
        assert len(r.get_summary().chunk_indexes) == len(packed._writer._Writer__chunk_indices)
        assert sum(1 for _ in r.iter_messages(topics=["/t3"])) == 600
