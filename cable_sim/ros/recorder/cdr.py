"""Exact, deterministic CDR bytes of an rclpy message (what a subscriber receives).

May import rclpy (lazily) and the standard library.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

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
