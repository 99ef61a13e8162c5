"""RunRecorder: non-blocking, crash-safe recording with a background writer thread.

The writer thread builds the message chunks itself (:mod:`.chunks`: one ``struct.pack`` and four
appends per message, compression outside the GIL) and leaves the header, schema, channel and
metadata records and the summary section to the stock :class:`mcap.writer.Writer` (unchunked;
:mod:`.index` hands it every chunk for its chunk indexes and statistics).

May import mcap and its sibling modules (chunks, definitions, cdr, files, index, metadata).
"""

from __future__ import annotations

import atexit
import collections
import errno
import os
import sys
import threading
import time
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.writer import Writer

from cable_sim.ros.recorder.cdr import serialize
from cable_sim.ros.recorder.chunks import ChannelState, ChunkBuilder
from cable_sim.ros.recorder.definitions import (
    DEFAULT_QOS_YAML,
    LIBRARY,
    MESSAGE_ENCODING,
    PROFILE,
    SCHEMA_ENCODING,
    message_definition,
    type_name_of,
)
from cable_sim.ros.recorder.files import _Sink, open_new_file
from cable_sim.ros.recorder.index import _pack_chunk_indexes, add_chunk, can_add_chunks
from cable_sim.ros.recorder.metadata import _str_dict

#: Uncompressed bytes after which the writer closes a chunk before its flush period: 16 MiB, so at
#: the node's data rates (10-20 MB/s in fast mode at n = 80) a chunk usually closes at the flush
#: period, about once a second: each close hands the GIL back and forth several times
#: (compression, file writes and fsync release it), and every hand-over costs the simulation
#: thread a thread wake-up, on a loaded machine up to a scheduler time slice.
DEFAULT_CHUNK_SIZE = 16 << 20


class RecorderError(RuntimeError):
    """The recording cannot be started (the message names the path and the reason)."""



_OPEN_RECORDERS: weakref.WeakSet[RunRecorder] = weakref.WeakSet()


@atexit.register
def _close_open_recorders() -> None:  # pragma: no cover - exercised by the signal tests
    for rec in list(_OPEN_RECORDERS):
        rec.close()


class RunRecorder:
    """Record ROS messages to an MCAP file without ever blocking or raising into the caller.

    Parameters
    ----------
    path : str or Path
        Requested ``.mcap`` file; missing parent directories are created. An existing file is
        never overwritten: the recording then goes to ``<stem>-1.mcap``, ``<stem>-2.mcap``, ...
        (see :func:`open_new_file`), a warning is logged, and :attr:`path` is the file actually
        written (:attr:`requested_path` the one asked for).
    metadata : dict of str -> dict of str -> str, optional
        Metadata records written at the start of the file (e.g. ``"scene"``, ``"run"``).
    compression : {"zstd", "lz4", "none"}
        Chunk compression.
    flush_period : float
        Seconds between chunk closes + fsync (the most data a SIGKILL can lose). > 0.
    logger : callable or logger, optional
        Where problems are reported: an object with ``warning``/``error`` methods (an rclpy or
        :mod:`logging` logger) or a callable taking one string. Called from the writer thread.
    max_queue : int
        Messages that may wait for the writer thread; beyond that new messages are dropped.
    chunk_size : int
        Uncompressed bytes after which a chunk is closed before the flush period.

    Raises
    ------
    RecorderError
        When the file cannot be created or written (message names the path and the reason).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        metadata: dict[str, dict[str, str]] | None = None,
        *,
        compression: str = "zstd",
        flush_period: float = 1.0,
        logger: Any = None,
        max_queue: int = 100_000,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
    ) -> None:
        #: The file asked for; :attr:`path` is the one written (they differ after a name clash).
        self.requested_path = Path(path)
        self.path = self.requested_path
        #: The open chunk (raises ValueError for an unknown compression, before any file exists).
        self._chunk = ChunkBuilder(chunk_size, compression)
        if not (flush_period > 0):
            raise ValueError(f"flush_period={flush_period!r}: must be > 0 [s]")
        if max_queue < 1:
            raise ValueError(f"max_queue={max_queue!r}: must be >= 1")
        self.flush_period = float(flush_period)
        #: Writer-thread idle sleep [s]: it drains the queue in batches, so the simulation thread
        #: hands over the GIL rarely (each hand-over costs it a thread wake-up, not only the
        #: writer's work): four times per flush period, at most every 0.25 s.
        self._poll = min(0.25, self.flush_period / 4)
        #: Set by :meth:`close`: wakes the writer thread from its poll wait at once.
        self._wake = threading.Event()
        #: Queued items the writer thread handles between two looks at the clock.
        self._batch = 20_000
        self.max_queue = int(max_queue)
        self._logger = logger
        #: ``(topic, type name, data, log_time, publish_time)`` per message; a metadata record is
        #: ``(None, name, dict, 0, 0)``; a deferred message (:meth:`write_deferred`)
        #: ``(topic, type name, payload, log_time, publish_time, encode)``.
        self._queue: collections.deque[tuple] = collections.deque()
        self._deferred = False  # whether write_deferred was ever called
        self._types: dict[type, str] = {}
        self._topic_types: dict[str, str] = {}
        #: topic -> its channel, or False when the topic cannot be recorded (no definition).
        self._channels: dict[str, ChannelState | bool] = {}
        self._offered_qos: dict[str, str] = {}
        self._schemas: dict[str, int] = {}
        self._dirty = False  # written since the last fsync (or messages in the open chunk)
        self._written = 0
        self._dropped = 0
        self._errors = 0
        self._last_error = ""
        self._failed = False
        self._closing = False
        self._closed = False
        self._close_lock = threading.RLock()
        self._last_drop_log = 0.0
        self._open_file()
        self._start_file(metadata)
        self._thread = threading.Thread(target=self._run, name=f"recorder:{self.path.name}",
                                        daemon=True)
        self._thread.start()
        _OPEN_RECORDERS.add(self)

    # ---------------------------------------------------------------- caller side
    def write(
        self, topic: str, msg: Any, log_time_ns: int, publish_time_ns: int | None = None, *,
        serialized: bytes | None = None,
    ) -> None:
        """Record one message (serialised here, written by the background thread).

        Never blocks, never raises: problems are counted in :attr:`stats` and logged.

        Parameters
        ----------
        topic : str
            Topic name as published (e.g. ``"/joint_states"``).
        msg : rclpy message
            The message.
        log_time_ns, publish_time_ns : int
            Timestamps [ns]; ``publish_time_ns`` defaults to ``log_time_ns``.
        serialized : bytes, optional
            ``serialize(msg)`` when the caller already has it (e.g. it published these bytes
            with ``publisher.publish(data)``): serialise once, publish and record the same bytes.
        """
        if self._closing or self._failed:
            self._dropped += 1
            return
        try:
            cls = type(msg)
            tname = self._types.get(cls)
            if tname is None:
                tname = self._types[cls] = type_name_of(cls)
            data = serialize(msg) if serialized is None else serialized
        except Exception as exc:  # noqa: BLE001 - never raise into the simulation
            self._error(f"cannot serialise message on {topic}: {exc}")
            self._dropped += 1
            return
        self.write_serialized(topic, tname, data, log_time_ns, publish_time_ns)

    def write_serialized(
        self, topic: str, type_name: str, data: bytes, log_time_ns: int,
        publish_time_ns: int | None = None,
    ) -> None:
        """Record already-serialised CDR bytes of type ``pkg/msg/Type`` (see :meth:`write`)."""
        if self._admit():
            lt = int(log_time_ns)
            pt = lt if publish_time_ns is None else int(publish_time_ns)
            self._queue.append((topic, type_name, data, lt, pt))

    def _admit(self) -> bool:
        """Whether one more message may be queued; if not, it is counted dropped (and a full
        queue logged)."""
        if self._closing or self._failed:
            self._dropped += 1
            return False
        if len(self._queue) >= self.max_queue:
            self._queue_full()
            return False
        return True

    def _queue_full(self) -> None:
        """Count a message dropped because the queue is full; log it (at most once a second)."""
        self._dropped += 1
        now = time.monotonic()
        if now - self._last_drop_log > 1.0:
            self._last_drop_log = now
            self._log(f"recorder queue full ({self.max_queue} messages): dropping messages "
                      f"({self._dropped} dropped so far)")

    def write_deferred(
        self, topic: str, type_name: str, encode: Callable[[list, list[int]], list[bytes]],
        payload: Any, log_time_ns: int, publish_time_ns: int | None = None,
    ) -> None:
        """Record a ``type_name`` message whose CDR bytes the writer thread makes.

        ``encode(payloads, log_times)`` is called in the writer thread with the payloads of all
        queued messages that share it (in queue order) and returns their bytes, so a message
        encoded from a few numbers (the recording's /tf at each joint state) costs the caller an
        append and the writer one vectorised encoding per batch. The message keeps its place in
        the recording among the others. Never blocks, never raises (see :meth:`write`); when
        ``encode`` raises, its messages are counted dropped and the error logged.

        Parameters
        ----------
        topic, type_name : str
            Topic name and ``pkg/msg/Type``.
        encode : callable
            ``(list of payloads, list of log times [ns]) -> list of bytes``, one per payload;
            called from the writer thread only (it may keep scratch of its own).
        payload : object
            What ``encode`` needs for this message; not modified afterwards by the caller.
        log_time_ns, publish_time_ns : int
            Timestamps [ns]; ``publish_time_ns`` defaults to ``log_time_ns``.
        """
        if self._admit():
            lt = int(log_time_ns)
            pt = lt if publish_time_ns is None else int(publish_time_ns)
            self._deferred = True
            self._queue.append((topic, type_name, payload, lt, pt, encode))

    def offer_qos(self, topic: str, qos_yaml: str) -> None:
        """Store ``qos_yaml`` (rosbag2's ``offered_qos_profiles`` form) for ``topic`` instead of the
        default (reliable, volatile, keep last 10); call before the topic's first message."""
        self._offered_qos[topic] = qos_yaml

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Add a metadata record (written in order with the messages)."""
        if self._closing or self._failed:
            return
        self._queue.append((None, name, _str_dict(data), 0, 0))

    @property
    def stats(self) -> dict[str, Any]:
        """``messages_written``, ``messages_dropped``, ``bytes_written``, ``errors``,
        ``last_error``, ``queued``, ``closed``, ``path``."""
        try:
            nbytes = self._sink.tell() if not self._closed else self.path.stat().st_size
        except (OSError, ValueError):
            nbytes = -1
        return {
            "messages_written": self._written,
            "messages_dropped": self._dropped,
            "bytes_written": nbytes,
            "errors": self._errors,
            "last_error": self._last_error,
            "queued": len(self._queue),
            "closed": self._closed,
            "path": str(self.path),
        }

    @property
    def message_counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return {ch.topic: ch.count for ch in list(self._channels.values()) if ch}

    def close(self, timeout: float = 30.0) -> None:
        """Drain the queue, write the summary and close the file. Idempotent and thread-safe.

        Parameters
        ----------
        timeout : float
            Longest wait for the writer thread to drain the queue [s].
        """
        with self._close_lock:
            if self._closed:
                return
            if not self._closing:  # (not again from a signal handler inside set(): its lock)
                self._closing = True
                self._wake.set()  # the writer thread stops waiting for its next poll
            if self._thread.is_alive() and threading.current_thread() is not self._thread:
                self._thread.join(timeout)
            if self._thread.is_alive():
                self._error(f"writer thread did not finish within {timeout} s; file may be incomplete")
            try:
                if not self._failed:
                    self._close_chunk()
                if not self._failed:
                    self._writer.finish()
                    self._sink.sync()
            except Exception as exc:  # noqa: BLE001
                self._io_error(exc)
            self._sink_close_quietly()
            self._closed = True
            _OPEN_RECORDERS.discard(self)

    def __enter__(self) -> RunRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---------------------------------------------------------------- writer thread
    def _run(self) -> None:
        last_flush = time.monotonic()
        q = self._queue
        while True:
            try:
                if q:
                    backlog = len(q) >= self._batch
                    self._drain(self._batch)
                    if not backlog and not self._closing:
                        # let messages gather: one GIL hand-off per poll period, not per message
                        self._wake.wait(self._poll)
                elif self._closing:
                    break
                else:
                    self._wake.wait(self._poll)
                now = time.monotonic()
                if now - last_flush >= self.flush_period:
                    if self._dirty:
                        self._flush()
                    last_flush = now
            except Exception as exc:  # noqa: BLE001 - never let the writer thread die silently
                self._error(f"recorder writer thread: {exc!r}")
        # final drain is done; flush what is left so a crash during finish() loses nothing
        try:
            if self._dirty:
                self._flush()
        except Exception as exc:  # noqa: BLE001
            self._error(f"recorder writer thread: {exc!r}")

    def _drain(self, batch: int) -> None:
        """Add up to ``batch`` queued items to the open chunk (writer thread): the hot loop."""
        q = self._queue
        if self._failed:
            self._drop_queued()
            return
        pop = q.popleft
        items = [pop() for _ in range(min(batch, len(q)))]
        if self._deferred:
            self._encode_deferred(items)
        channels = self._channels
        add = self._chunk.add
        n = 0
        i = -1
        try:
            for i, item in enumerate(items):
                if item is None:  # a deferred message that could not be encoded (counted)
                    continue
                topic, _tname, data, lt, pt = item
                ch = channels.get(topic)
                if not ch:
                    ch = self._slow_item(item)
                    if not ch:
                        if self._failed:
                            self._drop_items(items[i + 1:])
                            self._drop_queued()
                            return
                        continue
                try:
                    full = add(ch, data, lt, pt)
                except Exception as exc:  # noqa: BLE001 - a bad message must not stop the thread
                    self._dropped += 1
                    self._error(f"cannot write message on {topic}: {exc!r}")
                    continue
                n += 1
                if full:
                    self._written += n
                    n = 0
                    self._dirty = True  # written, not yet fsync'ed
                    self._close_chunk()
                    if self._failed:
                        self._drop_items(items[i + 1:])
                        self._drop_queued()
                        return
        except BaseException:  # unexpected (logged by _run): what was taken but not handled is counted
            self._drop_items(items[i + 1:])
            raise
        finally:
            self._written += n
            if n:
                self._dirty = True

    def _encode_deferred(self, items: list) -> None:
        """Replace the deferred messages of ``items`` (see :meth:`write_deferred`) by ordinary
        ones, one ``encode`` call per encoder; a message whose encoding fails becomes None (counted
        dropped, error logged)."""
        groups: dict[Any, list[int]] = {}
        for i, item in enumerate(items):
            if len(item) == 6:
                groups.setdefault(item[5], []).append(i)
        for encode, where in groups.items():
            try:
                datas = encode([items[i][2] for i in where], [items[i][3] for i in where])
                if len(datas) != len(where):
                    raise ValueError(f"{len(datas)} messages encoded for {len(where)}")
            except Exception as exc:  # noqa: BLE001 - never let the writer thread die silently
                self._dropped += len(where)
                self._error(f"cannot encode {len(where)} messages on {items[where[0]][0]}: {exc!r}")
                for i in where:
                    items[i] = None
                continue
            for i, data in zip(where, datas, strict=True):
                topic, tname, _payload, lt, pt, _ = items[i]
                items[i] = (topic, tname, data, lt, pt)

    def _drop_items(self, items: list) -> None:
        """Count the messages among ``items`` (taken from the queue, not written) as dropped."""
        self._dropped += sum(1 for item in items if item is not None and item[0] is not None)

    def _open_file(self) -> None:
        """Create the file (a new one, never an existing one) and its parent directories."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            f, self.path = open_new_file(self.requested_path)
            self._sink = _Sink(f)
        except OSError as exc:
            reason = exc.strerror or str(exc)
            bad = next((p for p in [self.path.parent, *self.path.parent.parents]
                        if p.exists() and not p.is_dir()), None)
            if bad is not None:
                reason = f"{bad} is not a directory"
            elif self.path.is_dir():
                reason = "it is a directory"
            raise RecorderError(f"cannot record to {str(self.path)!r}: {reason}") from exc
        if self.path != self.requested_path:
            self._log(f"{self.requested_path} already exists and is never overwritten: "
                      f"recording to {self.path} instead")

    def _start_file(self, metadata: dict[str, dict[str, str]] | None) -> None:
        """Write the header and the metadata records, and sync them to disk."""
        try:
            # unchunked: the message chunks are ours (see _close_chunk), schemas and channels are
            # written outside chunks, ahead of the first chunk that uses them
            self._writer = Writer(self._sink, use_chunking=False)
            if not can_add_chunks(self._writer):
                self._sink_close_quietly()
                raise RecorderError("the installed mcap package's Writer keeps no chunk index "
                                    "list / statistics the recorder can add its chunks to")
            _pack_chunk_indexes(self._writer)
            self._writer.start(profile=PROFILE, library=LIBRARY)
            for name, data in (metadata or {}).items():
                self._writer.add_metadata(name, _str_dict(data))
            self._sink.sync()
        except OSError as exc:
            self._sink_close_quietly()
            raise RecorderError(f"cannot record to {str(self.path)!r}: {exc.strerror or exc}") from exc

    def _slow_item(self, item: tuple) -> ChannelState | None:
        """A queued item the hot loop cannot handle (writer thread): a metadata record, the first
        message of a topic (registers its channel) or one of a topic that cannot be recorded.
        Returns the channel to add the message to, None when there is nothing more to do."""
        topic, tname = item[0], item[1]
        try:
            if topic is None:
                self._writer.add_metadata(tname, item[2])
                self._dirty = True
                return None
            ch = self._channels.get(topic)
            if ch is None:
                ch = self._register(topic, tname)
        except OSError as exc:
            self._io_error(exc)
            ch = None
        except Exception as exc:  # noqa: BLE001 - never let the writer thread die silently
            self._error(f"cannot register {topic}: {exc!r}")
            ch = None
        if not ch:
            if topic is not None:
                self._dropped += 1
            return None
        return ch  # type: ignore[return-value]

    def _register(self, topic: str, tname: str) -> ChannelState | bool:
        """Write the schema (if new) and channel records of ``topic``; False if it has no
        message definition (its messages are then dropped and counted)."""
        sid = self._schemas.get(tname)
        if sid is None:
            try:
                definition = message_definition(tname)
            except (OSError, ValueError) as exc:
                self._error(f"no message definition for {tname} (topic {topic}): {exc}")
                self._channels[topic] = False
                return False
            sid = self._schemas[tname] = self._writer.register_schema(
                name=tname, encoding=SCHEMA_ENCODING, data=definition.encode())
        cid = self._writer.register_channel(
            topic=topic, message_encoding=MESSAGE_ENCODING, schema_id=sid,
            metadata={"offered_qos_profiles": self._offered_qos.get(topic, DEFAULT_QOS_YAML)})
        self._writer.flush()  # the records reach the file before any chunk with their messages
        ch = self._channels[topic] = ChannelState(cid, topic)
        self._topic_types[topic] = tname
        self._dirty = True
        return ch

    def _close_chunk(self) -> None:
        """Compress and write the open chunk and its message indexes; account it in the summary.
        On a write error its messages count as dropped and recording stops."""
        if self._failed:
            return
        try:
            closed = self._chunk.close()
        except Exception as exc:  # noqa: BLE001 - never let the writer thread die silently
            lost = self._lose_open_chunk()
            self._error(f"cannot compress a chunk ({lost} messages dropped): {exc!r}")
            return
        if closed is None:
            return
        sink = self._sink
        try:
            start = sink.tell()
            for part in closed.chunk:
                sink.write(part)
            sink.write(closed.message_indexes)
        except OSError as exc:
            self._written -= closed.messages
            self._dropped += closed.messages
            self._io_error(exc)
            return
        add_chunk(self._writer, closed, start, start + closed.chunk_length)

    def _lose_open_chunk(self) -> int:
        """Empty the open chunk without writing it; its messages count as dropped, not written.
        Returns how many they were."""
        lost = self._chunk.messages
        self._chunk.discard()
        self._written -= lost
        self._dropped += lost
        return lost

    def _drop_queued(self) -> None:
        """Empty the queue after recording stopped, counting the messages in it as dropped."""
        q = self._queue
        while q:
            if q.popleft()[0] is not None:
                self._dropped += 1

    def _flush(self) -> None:
        """Close the open chunk, write it and fsync the file."""
        self._dirty = False
        if self._failed:
            return
        self._close_chunk()
        if self._failed:
            return
        try:
            self._sink.sync()
        except OSError as exc:
            self._io_error(exc)

    # ---------------------------------------------------------------- errors
    def _io_error(self, exc: BaseException) -> None:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        if isinstance(exc, OSError) and exc.errno == errno.ENOSPC:
            reason = "disk full (ENOSPC)"
        first = not self._failed
        self._failed = True
        self._lose_open_chunk()  # it will never be written
        self._error(f"I/O error writing {self.path}: {reason}"
                    + ("; recording stopped, further messages are dropped" if first else ""))

    def _error(self, text: str) -> None:
        self._errors += 1
        self._last_error = text
        self._log(text)

    def _log(self, text: str) -> None:
        lg = self._logger
        if lg is None:
            print(f"[cable_sim.ros.recorder] {text}", file=sys.stderr)
            return
        try:
            if hasattr(lg, "warning"):
                lg.warning(text)
            elif hasattr(lg, "warn"):
                lg.warn(text)
            else:
                lg(text)
        except Exception:  # noqa: BLE001 - a broken logger must not break recording
            pass

    def _sink_close_quietly(self) -> None:
        try:
            self._sink.close()
        except OSError:
            pass
