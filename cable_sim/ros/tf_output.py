"""TF of the cable in the node's recording: ``/tf``, ``/tf_static`` and ``robot_description`` in the MCAP.

In a ROS 2 install robot_state_publisher turns ``robot_description`` + ``joint_states`` into
``/tf`` and ``/tf_static`` on the live graph. A recording has no robot_state_publisher, so the node
writes what it would send into its MCAP (recording only; the live graph is unchanged): the
transforms of :func:`cable_sim.ros.urdf.tf_transforms` at every joint state (same stamps), the
fixed joints' transforms on ``/tf_static`` once at the start, and the URDF. A recorded run opened
in Foxglove (or played back) then shows the moving chain in a 3D panel with no extra nodes.

tf2_msgs has no wheel here: the ``tf2_msgs/msg/TFMessage`` schema is written from its definition
text (:data:`cable_sim.ros.recorder.definitions.SUPPLIED_DEFINITIONS`) and the CDR bytes by
:class:`TfMessageEncoder` from a template (the frame names and the layout are fixed for a model;
only the stamps and the 7 numbers per transform change), which is what a tf2_msgs publisher sends.
The /tf messages are encoded in the recorder's writer thread, many at once
(:meth:`CableTf.tf_many`, via :meth:`RunRecorder.write_deferred`): the simulation thread only
queues the joint positions.

Frames follow robot_state_publisher's ``frame_prefix``: with the node's ``frame_id`` =
``<prefix>world`` (the launch file's convention; default ``world``) every frame is
``<prefix><link>``; a ``frame_id`` not ending in ``world`` becomes the root frame itself.

May import numpy, numba, the standard library, :mod:`cable_sim.ros.urdf`, :mod:`cable_sim.ros.recorder`
(definitions only, lazily) and :mod:`cable_sim.core`.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

import numba as nb
import numpy as np

from cable_sim.core.model import CableModel
from cable_sim.ros.urdf import JOINT_AXIS, WORLD, static_transforms, tf_transforms

#: Message type of /tf and /tf_static.
TF_TYPE = "tf2_msgs/msg/TFMessage"
#: Topics (global, as tf2 uses them).
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
#: CDR encapsulation header: plain CDR, little endian.
_CDR_LE = b"\x00\x01\x00\x00"


class TfMessageEncoder:
    """CDR bytes of a ``tf2_msgs/msg/TFMessage`` with a fixed list of (parent, child) frames.

    The template is built once; :meth:`encode` / :meth:`encode_at` copy it and write the stamps
    and the numbers through typed views of the copy (CDR aligns every float64 to 8 bytes counted
    from the end of the 4-byte encapsulation header, so the body is an array of float64 and of
    uint32 words), a few numpy assignments whatever the number of transforms.

    Parameters
    ----------
    frames : sequence of (str, str)
        ``(header.frame_id, child_frame_id)`` of each transform, in message order.
    base : ndarray, shape (len(frames), 7), optional
        The numbers :meth:`encode_at` leaves in place (default zeros).
    """

    def __init__(self, frames: Sequence[tuple[str, str]], base: np.ndarray | None = None) -> None:
        self.frames = [(str(p), str(c)) for p, c in frames]
        body = bytearray()  # the message after the encapsulation header (CDR offsets count from here)
        stamps: list[int] = []
        values: list[int] = []

        def align(a: int) -> None:
            body.extend(bytes(-len(body) % a))

        body.extend(struct.pack("<I", len(self.frames)))
        for parent, child in self.frames:
            align(4)
            stamps.append(len(body) // 4)
            body.extend(bytes(8))  # builtin_interfaces/Time: int32 sec, uint32 nanosec
            for name in (parent, child):
                data = name.encode()
                align(4)
                body.extend(struct.pack("<I", len(data) + 1) + data + b"\x00")
            align(8)
            values.append(len(body) // 8)
            body.extend(bytes(56))  # Vector3 translation + Quaternion rotation: 7 float64
        self._size = 4 + len(body)
        align(8)  # the views need whole words; the padding is not sent
        self._template = np.frombuffer(_CDR_LE + bytes(body), dtype=np.uint8).copy()
        #: uint32 word index of each stamp's sec (nanosec follows) and float64 index of each
        #: transform's first number, in the body.
        self._sec_at = np.asarray(stamps, dtype=np.intp)
        self._nsec_at = self._sec_at + 1
        self._value_at = np.asarray(values, dtype=np.intp)[:, None] + np.arange(7)
        if base is not None:
            self._template[4:].view("<f8")[self._value_at] = np.asarray(base, dtype=float)

    def encode(self, stamp_ns: int, values: np.ndarray) -> bytes:
        """The message with every header stamped ``stamp_ns`` and ``values`` as its transforms.

        Parameters
        ----------
        stamp_ns : int
            Stamp of every transform [ns] (>= 0).
        values : ndarray, shape (len(frames), 7)
            Per transform: translation x, y, z [m], rotation quaternion x, y, z, w.
        """
        vals = np.asarray(values, dtype=float)
        if vals.shape != (len(self.frames), 7):
            raise ValueError(f"values has shape {vals.shape}; expected ({len(self.frames)}, 7)")
        return self.encode_at(stamp_ns, ((self._value_at, vals),))

    def positions(self, rows: slice | np.ndarray, cols: slice | np.ndarray) -> np.ndarray:
        """Where ``values[rows, cols]`` of :meth:`encode` go, for :meth:`encode_at`."""
        return self._value_at[rows, cols].copy()

    def encode_at(self, stamp_ns: int, writes: Sequence[tuple[np.ndarray, np.ndarray]]) -> bytes:
        """The message stamped ``stamp_ns`` with ``data`` at each ``positions`` of ``writes`` and
        the constructor's ``base`` elsewhere.

        Parameters
        ----------
        stamp_ns : int
            Stamp of every transform [ns] (>= 0).
        writes : sequence of (positions, data)
            ``positions`` from :meth:`positions`, ``data`` broadcastable to its shape.
        """
        out = self._template.copy()
        words = out[4:].view("<u4")
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        words[self._sec_at] = sec  # int32 sec >= 0: the same bits as uint32
        words[self._nsec_at] = nsec
        numbers = out[4:].view("<f8")
        for at, data in writes:
            numbers[at] = data
        return out[: self._size].tobytes()

    def rows(self, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``count`` copies of the template, one message per row, for writing many messages at
        once (:meth:`CableTf.tf_many`): ``(rows, numbers, words)``. Each row is padded by 4 bytes
        to a multiple of 8, so every message body (after its 4-byte header) starts 8-aligned and
        ``numbers``, ``words`` (float64 and uint32 views of all rows from the first body on) reach
        row ``i``'s body at ``i * rows.shape[1] // 8`` and ``i * rows.shape[1] // 4``."""
        width = self._template.size + 4
        rows = np.zeros((count, width), dtype=np.uint8)
        rows[:, : self._template.size] = self._template
        flat = rows.reshape(-1)[4 : count * width - 4]
        return rows, flat.view("<f8"), flat.view("<u4")

    def rows_bytes(self, rows: np.ndarray) -> list[bytes]:
        """The messages of ``rows`` (:meth:`messages`) as ``bytes``, one per row."""
        return [row.tobytes() for row in rows[:, : self._size]]

    def buffer(self) -> TfMessageBuffer:
        """A message of this layout kept for rewriting in place (see :class:`TfMessageBuffer`)."""
        return TfMessageBuffer(self._template.copy(), self._sec_at, self._nsec_at, self._size)


class TfMessageBuffer:
    """One TFMessage of a :class:`TfMessageEncoder`'s layout, rewritten in place message after message.

    For a caller that writes the same positions every time (the others keep the encoder's
    ``base``): no template copy per message, only the stamps, the written numbers and the final
    copy to ``bytes``. One buffer serves one thread.

    Parameters
    ----------
    message : ndarray of uint8
        A copy of the encoder's template (owned by the buffer from now on).
    sec_at, nsec_at : ndarray of intp
        uint32 word indices (in the body) of each transform's stamp.
    size : int
        Bytes of the message (the template is padded to whole words).
    """

    def __init__(self, message: np.ndarray, sec_at: np.ndarray, nsec_at: np.ndarray, size: int) -> None:
        self._message = message
        self._words = message[4:].view("<u4")
        #: The message's float64 words (body): write the numbers at :meth:`TfMessageEncoder.positions`.
        self.numbers = message[4:].view("<f8")
        self._sec_at = sec_at
        self._nsec_at = nsec_at
        self._size = size

    def tobytes(self, stamp_ns: int) -> bytes:
        """The message with every transform stamped ``stamp_ns`` [ns] (>= 0) and the numbers
        written so far."""
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        self._words[self._sec_at] = sec  # int32 sec >= 0: the same bits as uint32
        self._words[self._nsec_at] = nsec
        return self._message[: self._size].tobytes()


def _values(transforms: Sequence[Any]) -> np.ndarray:
    return np.array([[*t[2], *t[3]] for t in transforms], dtype=float).reshape(len(transforms), 7)


def frame_namer(frame_id: str):
    """Map of URDF link names to TF frame names for the node's ``frame_id`` (module docstring)."""
    if frame_id.endswith(WORLD):
        prefix = frame_id[: -len(WORLD)]
        return lambda name: prefix + name
    return lambda name: frame_id if name == WORLD else name


class CableTf:
    """The moving and fixed transforms of ``model`` as TFMessage bytes (see the module docstring).

    Parameters
    ----------
    model : CableModel
        The simulated model (the one the published URDF describes).
    frame_id : str
        The node's ``frame_id`` (the root frame; see :func:`frame_namer`).
    """

    def __init__(self, model: CableModel, frame_id: str = WORLD) -> None:
        self.model = model
        name = frame_namer(frame_id)
        moving = tf_transforms(model, np.zeros(model.n + 1), include_fixed=False)
        self._base = _values(moving)  # translations constant (heave only in row 0), rotations about -y
        self.moving = TfMessageEncoder([(name(p), name(c)) for p, c, _, _ in moving], self._base)
        fixed = static_transforms(model)
        self.fixed = TfMessageEncoder([(name(p), name(c)) for p, c, _, _ in fixed])
        self._fixed_values = _values(fixed)
        self._axis = np.asarray(JOINT_AXIS, dtype=float)
        self._quaternions = np.empty((4, model.n))  # rows x, y, z, w: contiguous per component
        self._axis_column = self._axis[:, None]
        # what tf() writes per joint state, in place (scratch: one CableTf serves one thread): the
        # heave and the links' quaternions (x, y, z = axis * sin, signed zeros included, as
        # tf_transforms gives them; w = cos)
        self._tf_message = self.moving.buffer()
        self._heave_at = self.moving.positions(0, 2)
        self._w_at = self.moving.positions(slice(1, None), 6)
        self._axis_at = [(self.moving.positions(slice(1, None), 3 + j), float(a))
                         for j, a in enumerate(self._axis)]
        # for tf_many: the same positions as index arrays of the compiled fill
        self._axis_index = np.stack([at for at, _ in self._axis_at]).astype(np.intp)
        self._w_index = np.asarray(self._w_at, dtype=np.intp)
        self._many: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # tf_many's rows
        self._half = np.empty(model.n)
        self._sin = np.empty(model.n)

    def _checked(self, joint_positions: Sequence[float] | np.ndarray) -> np.ndarray:
        """``joint_positions`` as a float array of shape ``(n + 1,)`` (ValueError otherwise)."""
        pos = np.asarray(joint_positions, dtype=float)
        if pos.shape != (self.model.n + 1,):
            raise ValueError(f"joint_positions has shape {pos.shape}; the model needs "
                             f"({self.model.n + 1},) (heave, then one relative angle per link)")
        return pos

    def _rotations(self, joint_positions: Sequence[float] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The joint positions (checked) and the links' quaternions ``(4, n)`` (rows x, y, z, w:
        rotations by the relative angles about :data:`JOINT_AXIS`), in this object's scratch."""
        pos = self._checked(joint_positions)
        half = 0.5 * pos[1:]
        q = self._quaternions
        np.multiply(self._axis_column, np.sin(half), out=q[:3])
        np.cos(half, out=q[3])
        return pos, q

    def moving_values(self, joint_positions: Sequence[float] | np.ndarray) -> np.ndarray:
        """``(n + 1, 7)`` translations and quaternions of the moving joints: the numbers of
        :func:`tf_transforms` (``include_fixed=False``), vectorised."""
        pos, q = self._rotations(joint_positions)
        v = self._base.copy()
        v[0, 2] = pos[0]
        v[1:, 3:7] = q.T
        return v

    def tf(self, joint_positions: Sequence[float] | np.ndarray, stamp_ns: int) -> bytes:
        """``/tf`` message (CDR) at a joint state (``JointState.position`` of the node): the bytes
        of ``moving.encode(stamp_ns, moving_values(joint_positions))``, only the heave and the
        quaternions written into the template."""
        pos = self._checked(joint_positions)
        numbers = self._tf_message.numbers
        half = np.multiply(pos[1:], 0.5, out=self._half)
        s = np.sin(half, out=self._sin)
        for at, a in self._axis_at:
            numbers[at] = s if a == 1.0 else a * s
        numbers[self._w_at] = np.cos(half, out=half)
        numbers[self._heave_at] = pos[0]
        return self._tf_message.tobytes(stamp_ns)

    def tf_many(self, joint_positions: Sequence[np.ndarray], stamps_ns: Sequence[int]) -> list[bytes]:
        """:meth:`tf` of many joint states at once (vectorised over the messages): the bytes of
        ``[tf(p, s) for p, s in zip(joint_positions, stamps_ns)]``, what the recorder's writer
        thread calls for the /tf messages it has gathered (:meth:`TfRecording.joint_state`).
        Keeps its own scratch, not :meth:`tf`'s: callable from another thread than :meth:`tf`, from
        one thread at a time (the writer thread). The messages' rows are kept from call to call:
        only the stamps and the numbers change between messages, so a row is written from the
        template once.

        Parameters
        ----------
        joint_positions : sequence of ndarray, shape (n + 1,) each
            JointState positions (heave, then one relative angle per link).
        stamps_ns : sequence of int
            Stamp of each message [ns] (>= 0).
        """
        if len(joint_positions) == 0:
            return []
        pos = np.asarray(joint_positions, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != self.model.n + 1:
            raise ValueError(f"joint_positions has shape {pos.shape}; the model needs "
                             f"(m, {self.model.n + 1}) (heave, then one relative angle per link)")
        stamps = np.asarray(stamps_ns, dtype=np.int64)
        if stamps.shape != (len(pos),) or (len(stamps) and stamps.min() < 0):
            raise ValueError(f"stamps_ns: {len(pos)} stamps >= 0 needed")
        rows, numbers, words = self._many_rows(len(pos))
        half = np.multiply(pos[:, 1:], 0.5)
        sec, nsec = np.divmod(stamps, 1_000_000_000)
        _fill_moving(numbers, words, rows.shape[1] // 8, rows.shape[1] // 4, np.ascontiguousarray(pos[:, 0]),
                     np.sin(half), np.cos(half), sec, nsec, self.moving._sec_at, self.moving._nsec_at,
                     int(self._heave_at), self._axis_index, self._axis, self._w_index)
        return self.moving.rows_bytes(rows[: len(pos)])

    def _many_rows(self, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`TfMessageEncoder.rows` for at least ``count`` messages, kept for the next call
        (grown to twice its size when too small)."""
        kept = self._many
        if kept is None or kept[0].shape[0] < count:
            kept = self._many = self.moving.rows(max(count, 2 * (0 if kept is None else kept[0].shape[0])))
        return kept

    def tf_static(self, stamp_ns: int) -> bytes:
        """``/tf_static`` message (CDR): the fixed joints."""
        return self.fixed.encode(stamp_ns, self._fixed_values)


@nb.njit(cache=True, nogil=True)
def _fill_moving(numbers: np.ndarray, words: np.ndarray, fstride: int, wstride: int, heave: np.ndarray,
                 sin_half: np.ndarray, cos_half: np.ndarray, sec: np.ndarray, nsec: np.ndarray,
                 sec_at: np.ndarray, nsec_at: np.ndarray, heave_at: int, axis_at: np.ndarray,
                 axis: np.ndarray, w_at: np.ndarray) -> None:
    """Write message ``i`` of :meth:`TfMessageEncoder.rows` (body at ``numbers[i * fstride:]``,
    ``words[i * wstride:]``) for every i: each transform's stamp ``sec[i]``, ``nsec[i]``, the heave
    ``heave[i]`` and the links' quaternions (x, y, z = axis * sin, w = cos of the half angles;
    ``a * s`` as numpy forms it, signed zeros included). Compiled without the GIL: the recorder's
    writer thread runs it while the simulation thread goes on."""
    for i in range(heave.shape[0]):
        fo = i * fstride
        wo = i * wstride
        for k in range(sec_at.shape[0]):
            words[wo + sec_at[k]] = sec[i]  # int32 sec >= 0: the same bits as uint32
            words[wo + nsec_at[k]] = nsec[i]
        numbers[fo + heave_at] = heave[i]
        for j in range(w_at.shape[0]):
            s = sin_half[i, j]
            for d in range(3):
                a = axis[d]
                numbers[fo + axis_at[d, j]] = s if a == 1.0 else a * s
            numbers[fo + w_at[j]] = cos_half[i, j]


class TfRecording:
    """Writes ``/tf`` at every joint state, and ``/tf_static`` + ``robot_description`` once, to a recorder.

    Parameters
    ----------
    recorder : cable_sim.ros.recorder.RunRecorder
        The run's recorder.
    model : CableModel
        The simulated model.
    frame_id : str
        The node's ``frame_id``.
    description_topic : str
        Full name of the node's ``robot_description`` topic.
    """

    def __init__(self, recorder: Any, model: CableModel, frame_id: str, description_topic: str) -> None:
        self.recorder = recorder
        self.cable = CableTf(model, frame_id)
        self._encode = self.cable.tf_many  # one bound method: the writer groups by it
        # compile (or load from numba's cache) the batch encoder now, before real time starts,
        # not in the writer thread at the first batch (a compile holds the GIL for seconds)
        self.cable.tf_many([np.zeros(model.n + 1)], [0])
        self.description_topic = description_topic
        self.started = False
        from cable_sim.ros.recorder.definitions import TRANSIENT_LOCAL_QOS_YAML  # the recorder needs mcap

        for topic in (TF_STATIC_TOPIC, description_topic):
            recorder.offer_qos(topic, TRANSIENT_LOCAL_QOS_YAML)

    def start(self, description_msg: Any, stamp_ns: int) -> None:
        """Record ``robot_description`` and ``/tf_static`` (once: at the start of the recording)."""
        if self.started:
            return
        self.started = True
        self.recorder.write(self.description_topic, description_msg, stamp_ns)
        self.recorder.write_serialized(TF_STATIC_TOPIC, TF_TYPE, self.cable.tf_static(stamp_ns), stamp_ns)

    def joint_state(self, joint_positions: Sequence[float], stamp_ns: int) -> None:
        """Record ``/tf`` at a published joint state: the positions (a copy) are queued, and the
        recorder's writer thread encodes the /tf messages it has gathered at once
        (:meth:`CableTf.tf_many`; the same bytes as :meth:`CableTf.tf`), in their place among the
        other messages."""
        pos = np.array(joint_positions, dtype=float)
        if pos.shape != (self.cable.model.n + 1,):
            self.cable._checked(pos)  # raises the ValueError that names the shapes
        self.recorder.write_deferred(TF_TOPIC, TF_TYPE, self._encode, pos, stamp_ns)


__all__ = ["TF_TYPE", "TF_TOPIC", "TF_STATIC_TOPIC", "TfMessageEncoder", "TfMessageBuffer", "CableTf",
           "TfRecording", "frame_namer"]
