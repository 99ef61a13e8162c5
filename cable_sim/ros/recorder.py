"""Crash-safe, non-blocking recording of a run to a rosbag2-compatible MCAP file.

:class:`RunRecorder` is what the node uses to record everything it publishes and receives:

- the file is an MCAP file as rosbag2 writes it: profile ``ros2``, one schema per message type
  named ``pkg/msg/Type`` with encoding ``ros2msg`` and the full concatenated message definition
  (the type's ``.msg`` text, then one ``====...====`` / ``MSG: pkg/Type`` section per nested
  type), channels with message encoding ``cdr`` and the ``offered_qos_profiles`` metadata;
  the message bytes are exactly :func:`rclpy.serialization.serialize_message` of the message;
- :meth:`RunRecorder.write` serialises in the caller and appends to a lock-free queue; a
  background thread writes chunked, zstd-compressed data. The caller is never blocked and never
  sees an exception: queue overflow and I/O errors (disk full) are counted in
  :attr:`RunRecorder.stats` and reported through the ``logger`` callback; after an I/O error
  further messages are dropped (and counted);
- every ``flush_period`` seconds the current chunk is closed, written, flushed and fsync'ed, so
  after a SIGKILL (or power loss) every chunk up to the last flush is readable by a streaming
  reader, and :func:`recover` rewrites such a file as a complete, indexed one;
- :meth:`RunRecorder.close` is idempotent, thread-safe and safe to call from ``finally`` blocks
  on Ctrl-C, SIGTERM (rclpy's ``ExternalShutdownException``) or exceptions; an ``atexit`` hook
  closes a recorder that was never closed.

The queue is a :class:`collections.deque` (atomic append/popleft, no Python-level lock), so a
signal handler that runs in the middle of :meth:`RunRecorder.write` and calls :meth:`close`
cannot deadlock.
"""

from __future__ import annotations

import atexit
import collections
import errno
import json
import os
import re
import sys
import threading
import time
import weakref
from collections.abc import Callable, Iterable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

#: MCAP profile and encodings rosbag2 uses.
PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
LIBRARY = "cable_sim recorder (mcap python)"

#: Delimiter rosbag2 puts between the sections of a concatenated message definition.
DEFINITION_SEPARATOR = "=" * 80

#: QoS the node offers on its publishers (reliable, volatile, keep last 10), in the YAML form
#: rosbag2 (Jazzy) stores in the channel metadata.
DEFAULT_QOS_YAML = (
    "- history: keep_last\n"
    "  depth: 10\n"
    "  reliability: reliable\n"
    "  durability: volatile\n"
    "  deadline:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  liveliness: automatic\n"
    "  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n"
    "  avoid_ros_namespace_conventions: false\n"
)

_PRIMITIVES = {
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring", "time", "duration",
}


class RecorderError(RuntimeError):
    """The recording cannot be started (the message names the path and the reason)."""


# --------------------------------------------------------------------------------------------
# Message definitions
# --------------------------------------------------------------------------------------------


def _share_dirs() -> list[Path]:
    dirs: list[Path] = []
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / "share")
    dirs.append(Path(sys.prefix) / "share")
    return dirs


def msg_file(type_name: str) -> Path:
    """The ``.msg`` file of ``pkg/msg/Type`` (or ``pkg/Type``) in the ament prefixes.

    Raises
    ------
    FileNotFoundError
        When no prefix of ``AMENT_PREFIX_PATH`` (nor ``sys.prefix``) has it.
    """
    pkg, name = _split_type(type_name)
    candidates = []
    try:  # a real ROS install: ask the ament index first
        from ament_index_python.packages import get_package_share_directory

        candidates.append(Path(get_package_share_directory(pkg)) / "msg" / f"{name}.msg")
    except Exception:  # noqa: BLE001 - no ament index / package not indexed
        pass
    candidates += [d / pkg / "msg" / f"{name}.msg" for d in _share_dirs()]
    for c in candidates:
        if c.is_file():
            return c
    raise FileNotFoundError(
        f"message definition {pkg}/msg/{name}.msg not found in {[str(c.parent) for c in candidates]}"
        " (set AMENT_PREFIX_PATH to the ROS install / venv prefix)"
    )


def _split_type(type_name: str) -> tuple[str, str]:
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise ValueError(f"message type {type_name!r}: expected 'pkg/msg/Type' or 'pkg/Type'")


_FIELD_RE = re.compile(r"^\s*([A-Za-z_][\w/]*)(?:\s*<=\s*\d+)?(?:\[[^\]]*\])?\s+[A-Za-z_]\w*")


def _dependencies(text: str, pkg: str) -> list[str]:
    """Nested message types (``pkg/Type``) used by the fields of a ``.msg`` text, in order."""
    deps: list[str] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = _FIELD_RE.match(line)
        if not m:
            continue
        ftype = m.group(1)
        # constants ("TYPE NAME=VALUE") are always primitives
        if ftype in _PRIMITIVES:
            continue
        if ftype == "Header":
            ftype = "std_msgs/Header"
        elif "/" not in ftype:
            ftype = f"{pkg}/{ftype}"
        else:
            p, n = _split_type(ftype)
            ftype = f"{p}/{n}"
        if ftype not in deps:
            deps.append(ftype)
    return deps


def message_definition(type_name: str) -> str:
    """Full concatenated definition of a message type, as rosbag2 stores it in MCAP schemas.

    The type's own ``.msg`` text, then for every nested type (depth first, each once) a section
    ``"=" * 80 + "\\nMSG: pkg/Type\\n" + text``.
    """
    pkg, name = _split_type(type_name)
    root = msg_file(f"{pkg}/{name}").read_text()
    seen = {f"{pkg}/{name}"}
    sections: list[str] = []
    stack = list(reversed(_dependencies(root, pkg)))
    while stack:
        dep = stack.pop()
        if dep in seen:
            continue
        seen.add(dep)
        dpkg, _ = _split_type(dep)
        text = msg_file(dep).read_text()
        sections.append(f"{DEFINITION_SEPARATOR}\nMSG: {dep}\n{text}")
        stack.extend(reversed([d for d in _dependencies(text, dpkg) if d not in seen]))
    out = root
    for s in sections:
        if not out.endswith("\n"):
            out += "\n"
        out += s
    return out


def type_name_of(msg: Any) -> str:
    """``pkg/msg/Type`` of an rclpy message instance (or class)."""
    cls = msg if isinstance(msg, type) else type(msg)
    module = cls.__module__.split(".")
    return f"{module[0]}/{module[1]}/{cls.__name__}"


# --------------------------------------------------------------------------------------------
# Exact CDR bytes
# --------------------------------------------------------------------------------------------
# rclpy.serialization.serialize_message (rmw_fastrtps_cpp, Jazzy) returns a buffer of the
# *estimated* serialised size, which overestimates empty sequences of 8-byte values (a JointState
# with empty velocity/effort comes back 8 bytes longer than its CDR data), and it leaves the
# alignment padding uninitialised (stale bytes from an earlier message), whereas what a
# subscriber receives is exactly as long as the CDR data, padding zeroed. :func:`serialize` walks
# the message, cuts the buffer to the exact length and zeroes the padding, so the recorded bytes
# are deterministic and equal to the bytes a subscriber receives.

_BASIC_SIZES = {
    "boolean": 1, "octet": 1, "char": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2,
    "wchar": 2, "int32": 4, "uint32": 4, "float": 4, "int64": 8, "uint64": 8, "double": 8,
    "long double": 16,
}
# Field kinds of a compiled plan. Runs of consecutive fixed-layout fields (primitives, fixed
# arrays of primitives, nested structures without strings or sequences) are merged into one
# _K_BLOCK whose size and padding depend only on the start offset modulo 8 (memoised).
(_K_BASIC, _K_STR, _K_MSG, _K_FIXED, _K_SEQ_BASIC, _K_ARR_BASIC, _K_SEQ_STR, _K_ARR_STR,
 _K_SEQ_FIXED, _K_ARR_FIXED, _K_SEQ_MSG, _K_ARR_MSG, _K_BLOCK) = range(13)
_FIXED_KINDS = (_K_BASIC, _K_ARR_BASIC, _K_FIXED, _K_ARR_FIXED)
_PLANS: dict[type, list[tuple[str, int, Any]]] = {}
_IS_FIXED: dict[type, bool] = {}
_ZEROS = bytes(8)
_serialize_message: Callable[[Any], bytes] | None = None  # rclpy's, imported on first use


class _UnsupportedLayout(TypeError):
    """A field type the walk does not model (wstring): rclpy's bytes are kept as they are."""


class _Block:
    """Consecutive fixed-layout fields: (kind, element size or class, count) items."""

    __slots__ = ("items", "memo")

    def __init__(self, items: list[tuple[int, Any, int]]) -> None:
        self.items = items
        self.memo: dict[int, tuple[int, tuple[int, ...]]] = {}

    def layout(self, phase: int) -> tuple[int, tuple[int, ...]]:
        """(size, padding ranges relative to the start) when starting at offset ``phase`` mod 8."""
        lay = self.memo.get(phase)
        if lay is None:
            pads: list[int] = []
            pos = phase
            for kind, arg, count in self.items:
                if kind == _K_BASIC:
                    pos = _align(pos, arg, pads) + arg
                elif kind == _K_ARR_BASIC:
                    pos = _align(pos, arg, pads) + arg * count if count else pos
                else:  # nested fixed structure(s)
                    for _ in range(count):
                        pos = _put_fixed(arg, pos, pads)
            lay = self.memo[phase] = (pos - phase, tuple(p - phase for p in pads))
        return lay


def _align(pos: int, a: int, pads: list[int] | None) -> int:
    new = pos + (-pos % min(a, 8))
    if pads is not None and new > pos:
        pads.append(pos)
        pads.append(new)
    return new


def _msg_class(t: Any) -> type:
    import importlib

    mod = importlib.import_module(".".join(t.namespaces))
    return getattr(mod, t.name)


def _raw_plan(cls: type) -> list[tuple[str, int, Any, int]]:
    from rosidl_parser import definition as d

    plan: list[tuple[str, int, Any, int]] = []
    names = list(cls.get_fields_and_field_types().keys())
    for name, t in zip(names, cls.SLOT_TYPES, strict=True):
        where = f"{cls.__name__}.{name}"
        if isinstance(t, d.BasicType):
            plan.append((name, _K_BASIC, _BASIC_SIZES[t.typename], 1))
        elif isinstance(t, d.AbstractWString):
            raise _UnsupportedLayout(f"{where}: wstring")
        elif isinstance(t, d.AbstractString):
            plan.append((name, _K_STR, None, 1))
        elif isinstance(t, d.NamespacedType):
            sub = _msg_class(t)
            plan.append((name, _K_FIXED if _fixed(sub) else _K_MSG, sub, 1))
        elif isinstance(t, d.AbstractNestedType):
            seq = isinstance(t, d.AbstractSequence)
            count = 0 if seq else int(t.size)
            vt = t.value_type
            if isinstance(vt, d.BasicType):
                plan.append((name, _K_SEQ_BASIC if seq else _K_ARR_BASIC, _BASIC_SIZES[vt.typename], count))
            elif isinstance(vt, d.AbstractWString):
                raise _UnsupportedLayout(f"{where}: wstring")
            elif isinstance(vt, d.AbstractString):
                plan.append((name, _K_SEQ_STR if seq else _K_ARR_STR, None, count))
            elif isinstance(vt, d.NamespacedType):
                sub = _msg_class(vt)
                if _fixed(sub):
                    plan.append((name, _K_SEQ_FIXED if seq else _K_ARR_FIXED, sub, count))
                else:
                    plan.append((name, _K_SEQ_MSG if seq else _K_ARR_MSG, sub, count))
            else:
                raise _UnsupportedLayout(f"{where}: {vt!r}")
        else:
            raise _UnsupportedLayout(f"{where}: {t!r}")
    return plan


def _plan(cls: type) -> list[tuple[str, int, Any]]:
    """Compiled plan of a message class: (attribute, kind, argument) triples."""
    plan = _PLANS.get(cls)
    if plan is not None:
        return plan
    plan = []
    block: list[tuple[int, Any, int]] = []
    for name, kind, arg, count in _raw_plan(cls):
        if kind in _FIXED_KINDS:
            block.append((kind, arg, count))
            continue
        if block:
            plan.append(("", _K_BLOCK, _Block(block)))
            block = []
        plan.append((name, kind, arg))
    if block:
        plan.append(("", _K_BLOCK, _Block(block)))
    _PLANS[cls] = plan
    return plan


def _fixed(cls: type) -> bool:
    """True when every instance of ``cls`` has the same CDR layout (no strings, no sequences)."""
    f = _IS_FIXED.get(cls)
    if f is None:
        f = _IS_FIXED[cls] = all(k in _FIXED_KINDS for _, k, _, _ in _raw_plan(cls))
    return f


def _fixed_layout(cls: type, phase: int) -> tuple[int, tuple[int, ...]]:
    plan = _plan(cls)
    if not plan:  # empty structure: one dummy uint8
        return 1, ()
    return plan[0][2].layout(phase)


def _put_fixed(cls: type, pos: int, pads: list[int] | None) -> int:
    size, rel = _fixed_layout(cls, pos % 8)
    if pads is not None and rel:
        pads.extend(pos + r for r in rel)
    return pos + size


def _cdr_end(msg: Any, pos: int = 0, pads: list[int] | None = None) -> int:
    """End offset (after the 4-byte encapsulation header) of ``msg`` serialised from ``pos``."""
    plan = _plan(type(msg))
    if not plan:  # empty structure: one dummy uint8
        return pos + 1
    for name, kind, arg in plan:
        if kind == _K_BLOCK:
            size, rel = arg.layout(pos % 8)
            if rel and pads is not None:
                pads.extend(pos + r for r in rel)
            pos += size
            continue
        v = getattr(msg, name)
        if kind == _K_STR:
            r = -pos % 4
            if r and pads is not None:
                pads += (pos, pos + r)
            pos += r + 5 + (len(v) if v.isascii() else len(v.encode("utf-8")))
        elif kind == _K_MSG:
            pos = _cdr_end(v, pos, pads)
        else:
            if kind in (_K_SEQ_BASIC, _K_SEQ_STR, _K_SEQ_FIXED, _K_SEQ_MSG):
                r = -pos % 4
                if r and pads is not None:
                    pads += (pos, pos + r)
                pos += r + 4
            n = len(v)
            if n == 0:
                continue
            if kind == _K_SEQ_BASIC:
                pos = _align(pos, arg, pads) + arg * n
            elif kind in (_K_SEQ_STR, _K_ARR_STR):
                for x in v:
                    r = -pos % 4
                    if r and pads is not None:
                        pads += (pos, pos + r)
                    pos += r + 5 + (len(x) if x.isascii() else len(x.encode("utf-8")))
            elif kind == _K_SEQ_FIXED:
                size, rel = _fixed_layout(arg, pos % 8)
                if (pos + size) % 8 == pos % 8:  # every element has the same layout
                    if pads is not None and rel:
                        for i in range(n):
                            pads.extend(pos + i * size + r for r in rel)
                    pos += n * size
                else:
                    for _ in range(n):
                        pos = _put_fixed(arg, pos, pads)
            else:
                for x in v:
                    pos = _cdr_end(x, pos, pads)
    return pos


def cdr_length(msg: Any) -> int:
    """Exact length [bytes] of the CDR serialisation of ``msg``, encapsulation header included."""
    return 4 + _cdr_end(msg, 0)


def serialize(msg: Any) -> bytes:
    """CDR bytes of ``msg`` as sent on the wire, deterministic.

    ``serialize_message(msg)`` cut to its exact length, with the alignment padding (which rclpy
    leaves uninitialised) set to zero, so the same message always gives the same bytes. Messages
    with wstring fields are returned as rclpy gives them.
    """
    global _serialize_message
    if _serialize_message is None:
        from rclpy.serialization import serialize_message as _serialize_message
    data = _serialize_message(msg)
    pads: list[int] = []
    try:
        n = 4 + _cdr_end(msg, 0, pads)
    except _UnsupportedLayout:
        return data
    if n > len(data):  # cannot happen for rmw_fastrtps; keep rclpy's bytes untouched
        return data
    if not pads:
        return data[:n] if n < len(data) else data
    buf = bytearray(data[:n])
    it = iter(pads)
    for a, b in zip(it, it, strict=True):
        buf[a + 4:b + 4] = _ZEROS[: b - a]
    return bytes(buf)


# --------------------------------------------------------------------------------------------
# The recorder
# --------------------------------------------------------------------------------------------


class _Sink:
    """Buffered binary file that the MCAP writer writes to; can be flushed to disk (fsync)."""

    def __init__(self, f: Any) -> None:
        self.f = f

    def write(self, data: bytes) -> int:
        return self.f.write(data)

    def tell(self) -> int:
        return self.f.tell()

    def flush(self) -> None:
        self.f.flush()

    def sync(self) -> None:
        self.f.flush()
        os.fsync(self.f.fileno())

    def close(self) -> None:
        self.f.close()


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


#: Most alternative names ``<stem>-<i><suffix>`` tried when the requested file exists.
MAX_NAME_ATTEMPTS = 10_000


def open_new_file(path: Path) -> tuple[Any, Path]:
    """Open a *new* file for writing, never an existing one; return ``(file, path used)``.

    The file is created exclusively (``open(..., "xb")``, O_CREAT | O_EXCL), so two writers that
    ask for the same name at the same instant cannot both get it. When ``path`` exists as a
    regular file (or a link to one), it is left untouched and ``<stem>-1<suffix>``,
    ``<stem>-2<suffix>``, ... are tried instead. An existing non-regular file that is not a
    directory (a device such as ``/dev/full``, a FIFO) holds nothing to destroy and is opened
    for writing as it is.

    Parameters
    ----------
    path : Path
        Requested file.

    Returns
    -------
    file : binary file object
        Open for writing.
    path : Path
        The file actually opened (``path`` itself unless it existed).

    Raises
    ------
    OSError
        ``IsADirectoryError`` when ``path`` is a directory, ``FileExistsError`` when
        :data:`MAX_NAME_ATTEMPTS` names are all taken, or the error of ``open`` itself.
    """
    for i in range(MAX_NAME_ATTEMPTS):
        p = path if i == 0 else path.with_name(f"{path.stem}-{i}{path.suffix}")
        try:
            return open(p, "xb"), p  # noqa: SIM115 - closed by _Sink.close()
        except FileExistsError:
            if p.is_dir():
                raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(p)) from None
            if p.exists() and not p.is_file():  # device / FIFO: nothing to overwrite
                return open(p, "wb"), p  # noqa: SIM115
    raise FileExistsError(errno.EEXIST, f"{path} and {MAX_NAME_ATTEMPTS - 1} numbered alternatives "
                          "exist", str(path))


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
        chunk_size: int = 1 << 20,
    ) -> None:
        #: The file asked for; :attr:`path` is the one written (they differ after a name clash).
        self.requested_path = Path(path)
        self.path = self.requested_path
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE, "": CompressionType.NONE}
        if compression not in comp:
            raise ValueError(f"compression={compression!r}: allowed 'zstd', 'lz4', 'none'")
        if not (flush_period > 0):
            raise ValueError(f"flush_period={flush_period!r}: must be > 0 [s]")
        if max_queue < 1:
            raise ValueError(f"max_queue={max_queue!r}: must be >= 1")
        self.flush_period = float(flush_period)
        #: Writer-thread idle sleep [s]: it drains the queue in batches, so the simulation thread
        #: hands over the GIL rarely.
        self._poll = 0.02
        self.max_queue = int(max_queue)
        self._logger = logger
        self._queue: collections.deque[tuple] = collections.deque()
        self._types: dict[type, str] = {}
        self._topic_types: dict[str, str] = {}
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._counts: dict[str, int] = collections.defaultdict(int)
        self._written = 0
        self._dropped = 0
        self._errors = 0
        self._last_error = ""
        self._failed = False
        self._closing = False
        self._closed = False
        self._close_lock = threading.RLock()
        self._last_drop_log = 0.0
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
        try:
            self._writer = Writer(self._sink, chunk_size=chunk_size, compression=comp[compression])
            _pack_chunk_indexes(self._writer)
            self._writer.start(profile=PROFILE, library=LIBRARY)
            for name, data in (metadata or {}).items():
                self._writer.add_metadata(name, _str_dict(data))
            self._sink.sync()
        except OSError as exc:
            self._sink_close_quietly()
            raise RecorderError(f"cannot record to {str(self.path)!r}: {exc.strerror or exc}") from exc
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
        if self._closing or self._failed:
            self._dropped += 1
            return
        if len(self._queue) >= self.max_queue:
            self._dropped += 1
            now = time.monotonic()
            if now - self._last_drop_log > 1.0:
                self._last_drop_log = now
                self._log(f"recorder queue full ({self.max_queue} messages): dropping messages "
                          f"({self._dropped} dropped so far)")
            return
        lt = int(log_time_ns)
        pt = lt if publish_time_ns is None else int(publish_time_ns)
        self._queue.append(("m", topic, type_name, data, lt, pt))

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Add a metadata record (written in order with the messages)."""
        if self._closing or self._failed:
            return
        self._queue.append(("d", name, _str_dict(data)))

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
        return dict(self._counts)

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
            self._closing = True
            if self._thread.is_alive() and threading.current_thread() is not self._thread:
                self._thread.join(timeout)
            if self._thread.is_alive():
                self._error(f"writer thread did not finish within {timeout} s; file may be incomplete")
            try:
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
        dirty = False
        q = self._queue
        while True:
            if not q:
                if self._closing:
                    break
                now = time.monotonic()
                if dirty and now - last_flush >= self.flush_period:
                    self._flush()
                    dirty = False
                    last_flush = now
                time.sleep(self._poll)
                continue
            item = q.popleft()
            if self._failed:
                if item[0] == "m":
                    self._dropped += 1
                continue
            try:
                if item[0] == "m":
                    _, topic, tname, data, lt, pt = item
                    cid = self._channels.get(topic)
                    if cid is None:
                        cid = self._register(topic, tname)
                    if cid is None:
                        self._dropped += 1
                        continue
                    self._writer.add_message(cid, lt, data, pt, sequence=self._counts[topic])
                    self._counts[topic] += 1
                    self._written += 1
                    dirty = True
                else:
                    self._writer.add_metadata(item[1], item[2])
            except OSError as exc:
                self._io_error(exc)
                if item[0] == "m":
                    self._dropped += 1
                continue
            except Exception as exc:  # noqa: BLE001 - never let the writer thread die silently
                self._error(f"cannot write message: {exc!r}")
                continue
            now = time.monotonic()
            if now - last_flush >= self.flush_period:
                self._flush()
                dirty = False
                last_flush = now
        # final drain is done; flush what is left so a crash during finish() loses nothing
        if dirty:
            self._flush()

    def _register(self, topic: str, tname: str) -> int | None:
        sid = self._schemas.get(tname)
        if sid is None:
            try:
                definition = message_definition(tname)
            except (OSError, ValueError) as exc:
                self._error(f"no message definition for {tname} (topic {topic}): {exc}")
                self._channels[topic] = None  # type: ignore[assignment]
                return None
            sid = self._schemas[tname] = self._writer.register_schema(
                name=tname, encoding=SCHEMA_ENCODING, data=definition.encode())
        cid = self._writer.register_channel(
            topic=topic, message_encoding=MESSAGE_ENCODING, schema_id=sid,
            metadata={"offered_qos_profiles": DEFAULT_QOS_YAML})
        self._channels[topic] = cid
        self._topic_types[topic] = tname
        return cid

    def _flush(self) -> None:
        if self._failed:
            return
        try:
            self._writer.flush()
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


def _str_dict(data: dict[str, Any]) -> dict[str, str]:
    return {str(k): str(v) for k, v in data.items()}


# --------------------------------------------------------------------------------------------
# Metadata helpers and recovery
# --------------------------------------------------------------------------------------------


def run_metadata(
    scene_values: dict[str, Any], *, kernel: str, integrator: str, step: float, n_links: int,
    clock_mode: str, start: datetime | None = None, node: str | None = None,
) -> dict[str, dict[str, str]]:
    """The ``"scene"`` and ``"run"`` metadata records of the shared recording format.

    ``node`` (the recording node's fully qualified name, e.g. ``/leg1/cable_sim_node``) is
    stored as ``run["node"]`` when given.
    """
    version = package_version()
    start = start or datetime.now(UTC)
    run = {
        "kernel": str(kernel), "integrator": str(integrator), "step": repr(float(step)),
        "n_links": str(int(n_links)), "clock_mode": str(clock_mode),
        "start_wall_time_iso": start.isoformat(), "cable_sim_version": str(version),
    }
    if node is not None:
        run["node"] = str(node)
    return {
        "scene": {"json": json.dumps(scene_values, default=_json_default, sort_keys=True)},
        "run": run,
    }


def package_version() -> str:
    """Installed cable_sim version (``"unknown"`` when not installed)."""
    try:
        from importlib.metadata import PackageNotFoundError, version

        return version("cable_sim")
    except (ImportError, PackageNotFoundError):
        return "unknown"


def _json_default(o: Any) -> Any:
    try:
        import numpy as np

        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    return str(o)


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


__all__ = [
    "RunRecorder", "RecorderError", "recover", "scan_records", "message_definition",
    "type_name_of", "serialize", "cdr_length", "run_metadata", "iter_topics", "msg_file",
    "open_new_file",
]
