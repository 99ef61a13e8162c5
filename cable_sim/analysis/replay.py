"""Read, plot, export and re-simulate a recorded run (an MCAP file written by the node).

Everything here works on the file alone (``mcap`` + ``mcap_ros2`` decoder, no ROS graph):

- :func:`load_run` decodes the recorded topics into arrays (:class:`Run`) and rebuilds the
  scene from the ``"scene"`` metadata record with :func:`cable_sim.scene.scenes.scene_from_dict`;
- :func:`summary` prints scene, duration, achieved real-time factor, max/RMS fairlead tension,
  max tip excursion, rejected inputs and overruns;
- :func:`plot_frames` (configurations as frames, like Figs. 9 and 10 of Pouzada & Gomes),
  :func:`plot_tension` (fairlead tension and heave time series), :func:`animate` (GIF);
- :func:`resimulate` runs :class:`cable_sim.scene.simulation.Simulation` again from the recorded
  ``applied_inputs`` (optionally with another n, integrator, step or kernel) and
  :func:`compare` reports the difference from the recording; with the recorded settings it is
  exactly zero;
- :func:`export_csv`;
- :func:`record_headless` runs a scene without ROS and records the same topics and message
  types the node publishes (for documentation figures and tests of the recorder);
- ``cable_sim_replay --recover BAD.mcap FIXED.mcap`` repairs a file cut short by SIGKILL.

Timing convention of ``applied_inputs``: a value recorded with log time ``t_ns`` is held from
step ``k = round(t_ns / (h * 1e9))`` on (``h`` the recorded step), i.e. over the step from k to
k + 1; the outputs stamped k were published before it was applied (as the node does); with
another step ``h'`` it applies from ``round(t_ns / (h' * 1e9))``.
"""

from __future__ import annotations

import argparse
import csv
import json
import struct
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cable_sim.core import dynamics
from cable_sim.ros.messages import (
    build_diagnostics,
    build_float_array,
    build_joint_state,
    build_markers,
    build_wrench,
    clock_message,
    joint_state_arrays,
)
from cable_sim.scene.scenes import Scene, load_scene, scene_from_dict

#: Topic base names the node publishes / subscribes (relative; recorded with namespace).
TOPICS = ("joint_states", "cable_markers", "fairlead_tension", "anchor_force", "line_tension",
          "diagnostics", "applied_inputs", "heave_force", "wave_elevation", "clock")

Progress = Callable[[str], None]


def _base(topic: str) -> str:
    return topic.rstrip("/").rsplit("/", 1)[-1]


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


@dataclass
class Series:
    """A time series: ``t`` [s] (n,) and ``v`` (n, ...)."""

    t: np.ndarray
    v: np.ndarray

    def __len__(self) -> int:
        return len(self.t)


def _empty(width: int | None = None) -> Series:
    return Series(np.zeros(0), np.zeros((0,) if width is None else (0, width)))


@dataclass
class Run:
    """A recorded run as arrays (SI units, times in seconds of simulation time).

    Attributes
    ----------
    path : Path
        The file.
    scene : Scene
        Scene rebuilt from the ``"scene"`` metadata (at the recorded number of links).
    run_info : dict
        The ``"run"`` metadata record (kernel, integrator, step, n_links, clock_mode, ...).
    metadata : dict
        Every metadata record by name.
    t_ns : ndarray (N,) int64
        Joint-state stamps [ns].
    t : ndarray (N,)
        Joint-state times [s].
    heave : ndarray (N,)
        Platform heave z_m [m].
    joint_position, joint_velocity, joint_effort : ndarray (N, n+1)
        JointState arrays as recorded (heave then relative angles).
    angles : ndarray (N, n)
        Absolute link angles theta_i [rad] (cumulative sum of the relative angles).
    polyline : ndarray (N, n+1, 2)
        (x, z) of the fairlead and every joint [m] (:func:`cable_sim.core.dynamics.joint_positions`).
    fairlead : Series
        Force the cable exerts on the platform, ``v`` (M, 2) = (F_x, F_z) [N].
    anchor : Series
        Force the cable exerts on the anchor (K, 2) [N] (empty for a free end).
    line_tension : Series
        Axial tension at the top of each link (L, n) [N].
    applied : Series
        Held input values (A, 2) = (heave_force, wave_elevation) from ``applied_inputs``.
    applied_t_ns : ndarray (A,) int64
        Their log times [ns].
    received : dict of str -> Series
        Input messages received (``heave_force``, ``wave_elevation``), values (R,).
    diagnostics : dict of str -> Series
        Numeric diagnostic values by ``"status name/key"`` (non-numeric values are skipped).
    diagnostics_text : dict of str -> list of str
        Last value of every diagnostic key, as text.
    counts : dict of str -> int
        Messages per topic.
    """

    path: Path
    scene: Scene
    run_info: dict[str, str]
    metadata: dict[str, dict[str, str]]
    t_ns: np.ndarray
    t: np.ndarray
    heave: np.ndarray
    joint_position: np.ndarray
    joint_velocity: np.ndarray
    joint_effort: np.ndarray
    angles: np.ndarray
    polyline: np.ndarray
    fairlead: Series
    anchor: Series
    line_tension: Series
    applied: Series
    applied_t_ns: np.ndarray
    received: dict[str, Series] = field(default_factory=dict)
    diagnostics: dict[str, Series] = field(default_factory=dict)
    diagnostics_text: dict[str, str] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)

    @property
    def n_links(self) -> int:
        """Number of links."""
        return self.angles.shape[1]

    @property
    def step(self) -> float:
        """Recorded physics step h [s]."""
        return float(self.run_info.get("step", self.scene.sim["step"]))

    @property
    def fairlead_tension(self) -> np.ndarray:
        """|fairlead force| [N] at ``fairlead.t``."""
        return np.hypot(self.fairlead.v[:, 0], self.fairlead.v[:, 1]) if len(self.fairlead) else np.zeros(0)

    @property
    def tip(self) -> np.ndarray:
        """(x, z) of the cable's end (N, 2) [m]."""
        return self.polyline[:, -1, :]

    def diagnostic(self, *words: str) -> Series | None:
        """The first numeric diagnostic whose key contains all ``words`` (case-insensitive)."""
        for key, s in self.diagnostics.items():
            k = key.lower()
            if all(w.lower() in k for w in words):
                return s
        return None


def _decoders():
    from mcap_ros2.decoder import DecoderFactory

    factory = DecoderFactory()
    cache: dict[int, Any] = {}

    def decode(schema, data: bytes):
        d = cache.get(schema.id)
        if d is None:
            d = cache[schema.id] = factory.decoder_for("cdr", schema)
        return d(data)

    return decode


class _Stamp:
    __slots__ = ("sec", "nanosec")

    def __init__(self, sec: int, nanosec: int) -> None:
        self.sec, self.nanosec = sec, nanosec


class _Obj:
    """Attribute bag standing in for a decoded message (only the fields :func:`load_run` reads)."""

    def __init__(self, **kw: Any) -> None:
        self.__dict__.update(kw)


_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iII")


def _cdr_start(data: bytes) -> tuple[_Stamp, int]:
    """Check the encapsulation (little-endian plain CDR) and read a std_msgs/Header.

    Offsets ``o`` are relative to the body (after the 4-byte encapsulation header), as CDR
    alignment is; ``data`` is indexed at ``o + 4``.
    """
    if data[:2] != b"\x00\x01":
        raise ValueError("not little-endian plain CDR")
    sec, nanosec, n = _STAMP.unpack_from(data, 4)
    return _Stamp(sec, nanosec), 12 + n


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


def _fast_joint_state(data: bytes) -> _Obj:
    stamp, o = _cdr_start(data)
    o = _cdr_skip_strings(data, o)  # names
    pos, o = _cdr_f64s(data, o)
    vel, o = _cdr_f64s(data, o)
    eff, o = _cdr_f64s(data, o)
    return _Obj(header=_Obj(stamp=stamp), position=pos, velocity=vel, effort=eff)


def _fast_wrench(data: bytes) -> _Obj:
    stamp, o = _cdr_start(data)
    f, o = _cdr_f64s(data, o, 3)
    return _Obj(header=_Obj(stamp=stamp), wrench=_Obj(force=_Obj(x=f[0], y=f[1], z=f[2])))


def _fast_float_array(data: bytes) -> _Obj:
    if data[:2] != b"\x00\x01":
        raise ValueError("not little-endian plain CDR")
    ndim, o = _cdr_u32(data, 0)
    for _ in range(ndim):  # layout.dim: label, size, stride
        n, o = _cdr_u32(data, o)
        o += n + 8 + (-(o + n) % 4)
    _, o = _cdr_u32(data, o)  # layout.data_offset
    return _Obj(data=_cdr_f64s(data, o)[0])


#: Hand-written CDR readers for the large, frequent message types (the generic decoder unpacks
#: one float at a time: ~20x slower on a long run). Anything else, or any surprise, falls back.
_FAST = {"sensor_msgs/msg/JointState": _fast_joint_state,
         "geometry_msgs/msg/WrenchStamped": _fast_wrench,
         "std_msgs/msg/Float64MultiArray": _fast_float_array}


def _fast_decoders():
    generic = _decoders()

    def decode(schema, data: bytes):
        fast = _FAST.get(schema.name)
        if fast is not None and schema.encoding == "ros2msg":
            try:
                return fast(data)
            except (ValueError, IndexError, struct.error):
                pass
        return generic(schema, data)

    return decode


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _number(s: str) -> float | None:
    try:
        v = float(s)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def read_metadata(path: str | Path) -> dict[str, dict[str, str]]:
    """Every metadata record of an MCAP file by name."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}


def scene_of(metadata: dict[str, dict[str, str]]) -> Scene:
    """The scene recorded in the ``"scene"`` metadata (at the recorded ``n_links``)."""
    if "scene" not in metadata or "json" not in metadata["scene"]:
        raise ValueError("recording has no 'scene' metadata record with a 'json' entry")
    scene = scene_from_dict(json.loads(metadata["scene"]["json"]))
    n = metadata.get("run", {}).get("n_links")
    if n is not None and int(n) != scene.params.n_links:
        scene = scene.with_links(int(n))
    return scene


#: Topics :func:`load_run` can decode (base names).
LOADABLE = frozenset({"joint_states", "fairlead_tension", "anchor_force", "line_tension", "diagnostics",
                      "applied_inputs", "heave_force", "wave_elevation"})

#: Fewer messages to read than this: no progress lines.
PROGRESS_MIN_MESSAGES = 10_000


def load_run(path: str | Path, progress: Progress | None = None, namespace: str | None = None,
             topics: Iterable[str] | None = None) -> Run:
    """Decode a recorded run into arrays.

    Only the requested topics are read (chunks are still decompressed, but other messages are
    neither decoded nor kept); the large message types are decoded by hand-written CDR readers.

    Parameters
    ----------
    path : str or Path
        The ``.mcap`` file.
    progress : callable, optional
        Called with a progress line at every 10 % of the messages to read, when there are at
        least :data:`PROGRESS_MIN_MESSAGES` of them.
    namespace : str, optional
        Only topics under this namespace (default: every topic, by base name).
    topics : iterable of str, optional
        Base names of the topics to decode, a subset of :data:`LOADABLE` (default: all of them);
        ``joint_states`` is always read. Series of topics not read are empty.

    Raises
    ------
    ValueError
        When the file has no scene metadata or no joint states, or ``topics`` names a topic
        not in :data:`LOADABLE`.
    """
    from mcap.reader import make_reader

    path = Path(path)
    wanted = set(LOADABLE if topics is None else topics) | {"joint_states"}
    if not wanted <= LOADABLE:
        raise ValueError(f"topics {sorted(wanted - LOADABLE)}: allowed {sorted(LOADABLE)}")
    decode = _fast_decoders()
    js_t: list[int] = []
    js_p: list[Any] = []
    js_v: list[Any] = []
    js_e: list[Any] = []
    fl_t: list[int] = []
    fl_v: list[tuple[float, float]] = []
    an_t: list[int] = []
    an_v: list[tuple[float, float]] = []
    lt_t: list[int] = []
    lt_v: list[Any] = []
    ap_t: list[int] = []
    ap_v: list[Any] = []
    rc: dict[str, tuple[list[int], list[float]]] = {"heave_force": ([], []), "wave_elevation": ([], [])}
    dg: dict[str, tuple[list[int], list[float]]] = {}
    dg_text: dict[str, str] = {}
    counts: dict[str, int] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        scene = scene_of(metadata)

        def selected(topic: str) -> bool:
            if namespace is not None and topic.rstrip("/").rsplit("/", 1)[0] != namespace.rstrip("/"):
                return False
            return _base(topic) in wanted

        stats = summary.statistics if summary is not None else None
        if stats is not None and stats.channel_message_counts:
            # counts from the summary; read only the selected channels
            for cid, n_msg in stats.channel_message_counts.items():
                topic = summary.channels[cid].topic
                counts[topic] = counts.get(topic, 0) + n_msg
            read = sorted(t for t in counts if selected(t))
            total = sum(counts[t] for t in read)
            count_here = False
        else:
            read, total, count_here = None, 0, True
        show = progress is not None and total >= PROGRESS_MIN_MESSAGES
        t0 = time.monotonic()
        next_tenth, seen = 1, 0
        for schema, channel, message in reader.iter_messages(topics=read, log_time_order=True):
            topic = channel.topic
            if count_here:
                counts[topic] = counts.get(topic, 0) + 1
            if not selected(topic):
                continue
            seen += 1
            if show and seen * 10 >= next_tenth * total:
                progress(f"{path.name}: read {seen}/{total} messages ({10 * next_tenth}%, "
                         f"{time.monotonic() - t0:.1f} s)")
                next_tenth = seen * 10 // total + 1
            base = _base(topic)
            msg = decode(schema, message.data)
            lt = int(message.log_time)
            if base == "joint_states":
                js_t.append(_stamp_ns(msg.header.stamp))
                js_p.append(msg.position)
                js_v.append(msg.velocity)
                js_e.append(msg.effort)
            elif base == "fairlead_tension":
                fl_t.append(_stamp_ns(msg.header.stamp))
                fl_v.append((msg.wrench.force.x, msg.wrench.force.z))
            elif base == "anchor_force":
                an_t.append(_stamp_ns(msg.header.stamp))
                an_v.append((msg.wrench.force.x, msg.wrench.force.z))
            elif base == "line_tension":
                lt_t.append(lt)
                lt_v.append(msg.data)
            elif base == "applied_inputs":
                ap_t.append(lt)
                ap_v.append(list(msg.data)[:2])
            elif base in rc:
                rc[base][0].append(lt)
                rc[base][1].append(float(msg.data))
            elif base == "diagnostics":
                for st in msg.status:
                    for kv in st.values:
                        key = f"{st.name}/{kv.key}"
                        dg_text[key] = kv.value
                        v = _number(kv.value)
                        if v is not None:
                            s = dg.setdefault(key, ([], []))
                            s[0].append(lt)
                            s[1].append(v)
    if not js_t:
        raise ValueError(f"{path}: no joint_states messages")
    pos = np.asarray(js_p, dtype=float)
    n = pos.shape[1] - 1
    if n != scene.params.n_links:
        scene = scene.with_links(n)
    model = scene.model()
    angles = np.cumsum(pos[:, 1:], axis=1)
    q = np.concatenate([pos[:, :1], angles], axis=1)
    poly = np.stack([dynamics.joint_positions(model, qi) for qi in q])
    t_ns = np.asarray(js_t, dtype=np.int64)

    def series(ts: list[int], vs: list[Any], width: int | None) -> Series:
        if not ts:
            return _empty(width)
        return Series(np.asarray(ts, dtype=np.int64) / 1e9, np.asarray(vs, dtype=float))

    return Run(
        path=path, scene=scene, run_info=metadata.get("run", {}), metadata=metadata,
        t_ns=t_ns, t=t_ns / 1e9, heave=pos[:, 0].copy(), joint_position=pos,
        joint_velocity=_rect(js_v, n + 1), joint_effort=_rect(js_e, n + 1),
        angles=angles, polyline=poly,
        fairlead=series(fl_t, fl_v, 2), anchor=series(an_t, an_v, 2),
        line_tension=series(lt_t, lt_v, n),
        applied=series(ap_t, ap_v, 2), applied_t_ns=np.asarray(ap_t, dtype=np.int64),
        received={k: series(v[0], v[1], None) for k, v in rc.items()},
        diagnostics={k: series(v[0], v[1], None) for k, v in dg.items()},
        diagnostics_text=dg_text, counts=counts,
    )


def _rect(rows: list[Any], width: int) -> np.ndarray:
    if rows and all(len(r) == width for r in rows):
        return np.asarray(rows, dtype=float)
    return np.full((len(rows), width), np.nan)


# --------------------------------------------------------------------------------------------
# Summary
# --------------------------------------------------------------------------------------------


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def summary_values(run: Run) -> dict[str, Any]:
    """The numbers :func:`summary` prints."""
    ten = run.fairlead_tension
    tip0 = run.tip[0]
    exc = np.linalg.norm(run.tip - tip0, axis=1)
    rtf = run.diagnostic("real", "time", "factor") or run.diagnostic("rtf")
    rej = run.diagnostic("rejected")
    ovr = run.diagnostic("overrun")
    return {
        "scene": run.scene.name,
        "n_links": run.n_links,
        "kernel": run.run_info.get("kernel", ""),
        "integrator": run.run_info.get("integrator", ""),
        "step": run.step,
        "clock_mode": run.run_info.get("clock_mode", ""),
        "duration": float(run.t[-1] - run.t[0]) if len(run.t) else 0.0,
        "t_end": float(run.t[-1]),
        "real_time_factor": float(rtf.v[-1]) if rtf is not None and len(rtf) else float("nan"),
        "fairlead_tension_max": float(ten.max()) if len(ten) else float("nan"),
        "fairlead_tension_rms": _rms(ten),
        "tip_excursion_max": float(exc.max()),
        "joint_excursion_max": float(np.linalg.norm(run.polyline - run.polyline[:1], axis=2).max()),
        "rejected_inputs": int(rej.v[-1]) if rej is not None and len(rej) else 0,
        "overruns": int(ovr.v[-1]) if ovr is not None and len(ovr) else 0,
        "messages": dict(run.counts),
    }


def summary(run: Run) -> str:
    """Human-readable summary of a run."""
    s = summary_values(run)
    lines = [
        f"file          {run.path}",
        f"scene         {s['scene']} (n = {s['n_links']}, {s['integrator']}, h = {s['step']:g} s, "
        f"kernel {s['kernel']}, clock {s['clock_mode']})",
        f"duration      {s['duration']:.3f} s simulated (t = {run.t[0]:.3f} .. {s['t_end']:.3f} s)",
        f"real-time     {s['real_time_factor']:.3g} x (last reported)",
        f"fairlead T    max {s['fairlead_tension_max']:.6g} N, RMS {s['fairlead_tension_rms']:.6g} N",
        f"tip excursion max {s['tip_excursion_max']:.4g} m from its initial position "
        f"(any joint: {s['joint_excursion_max']:.4g} m)",
        f"rejected      {s['rejected_inputs']} inputs",
        f"overruns      {s['overruns']}",
        "messages      " + ", ".join(f"{k} {v}" for k, v in sorted(s["messages"].items())),
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------------------------


def _frame_indices(run: Run, interval: float | None) -> np.ndarray:
    if interval is None:
        interval = float(run.scene.extra.get("frame_interval", 1.0))
    if interval <= 0:
        raise ValueError(f"frame interval {interval!r}: must be > 0 [s]")
    targets = np.arange(run.t[0], run.t[-1] + 1e-9, interval)
    idx = np.unique(np.clip(np.searchsorted(run.t, targets - 1e-9), 0, len(run.t) - 1))
    return idx


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _draw_scene(ax, run: Run) -> None:
    m = run.scene.model()
    if m.end != 0:
        ax.plot(*m.anchor, marker="^", color="k", ms=9, ls="none", label="anchor")
    ax.axhline(0.0, color="tab:blue", lw=0.8, alpha=0.5)


def plot_frames(run: Run, out: str | Path, interval: float | None = None, title: str | None = None) -> Path:
    """The cable's configuration every ``interval`` seconds, one x-z figure (paper Figs. 9/10).

    The platform (fairlead) is drawn at the top of each polyline; equal aspect.
    """
    plt = _pyplot()
    idx = _frame_indices(run, interval)
    fig, ax = plt.subplots(figsize=(7.5, 7.0))
    cmap = plt.get_cmap("viridis")
    for j, i in enumerate(idx):
        c = cmap(j / max(1, len(idx) - 1))
        p = run.polyline[i]
        ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=1.0)
        ax.plot(p[0, 0], p[0, 1], "s", color=c, ms=5)
    _draw_scene(ax, run)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    step = float(np.median(np.diff(run.t[idx]))) if len(idx) > 1 else 0.0
    ax.set_title(title or f"{run.scene.name}: {len(idx)} frames every {step:g} s, "
                 f"t = {run.t[idx[0]]:g}..{run.t[idx[-1]]:g} s (platform ■ at top)")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(run.t[idx[0]], run.t[idx[-1]]))
    fig.colorbar(sm, ax=ax, label="t [s]", shrink=0.8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_tension(run: Run, out: str | Path, title: str | None = None) -> Path:
    """Fairlead tension (and anchor force) and platform heave against time."""
    plt = _pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    if len(run.fairlead):
        a1.plot(run.fairlead.t, run.fairlead_tension / 1e3, label="fairlead |F| (cable on platform)")
    if len(run.anchor):
        a1.plot(run.anchor.t, np.hypot(*run.anchor.v.T) / 1e3, label="anchor |F|", alpha=0.8)
    a1.set_ylabel("tension [kN]")
    a1.legend(loc="best")
    a1.grid(True, alpha=0.3)
    a2.plot(run.t, run.heave, color="tab:green")
    a2.set_ylabel("heave z_m [m]")
    a2.set_xlabel("t [s]")
    a2.grid(True, alpha=0.3)
    a1.set_title(title or f"{run.scene.name}: fairlead tension and platform heave")
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def gif_frame_indices(run: Run, seconds: float = 10.0, fps: float = 10.0,
                      interval: float | None = None) -> np.ndarray:
    """Joint-state samples shown in a GIF of at most ``seconds * fps`` frames.

    Without ``interval``, a short run plays in real time (one frame every ``1 / fps`` s of
    simulation time) and a longer one is subsampled evenly to fit in ``seconds``. With
    ``interval`` [s], one frame every ``interval`` s, also subsampled evenly if that gives more
    than ``seconds * fps`` frames.

    Raises
    ------
    ValueError
        When ``seconds``, ``fps`` or ``interval`` is not > 0.
    """
    if not (np.isfinite(seconds) and seconds > 0):
        raise ValueError(f"gif seconds {seconds!r}: must be > 0 [s]")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"gif fps {fps!r}: must be > 0 [frames/s]")
    max_frames = max(1, int(seconds * fps + 1e-9))
    if interval is None:
        span = float(run.t[-1] - run.t[0])
        interval = max(1.0 / fps, span / max(1, max_frames - 1)) if span > 0 else 1.0 / fps
    idx = _frame_indices(run, interval)
    if len(idx) > max_frames:
        idx = np.unique(idx[np.round(np.linspace(0, len(idx) - 1, max_frames)).astype(int)])
    return idx


def animate(run: Run, out: str | Path, interval: float | None = None, fps: float = 10.0,
            seconds: float = 10.0, progress: Progress | None = None) -> Path:
    """Animated GIF of the cable: at most ``seconds * fps`` frames played at ``fps``.

    Frames are chosen by :func:`gif_frame_indices` (a long run is subsampled to fit in
    ``seconds``); ``progress`` gets a line at every 10 % of the frames rendered.
    """
    plt = _pyplot()
    from matplotlib.animation import PillowWriter

    idx = gif_frame_indices(run, seconds, fps, interval)
    fig, ax = plt.subplots(figsize=(6, 5.5))
    allp = run.polyline[idx]
    pad = 5.0
    ax.set_xlim(allp[..., 0].min() - pad, allp[..., 0].max() + pad)
    ax.set_ylim(allp[..., 1].min() - pad, max(allp[..., 1].max(), 0.0) + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    _draw_scene(ax, run)
    (line,) = ax.plot([], [], "-o", ms=2, lw=1.2)
    (plat,) = ax.plot([], [], "s", ms=8, color="tab:red")
    txt = ax.set_title("")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = PillowWriter(fps=fps)
    t0 = time.monotonic()
    n_frames, next_tenth = len(idx), 1
    if progress is not None:
        every = float(np.median(np.diff(run.t[idx]))) if n_frames > 1 else 0.0
        progress(f"{out.name}: rendering {n_frames} frames (one every {every:.3g} s of the run, "
                 f"{n_frames / fps:.3g} s at {fps:g} fps)")
    with writer.saving(fig, str(out), dpi=80):
        for j, i in enumerate(idx, start=1):
            p = run.polyline[i]
            line.set_data(p[:, 0], p[:, 1])
            plat.set_data([p[0, 0]], [p[0, 1]])
            txt.set_text(f"{run.scene.name}  t = {run.t[i]:.2f} s")
            writer.grab_frame()
            if progress is not None and j * 10 >= next_tenth * n_frames:
                progress(f"{out.name}: frame {j}/{n_frames} ({10 * next_tenth}%, "
                         f"{time.monotonic() - t0:.1f} s)")
                next_tenth = j * 10 // n_frames + 1
    plt.close(fig)
    return out


# --------------------------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------------------------


def export_csv(run: Run, out: str | Path) -> Path:
    """One row per joint-state sample: t, heave, tip x/z, fairlead force and tension, held
    inputs, absolute angles.

    Fairlead values are linearly interpolated onto the joint-state times when the two topics
    were published at different times (exact when they share stamps).
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    t = run.t
    if len(run.fairlead):
        fx = np.interp(t, run.fairlead.t, run.fairlead.v[:, 0])
        fz = np.interp(t, run.fairlead.t, run.fairlead.v[:, 1])
    else:
        fx = fz = np.full(len(t), np.nan)
    held = np.zeros((len(t), 2))
    if len(run.applied):
        j = np.searchsorted(run.applied_t_ns, run.t_ns, side="right") - 1
        ok = j >= 0
        held[ok] = run.applied.v[j[ok]]
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "heave", "tip_x", "tip_z", "fairlead_fx", "fairlead_fz", "fairlead_tension",
                    "held_heave_force", "held_wave_elevation"]
                   + [f"theta_{i + 1}" for i in range(run.n_links)])
        for i in range(len(t)):
            w.writerow([repr(float(t[i])), repr(float(run.heave[i])), repr(float(run.tip[i, 0])),
                        repr(float(run.tip[i, 1])), repr(float(fx[i])), repr(float(fz[i])),
                        repr(float(np.hypot(fx[i], fz[i]))), repr(float(held[i, 0])),
                        repr(float(held[i, 1]))] + [repr(float(a)) for a in run.angles[i]])
    return out


# --------------------------------------------------------------------------------------------
# Re-simulation
# --------------------------------------------------------------------------------------------


@dataclass
class Resim:
    """A re-simulation sampled at the recording's times.

    Attributes
    ----------
    settings : dict
        kernel, integrator, step, n_links used.
    t : ndarray (N,)
        Simulation times of the samples [s] (``k * h`` nearest to each recorded stamp).
    joint_position, joint_velocity, joint_effort : ndarray (N, n+1)
        JointState arrays, computed as the node computes them.
    heave : ndarray (N,)
    tip : ndarray (N, 2)
    fairlead_t : ndarray (M,)
    fairlead : ndarray (M, 2)
        Force the cable exerts on the platform [N].
    steps : int
        Physics steps taken.
    wall : float
        Wall time of the re-simulation [s].
    """

    settings: dict[str, Any]
    t: np.ndarray
    joint_position: np.ndarray
    joint_velocity: np.ndarray
    joint_effort: np.ndarray
    heave: np.ndarray
    tip: np.ndarray
    fairlead_t: np.ndarray
    fairlead: np.ndarray
    steps: int
    wall: float



def resimulate(
    run: Run, *, links: int | None = None, integrator: str | None = None, step: float | None = None,
    kernel: str | None = None, progress: Progress | None = None,
) -> Resim:
    """Run the recorded scene again from its recorded ``applied_inputs``.

    Defaults are the recorded settings (``run`` metadata), which reproduce the recorded joint
    states bit for bit. Samples are taken at the recorded joint-state and fairlead stamps
    (nearest step of the new ``h``).
    """
    from cable_sim.scene.simulation import Simulation

    ri = run.run_info
    rec_step = float(ri.get("step", run.step))
    settings = {
        "kernel": kernel or ri.get("kernel") or run.scene.sim["kernel"],
        "integrator": integrator or ri.get("integrator") or run.scene.sim["integrator"],
        "step": float(step) if step is not None else rec_step,
        "n_links": int(links) if links is not None else run.n_links,
    }
    sim = Simulation(run.scene, kernel=settings["kernel"], integrator=settings["integrator"],
                     step=settings["step"], n_links=settings["n_links"])
    h = sim.h
    hns = h * 1e9
    k_js = np.rint(run.t_ns / hns).astype(np.int64)
    fl_ns = np.rint(run.fairlead.t * 1e9).astype(np.int64) if len(run.fairlead) else np.zeros(0, np.int64)
    k_fl = np.rint(fl_ns / hns).astype(np.int64)
    k_in = np.rint(run.applied_t_ns / hns).astype(np.int64)
    k_end = int(max(k_js.max(initial=0), k_fl.max(initial=0)))
    n = settings["n_links"]
    N = len(k_js)
    jp = np.empty((N, n + 1))
    jv = np.empty((N, n + 1))
    je = np.empty((N, n + 1))
    tip = np.empty((N, 2))
    fl = np.empty((len(k_fl), 2))
    events: dict[int, list[tuple[str, int]]] = {}
    for i, k in enumerate(k_js):
        events.setdefault(int(k), []).append(("js", i))
    for i, k in enumerate(k_fl):
        events.setdefault(int(k), []).append(("fl", i))
    inputs: dict[int, list[int]] = {}
    for i, k in enumerate(k_in):
        inputs.setdefault(int(k), []).append(i)
    t0 = time.perf_counter()
    last = time.monotonic()
    sim.reset()
    while True:
        k = sim.k
        # as in the node: the outputs of step k are published before inputs stamped k are applied
        ev = events.get(k)
        if ev:
            out = sim.outputs()
            for kind, i in ev:
                if kind == "js":
                    jp[i], jv[i], je[i] = joint_state_arrays(out)
                    tip[i] = out.joint_positions[-1]
                else:
                    fl[i] = -out.fairlead_force
        for i in inputs.get(k, ()):
            sim.set_heave_force(float(run.applied.v[i, 0]))
            sim.set_wave_elevation(float(run.applied.v[i, 1]))
        if k >= k_end:
            break
        sim.step()
        if progress is not None and k % 1000 == 0 and time.monotonic() - last > 2.0:
            last = time.monotonic()
            progress(f"resimulate: t = {sim.t:.2f} / {k_end * h:.2f} s")
    return Resim(settings=settings, t=k_js * h, joint_position=jp, joint_velocity=jv,
                 joint_effort=je, heave=jp[:, 0].copy(), tip=tip, fairlead_t=k_fl * h,
                 fairlead=fl, steps=sim.k, wall=time.perf_counter() - t0)


def compare(run: Run, sim: Resim) -> dict[str, float]:
    """Max and RMS differences re-simulation - recording: heave [m], tip position [m] (distance
    between the recorded and re-simulated end of the cable), fairlead tension [N]; plus
    ``identical_joint_states`` (1.0 when positions and velocities are bitwise equal)."""
    dh = sim.heave - run.heave
    dtip = np.linalg.norm(sim.tip - run.tip, axis=1)
    dT = np.hypot(*sim.fairlead.T) - run.fairlead_tension if len(run.fairlead) else np.zeros(0)
    same = (sim.joint_position.shape == run.joint_position.shape
            and np.array_equal(sim.joint_position, run.joint_position)
            and np.array_equal(sim.joint_velocity, run.joint_velocity))
    return {
        "heave_max": float(np.abs(dh).max()), "heave_rms": _rms(dh),
        "tip_max": float(dtip.max()), "tip_rms": _rms(dtip),
        "tension_max": float(np.abs(dT).max()) if len(dT) else float("nan"), "tension_rms": _rms(dT),
        "identical_joint_states": 1.0 if same else 0.0,
    }


# --------------------------------------------------------------------------------------------
# Headless recording (same topics and messages as the node, without a ROS graph)
# --------------------------------------------------------------------------------------------


class _NoRecorder:
    """Stand-in for :class:`~cable_sim.ros.recorder.RunRecorder` when recording is off."""

    stats: dict[str, Any] = {"messages_written": 0, "messages_dropped": 0, "bytes_written": 0,
                             "errors": 0, "last_error": ""}

    def write(self, *args: Any, **kwargs: Any) -> None:
        pass

    def write_serialized(self, *args: Any, **kwargs: Any) -> None:
        pass

    def close(self) -> None:
        pass


def record_headless(
    scene: Scene | str, path: str | Path | None, duration: float, *,
    kernel: str | None = None, integrator: str | None = None, step: float | None = None,
    n_links: int | None = None, overrides: dict[str, Any] | None = None,
    joint_state_rate: float = 50.0, marker_rate: float = 10.0, tension_rate: float = 50.0,
    diagnostics_rate: float = 1.0, inputs: Iterable[tuple[float, str, float]] = (),
    frame_id: str = "world", namespace: str = "", flush_period: float = 1.0,
    chunk_size: int = 1 << 20, progress: Progress | None = None,
    publish: Callable[[str, Any], None] | None = None, serialize_once: bool = False,
) -> dict[str, Any]:
    """Simulate ``scene`` for ``duration`` s without ROS and record what the node would publish.

    Topics, message types, stamps and metadata follow the shared interface (joint_states,
    cable_markers, fairlead_tension, anchor_force, line_tension, diagnostics, applied_inputs,
    clock, and received heave_force / wave_elevation). ``inputs`` are (t [s], topic
    ``"heave_force"`` or ``"wave_elevation"``, value) "received" messages: each is recorded on
    its topic at the step it arrives and held from that step on (``applied_inputs`` recorded).
    With ``path=None`` every message is built but nothing is recorded (benchmark baseline).
    ``publish(topic, msg_or_bytes)``, if given, is called for every message (e.g. a real rclpy
    publisher); with ``serialize_once`` the message is serialised once
    (:func:`cable_sim.ros.recorder.serialize`) and the same bytes are published and recorded.

    Returns
    -------
    dict
        Recorder stats plus ``published`` (count per topic), ``steps``, ``wall``.
    """
    from std_msgs.msg import Float64

    from cable_sim.ros.recorder import RunRecorder, run_metadata
    from cable_sim.scene.simulation import Simulation

    if isinstance(scene, str):
        scene = load_scene(scene, overrides)
    sim = Simulation(scene, kernel=kernel, integrator=integrator, step=step, n_links=n_links)
    h = sim.h
    integ = sim.choice.integrator if sim.choice is not None else (integrator or scene.sim["integrator"])
    meta = run_metadata(dict(scene.source), kernel=sim.kernel, integrator=integ, step=h,
                        n_links=sim.model.n, clock_mode="headless")
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""

    def topic(name: str) -> str:
        return f"{ns}/{name}"

    def every(rate: float) -> int:
        return max(1, int(round(1.0 / (rate * h))))

    p_js, p_mk, p_tn, p_dg = every(joint_state_rate), every(marker_rate), every(tension_rate), every(
        diagnostics_rate)
    k_end = int(round(duration / h))
    sched: dict[int, list[tuple[str, float]]] = {}
    for t_in, name, value in inputs:
        if name not in ("heave_force", "wave_elevation"):
            raise ValueError(f"input topic {name!r}: allowed 'heave_force', 'wave_elevation'")
        sched.setdefault(int(round(t_in / h)), []).append((name, float(value)))
    published: dict[str, int] = {}
    rec: Any = (RunRecorder(path, meta, flush_period=flush_period, chunk_size=chunk_size)
                if path is not None else _NoRecorder())
    t0 = time.perf_counter()
    last = time.monotonic()

    from cable_sim.ros.recorder import serialize

    def pub(name: str, msg: Any, stamp: int) -> None:
        key = topic(name) if name != "clock" else "/clock"
        if serialize_once:
            data = serialize(msg)
            if publish is not None:
                publish(key, data)
            rec.write(key, msg, stamp, stamp, serialized=data)
        else:
            if publish is not None:
                publish(key, msg)
            rec.write(key, msg, stamp, stamp)
        published[key] = published.get(key, 0) + 1

    try:
        sim.reset()
        while True:
            k = sim.k
            stamp = int(round(k * h * 1e9))
            want = [k % p_js == 0, k % p_mk == 0, k % p_tn == 0, k % p_dg == 0]
            if any(want):
                out = sim.outputs()
                if want[0]:
                    pub("clock", clock_message(stamp), stamp)
                    pub("joint_states", build_joint_state(out, stamp, frame_id), stamp)
                if want[1]:
                    pub("cable_markers", build_markers(out, sim.model, stamp, frame_id), stamp)
                if want[2]:
                    pub("fairlead_tension", build_wrench(-out.fairlead_force, stamp, frame_id), stamp)
                    if sim.model.end != 0:
                        pub("anchor_force", build_wrench(-out.anchor_force, stamp, frame_id), stamp)
                    pub("line_tension", build_float_array(out.axial_tension), stamp)
                if want[3]:
                    wall = time.perf_counter() - t0
                    st = rec.stats
                    pub("diagnostics", build_diagnostics({
                        "real_time_factor": repr(sim.t / wall) if wall > 0 else "nan",
                        "energy": repr(out.energy), "constraint_drift": repr(out.constraint_drift),
                        "slack": repr(out.slack), "rejected_inputs": "0", "overruns": "0",
                        "recorder_messages_written": str(st["messages_written"]),
                        "recorder_messages_dropped": str(st["messages_dropped"]),
                    }, stamp), stamp)
            # inputs received at step k (after its outputs were published, as in the node)
            changed = False
            for name, value in sched.get(k, ()):
                pub(name, Float64(data=value), stamp)
                if name == "heave_force":
                    sim.set_heave_force(value)
                else:
                    sim.set_wave_elevation(value)
                changed = True
            if changed:
                pub("applied_inputs", build_float_array(
                    [sim.held_heave_force, sim.held_wave_elevation]), stamp)
            if k >= k_end:
                break
            sim.step()
            if progress is not None and time.monotonic() - last > 2.0:
                last = time.monotonic()
                progress(f"record_headless: t = {sim.t:.2f} / {k_end * h:.2f} s")
    finally:
        rec.close()
    return {**rec.stats, "published": published, "steps": sim.k, "wall": time.perf_counter() - t0}



# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------


def _progress(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    """``cable_sim_replay``: summary, plots, CSV, re-simulation, recovery of a recorded run."""
    ap = argparse.ArgumentParser(
        prog="cable_sim_replay",
        description="Inspect, plot, export and re-simulate a cable_sim recording (MCAP).")
    ap.add_argument("bag", nargs="?", help="recorded .mcap file")
    ap.add_argument("--recover", nargs=2, metavar=("BAD", "FIXED"),
                    help="rewrite a truncated recording (after SIGKILL) as a complete file")
    ap.add_argument("--record-headless", metavar="SCENE",
                    help="first simulate SCENE without ROS and record it to BAG")
    ap.add_argument("--duration", type=float, help="with --record-headless: seconds (default: scene)")
    ap.add_argument("--frames", metavar="PNG", help="configuration frames figure (x-z)")
    ap.add_argument("--frame-interval", type=float, help="seconds between frames (default: scene)")
    ap.add_argument("--tension", metavar="PNG", help="fairlead tension and heave time series")
    ap.add_argument("--gif", metavar="GIF", help="animated GIF")
    ap.add_argument("--gif-interval", type=float,
                    help="seconds of the run between GIF frames (default: real time at --gif-fps, "
                         "subsampled to fit --gif-seconds)")
    ap.add_argument("--gif-seconds", type=float, default=10.0,
                    help="longest GIF [s]: at most gif-seconds * gif-fps frames (default 10)")
    ap.add_argument("--gif-fps", type=float, default=10.0, help="GIF frames per second (default 10)")
    ap.add_argument("--csv", metavar="CSV", help="export time series as CSV")
    ap.add_argument("--resim", action="store_true", help="re-simulate from the recorded inputs")
    ap.add_argument("--links", type=int, help="re-simulate with N links")
    ap.add_argument("--integrator", help="re-simulate with this integrator")
    ap.add_argument("--step", type=float, help="re-simulate with this step h [s]")
    ap.add_argument("--kernel", help="re-simulate with this kernel (dense/fast)")
    ap.add_argument("--quiet", action="store_true", help="no summary")
    a = ap.parse_args(argv)

    if a.recover:
        from cable_sim.ros.recorder import recover

        info = recover(a.recover[0], a.recover[1], progress=_progress)
        state = f"input was truncated: {info['error']}" if info["truncated"] else "input was complete"
        print(f"recovered {info['messages']} messages on {info['channels']} channels, "
              f"{info['metadata']} metadata records -> {a.recover[1]} ({state})")
        if not a.bag:
            return 0
    if not a.bag:
        ap.error("a recorded .mcap file is required")
    if a.record_headless:
        scene = load_scene(a.record_headless)
        dur = a.duration if a.duration is not None else float(scene.sim["duration"])
        if not dur > 0:
            ap.error("--duration must be > 0 (the scene has no duration)")
        st = record_headless(scene, a.bag, dur, progress=_progress)
        print(f"recorded {st['messages_written']} messages ({st['bytes_written']} bytes) to {a.bag}",
              file=sys.stderr)
    for name in ("gif_seconds", "gif_fps", "gif_interval"):
        v = getattr(a, name)
        if v is not None and not (np.isfinite(v) and v > 0):
            ap.error(f"--{name.replace('_', '-')} {v!r}: must be > 0")
    # decode only what the requested outputs use (joint states are always read)
    topics = {"joint_states"}
    if not a.quiet:
        topics |= {"fairlead_tension", "diagnostics"}
    if a.tension:
        topics |= {"fairlead_tension", "anchor_force"}
    if a.csv or a.resim or any(v is not None for v in (a.links, a.integrator, a.step, a.kernel)):
        topics = set(LOADABLE)
    run = load_run(a.bag, progress=_progress, topics=topics)
    if not a.quiet:
        print(summary(run))
    if a.frames:
        print(f"wrote {plot_frames(run, a.frames, a.frame_interval)}")
    if a.tension:
        print(f"wrote {plot_tension(run, a.tension)}")
    if a.gif:
        gif = animate(run, a.gif, interval=a.gif_interval, fps=a.gif_fps, seconds=a.gif_seconds,
                      progress=_progress)
        print(f"wrote {gif}")
    if a.csv:
        print(f"wrote {export_csv(run, a.csv)}")
    if a.resim or any(v is not None for v in (a.links, a.integrator, a.step, a.kernel)):
        rs = resimulate(run, links=a.links, integrator=a.integrator, step=a.step, kernel=a.kernel,
                        progress=_progress)
        d = compare(run, rs)
        s = rs.settings
        print(f"re-simulation (n = {s['n_links']}, {s['integrator']}, h = {s['step']:g} s, kernel "
              f"{s['kernel']}; {rs.steps} steps in {rs.wall:.2f} s) minus recording:")
        print(f"  heave            max {d['heave_max']:.3e} m   RMS {d['heave_rms']:.3e} m")
        print(f"  tip position     max {d['tip_max']:.3e} m   RMS {d['tip_rms']:.3e} m")
        print(f"  fairlead tension max {d['tension_max']:.3e} N   RMS {d['tension_rms']:.3e} N")
        print("  joint states bitwise identical: " + ("yes" if d["identical_joint_states"] else "no"))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
