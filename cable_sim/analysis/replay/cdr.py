"""Decoders of recorded messages: the generic ``mcap_ros2`` one and hand-written CDR readers.

The generic decoder unpacks one float at a time (~20x slower on a long run), so the large,
frequent message types (JointState, WrenchStamped, Float64MultiArray) are read here directly
from their little-endian plain CDR bytes into light attribute bags (:class:`Obj`) carrying only
the fields :func:`cable_sim.analysis.replay.load.load_run` reads. Anything else, or any surprise
in the bytes, falls back to the generic decoder.

Part of the analysis layer; imports numpy and ``mcap_ros2`` only (no other cable_sim module).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import numpy as np

Decoder = Callable[[Any, bytes], Any]


def decoders() -> Decoder:
    """``decode(schema, data)`` through ``mcap_ros2`` (one cached decoder per schema)."""
    from mcap_ros2.decoder import DecoderFactory

    factory = DecoderFactory()
    cache: dict[int, Any] = {}

    def decode(schema, data: bytes):
        d = cache.get(schema.id)
        if d is None:
            d = cache[schema.id] = factory.decoder_for("cdr", schema)
        return d(data)

    return decode


class Stamp:
    """builtin_interfaces/Time as read from CDR."""

    __slots__ = ("sec", "nanosec")

    def __init__(self, sec: int, nanosec: int) -> None:
        self.sec, self.nanosec = sec, nanosec


class Obj:
    """Attribute bag standing in for a decoded message (only the fields ``load_run`` reads)."""

    def __init__(self, **kw: Any) -> None:
        self.__dict__.update(kw)


_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iII")


def _cdr_start(data: bytes) -> tuple[Stamp, int]:
    """Check the encapsulation (little-endian plain CDR) and read a std_msgs/Header.

    Offsets ``o`` are relative to the body (after the 4-byte encapsulation header), as CDR
    alignment is; ``data`` is indexed at ``o + 4``.
    """
    if data[:2] != b"\x00\x01":
        raise ValueError("not little-endian plain CDR")
    sec, nanosec, n = _STAMP.unpack_from(data, 4)
    return Stamp(sec, nanosec), 12 + n


def _cdr_u32(data: bytes, o: int) -> tuple[int, int]:
    o += -o % 4
    return _U32.unpack_from(data, o + 4)[0], o + 4


def _cdr_skip_strings(data: bytes, o: int) -> int:
    count, o = _cdr_u32(data, o)
    unpack = _U32.unpack_from
    for _ in range(count):
        o += -o % 4
        o += 4 + unpack(data, o + 4)[0]
    return o


def _cdr_f64s(data: bytes, o: int, count: int | None = None) -> tuple[np.ndarray, int]:
    if count is None:
        count, o = _cdr_u32(data, o)
    if count == 0:
        return np.zeros(0), o
    o += -o % 8
    end = o + 8 * count
    if end + 4 > len(data):
        raise ValueError("CDR sequence beyond the end of the message")
    return np.frombuffer(data, dtype="<f8", count=count, offset=o + 4), end


def _fast_joint_state(data: bytes) -> Obj:
    stamp, o = _cdr_start(data)
    o = _cdr_skip_strings(data, o)  # names
    pos, o = _cdr_f64s(data, o)
    vel, o = _cdr_f64s(data, o)
    eff, o = _cdr_f64s(data, o)
    return Obj(header=Obj(stamp=stamp), position=pos, velocity=vel, effort=eff)


def _fast_wrench(data: bytes) -> Obj:
    stamp, o = _cdr_start(data)
    f, o = _cdr_f64s(data, o, 3)
    return Obj(header=Obj(stamp=stamp), wrench=Obj(force=Obj(x=f[0], y=f[1], z=f[2])))


def _fast_float_array(data: bytes) -> Obj:
    if data[:2] != b"\x00\x01":
        raise ValueError("not little-endian plain CDR")
    ndim, o = _cdr_u32(data, 0)
    for _ in range(ndim):  # layout.dim: label, size, stride
        n, o = _cdr_u32(data, o)
        o += n + 8 + (-(o + n) % 4)
    _, o = _cdr_u32(data, o)  # layout.data_offset
    return Obj(data=_cdr_f64s(data, o)[0])


#: Hand-written CDR readers for the large, frequent message types (the generic decoder unpacks
#: one float at a time: ~20x slower on a long run). Anything else, or any surprise, falls back.
FAST = {"sensor_msgs/msg/JointState": _fast_joint_state,
        "geometry_msgs/msg/WrenchStamped": _fast_wrench,
        "std_msgs/msg/Float64MultiArray": _fast_float_array}


def fast_decoders() -> Decoder:
    """``decode(schema, data)``: the hand-written readers of :data:`FAST` where they apply, else
    (other types, other encodings, malformed bytes) the generic :func:`decoders`."""
    generic = decoders()

    def decode(schema, data: bytes):
        fast = FAST.get(schema.name)
        if fast is not None and schema.encoding == "ros2msg":
            try:
                return fast(data)
            except (ValueError, IndexError, struct.error):
                pass
        return generic(schema, data)

    return decode
