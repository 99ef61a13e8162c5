"""CDR bytes of a message whose layout is fixed for a run, by patching a serialised template.

The node publishes the same message shapes every tick (a model's n is fixed for the node's life):
a JointState with the same joint names, a MarkerArray with the same markers and point counts, a
Float64MultiArray of n values. Building those as rclpy objects and serialising them costs
milliseconds at n = 2000 (Python objects per point and per name); only a few numbers change.
:class:`TemplateEncoder` serialises one *prototype* once with the exact serialiser
(:func:`cable_sim.ros.recorder.cdr.serialize`), finds where each changing field's bytes lie by
its sentinel values, and then encodes a message by copying the template and writing the new
values into those byte ranges: the result is byte for byte what the serialiser gives for the
same message (tested), published with ``publisher.publish(bytes)`` and recorded as the same bytes.

May import numpy, :mod:`cable_sim.ros.recorder.cdr` (which imports rclpy lazily) and the standard
library.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from cable_sim.ros.recorder.cdr import serialize

#: CDR of the encapsulation header is followed by little-endian data (rmw_fastrtps, x86-64).
_LE = {np.dtype(np.float64): "<f8", np.dtype(np.float32): "<f4", np.dtype(np.int32): "<i4",
       np.dtype(np.uint32): "<u4"}


class TemplateError(ValueError):
    """A sentinel was not found in the prototype's bytes as often as declared."""


def sentinel(shape: int | tuple[int, ...], dtype: Any = np.float64, seed: int = 0) -> np.ndarray:
    """Values to place in a changing field of a prototype: random, distinct, never 0 or 1.

    Parameters
    ----------
    shape : int or tuple of int
        Shape of the field's values.
    dtype : numpy dtype
        float64 (``double``), float32 (``float``).
    seed : int
        Give each field of one prototype its own seed, so their bytes differ.
    """
    rng = np.random.default_rng(12345 + seed)
    return (rng.uniform(3.0, 7.0, size=shape) * (1.0 + 1e-3 * (seed + 1))).astype(dtype)


def stamp_sentinel(seed: int = 0) -> int:
    """A simulated-time stamp [ns] for a prototype: seconds and nanoseconds unlikely in data."""
    return (1_234_567_000 + 1_111 * seed) * 1_000_000_000 + 876_543_219 - seed


def stamp_bytes(stamp_ns: int) -> bytes:
    """builtin_interfaces/Time (int32 sec, uint32 nanosec) of ``stamp_ns`` as CDR bytes."""
    sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
    return np.array([sec], "<i4").tobytes() + np.array([nsec], "<u4").tobytes()


class TemplateEncoder:
    """Encode messages of one fixed layout by writing new values into a serialised prototype.

    Parameters
    ----------
    prototype : rclpy message
        A message of the layout, each changing field holding its sentinel values.
    fields : mapping of str to (ndarray, int)
        Name of each changing field -> (its sentinel values as placed in the prototype, the
        number of times those bytes occur in it; e.g. a header stamp shared by 4 markers).
        Values are written contiguously in C order with the sentinel's dtype.
    stamp : int, optional
        The prototype's header stamp [ns] (:func:`stamp_sentinel`) when the layout has stamps;
        every occurrence of its bytes is then rewritten by :meth:`encode`'s ``stamp_ns``.
    stamps : int
        How many times that stamp occurs.

    Raises
    ------
    TemplateError
        When a sentinel's bytes do not occur exactly as often as declared (the prototype was not
        built with the sentinel, or its bytes occur by chance elsewhere).
    """

    def __init__(self, prototype: Any, fields: Mapping[str, tuple[np.ndarray, int]],
                 stamp: int | None = None, stamps: int = 1) -> None:
        data = serialize(prototype)
        self.nbytes = len(data)
        self._template = bytes(data)
        self._slots: dict[str, tuple[list[int], np.dtype, tuple[int, ...]]] = {}
        for name, (values, count) in fields.items():
            dt = np.dtype(_LE[np.asarray(values).dtype])
            self._slots[name] = (_find(data, np.ascontiguousarray(values, dt).tobytes(), count, name),
                                 dt, np.shape(values))
        self._stamp_at: list[int] = []
        if stamp is not None:
            self._stamp_at = _find(data, stamp_bytes(stamp), stamps, "header stamp")

    def encode(self, stamp_ns: int | None = None, **values: np.ndarray) -> bytes:
        """CDR bytes (encapsulation header included) with the given stamp and field values.

        Every field given at construction must be given, with the sentinel's shape.
        """
        # bytes and bytearray, not numpy uint8 arrays: numpy copies of more than a few hundred
        # elements release the GIL, and each release wakes a thread waiting for it (the
        # recorder's writer) or hands it over, at a cost to this thread (README: recording)
        out = bytearray(self._template)
        if self._stamp_at:
            sb = stamp_bytes(0 if stamp_ns is None else stamp_ns)
            for at in self._stamp_at:
                out[at:at + 8] = sb
        if values.keys() != self._slots.keys():
            raise TypeError(f"encode() needs exactly the fields {sorted(self._slots)}, "
                            f"got {sorted(values)}")
        for name, (offsets, dt, shape) in self._slots.items():
            v = np.asarray(values[name], dtype=dt)
            if v.shape != shape:
                raise ValueError(f"field {name!r} has shape {v.shape}; the layout has {shape}")
            raw = v.tobytes()
            for at in offsets:
                out[at:at + len(raw)] = raw
        return bytes(out)


def _find(data: bytes, pattern: bytes, count: int, name: str) -> list[int]:
    """Start offsets of the ``count`` occurrences of ``pattern`` in ``data`` (else TemplateError)."""
    found, at = [], data.find(pattern)
    while at >= 0:
        found.append(at)
        at = data.find(pattern, at + 1)
    if len(found) != count:
        raise TemplateError(f"{name}: its sentinel bytes occur {len(found)} times in the "
                            f"prototype, expected {count}")
    return found
