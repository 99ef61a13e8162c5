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

The package: :mod:`.writer` (:class:`RunRecorder`), :mod:`.definitions` (message definition
text), :mod:`.cdr` (exact CDR bytes), :mod:`.files` (new files only), :mod:`.index` (packed chunk
indexes), :mod:`.metadata` (run metadata), :mod:`.recover` (truncated files). This ``__init__``
re-exports what the node, the analysis tools and the tests use; modules of the package import
their siblings directly. May import mcap, rclpy (lazily) and the standard library.
"""

from cable_sim.ros.recorder.cdr import cdr_length, serialize
from cable_sim.ros.recorder.definitions import message_definition, msg_file, type_name_of
from cable_sim.ros.recorder.files import open_new_file
from cable_sim.ros.recorder.metadata import package_version, run_metadata
from cable_sim.ros.recorder.recover import iter_topics, recover, scan_records
from cable_sim.ros.recorder.writer import RecorderError, RunRecorder

__all__ = [
    "RunRecorder", "RecorderError", "recover", "scan_records", "message_definition",
    "type_name_of", "serialize", "cdr_length", "run_metadata", "iter_topics", "msg_file",
    "open_new_file", "package_version",
]
