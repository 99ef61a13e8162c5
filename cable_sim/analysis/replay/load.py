"""Load a recorded run: the MCAP file's topics decoded into arrays (:class:`Run`).

:func:`load_run` reads only the requested topics (decoded by :mod:`.cdr`), rebuilds the scene
from the ``"scene"`` metadata record (:func:`scene_of`) and the cable's polyline from the joint
states. :class:`Tenths` is the 10 %-progress line the replay tools share.

Part of the analysis layer: may import every layer (here core and scene) and ``mcap``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cable_sim.core import dynamics
from cable_sim.scene.scenes import Scene, scene_from_dict

from .cdr import fast_decoders

#: Topic base names the node publishes / subscribes (relative; recorded with namespace).
TOPICS = ("joint_states", "cable_markers", "fairlead_tension", "anchor_force", "line_tension",
          "diagnostics", "applied_inputs", "heave_force", "wave_elevation", "clock", "seabed_contact")

#: Topics :func:`load_run` can decode (base names).
LOADABLE = frozenset({"joint_states", "fairlead_tension", "anchor_force", "line_tension", "diagnostics",
                      "applied_inputs", "heave_force", "wave_elevation", "seabed_contact"})

#: Width of a ``seabed_contact`` value: touchdown arc length [m], touchdown x [m], laid length [m],
#: seabed reaction [N] (msg_configs/interface.yaml).
SEABED_WIDTH = 4

#: Fewer messages to read than this: no progress lines.
PROGRESS_MIN_MESSAGES = 10_000

Progress = Callable[[str], None]


def base(topic: str) -> str:
    """A topic's base name (``/ns/joint_states`` -> ``joint_states``)."""
    return topic.rstrip("/").rsplit("/", 1)[-1]


class Tenths:
    """Calls ``progress(f"{what(i)} (p%, s s)")`` each time ``i`` of ``total`` passes another 10 %.

    ``progress=None`` reports nothing; call the object once per item done.
    """

    def __init__(self, progress: Progress | None, total: int, what: Callable[[int], str]) -> None:
        self.progress, self.total, self.what = progress, total, what
        self.done, self.next_tenth = 0, 1
        self.t0 = time.monotonic()

    def __call__(self) -> None:
        self.done += 1
        if self.progress is not None and self.done * 10 >= self.next_tenth * self.total:
            self.progress(f"{self.what(self.done)} ({10 * self.next_tenth}%, "
                          f"{time.monotonic() - self.t0:.1f} s)")
            self.next_tenth = self.done * 10 // self.total + 1


@dataclass
class Series:
    """A time series: ``t`` [s] (n,) and ``v`` (n, ...)."""

    t: np.ndarray
    v: np.ndarray

    def __len__(self) -> int:
        return len(self.t)


def _series(ts: list[int], vs: list[Any], width: int | None) -> Series:
    """Log times [ns] and values as a :class:`Series` (empty, of the given width, when none)."""
    if not ts:
        return Series(np.zeros(0), np.zeros((0,) if width is None else (0, width)))
    return Series(np.asarray(ts, dtype=np.int64) / 1e9, np.asarray(vs, dtype=float))


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
    seabed : Series
        ``seabed_contact`` values (S, 4): touchdown arc length from the anchor [m], touchdown x
        [m], laid length [m], seabed reaction [N] (empty without a seabed or when not read).
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
    seabed: Series = field(default_factory=lambda: _series([], [], SEABED_WIDTH))

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


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _number(s: str) -> float | None:
    try:
        v = float(s)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def _rect(rows: list[Any], width: int) -> np.ndarray:
    if rows and all(len(r) == width for r in rows):
        return np.asarray(rows, dtype=float)
    return np.full((len(rows), width), np.nan)


class _Collector:
    """The decoded messages of a run, topic by topic, until they become a :class:`Run`."""

    def __init__(self) -> None:
        self.js: tuple[list[int], list[Any], list[Any], list[Any]] = ([], [], [], [])
        #: (times [ns], values): header stamps for the wrenches, log times for the rest
        self.series: dict[str, tuple[list[int], list[Any]]] = {
            k: ([], []) for k in ("fairlead_tension", "anchor_force", "line_tension", "applied_inputs",
                                  "seabed_contact")}
        self.received: dict[str, tuple[list[int], list[float]]] = {"heave_force": ([], []),
                                                                   "wave_elevation": ([], [])}
        self.diag: dict[str, tuple[list[int], list[float]]] = {}
        self.diag_text: dict[str, str] = {}

    def add(self, topic_base: str, msg: Any, log_time: int) -> None:
        """Keep one decoded message of the topic with base name ``topic_base``."""
        if topic_base == "joint_states":
            for lst, v in zip(self.js, (_stamp_ns(msg.header.stamp), msg.position, msg.velocity,
                                        msg.effort), strict=True):
                lst.append(v)
        elif topic_base in ("fairlead_tension", "anchor_force"):
            ts, vs = self.series[topic_base]
            ts.append(_stamp_ns(msg.header.stamp))
            vs.append((msg.wrench.force.x, msg.wrench.force.z))
        elif topic_base in ("line_tension", "applied_inputs", "seabed_contact"):
            ts, vs = self.series[topic_base]
            ts.append(log_time)
            vs.append(list(msg.data)[:2] if topic_base == "applied_inputs" else msg.data)
        elif topic_base in self.received:
            self.received[topic_base][0].append(log_time)
            self.received[topic_base][1].append(float(msg.data))
        elif topic_base == "diagnostics":
            for st in msg.status:
                for kv in st.values:
                    key = f"{st.name}/{kv.key}"
                    self.diag_text[key] = kv.value
                    v = _number(kv.value)
                    if v is not None:
                        s = self.diag.setdefault(key, ([], []))
                        s[0].append(log_time)
                        s[1].append(v)

    def run(self, path: Path, scene: Scene, metadata: dict[str, dict[str, str]],
            counts: dict[str, int]) -> Run:
        """The collected messages as a :class:`Run` (joint positions turned into polylines)."""
        js_t, js_p, js_v, js_e = self.js
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
        s = self.series
        return Run(
            path=path, scene=scene, run_info=metadata.get("run", {}), metadata=metadata,
            t_ns=t_ns, t=t_ns / 1e9, heave=pos[:, 0].copy(), joint_position=pos,
            joint_velocity=_rect(js_v, n + 1), joint_effort=_rect(js_e, n + 1),
            angles=angles, polyline=poly,
            fairlead=_series(*s["fairlead_tension"], 2), anchor=_series(*s["anchor_force"], 2),
            line_tension=_series(*s["line_tension"], n),
            applied=_series(*s["applied_inputs"], 2),
            applied_t_ns=np.asarray(s["applied_inputs"][0], dtype=np.int64),
            received={k: _series(*v, None) for k, v in self.received.items()},
            diagnostics={k: _series(*v, None) for k, v in self.diag.items()},
            diagnostics_text=self.diag_text, counts=counts,
            seabed=_series(*s["seabed_contact"], SEABED_WIDTH),
        )


def _channels_to_read(summary: Any, selected: Callable[[str], bool]
                      ) -> tuple[list[str] | None, int, dict[str, int]]:
    """(topics to read, messages on them, messages per topic) from the file's summary, or
    ``(None, 0, {})`` when it has no message counts (every topic is then read and counted)."""
    stats = summary.statistics if summary is not None else None
    if stats is None or not stats.channel_message_counts:
        return None, 0, {}
    counts: dict[str, int] = {}
    for cid, n_msg in stats.channel_message_counts.items():
        topic = summary.channels[cid].topic
        counts[topic] = counts.get(topic, 0) + n_msg
    read = sorted(t for t in counts if selected(t))
    return read, sum(counts[t] for t in read), counts


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

    def selected(topic: str) -> bool:
        if namespace is not None and topic.rstrip("/").rsplit("/", 1)[0] != namespace.rstrip("/"):
            return False
        return base(topic) in wanted

    decode = fast_decoders()
    kept = _Collector()
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        scene = scene_of(metadata)
        read, total, counts = _channels_to_read(summary, selected)
        count_here = read is None
        tick = Tenths(progress if total >= PROGRESS_MIN_MESSAGES else None, total,
                      lambda i: f"{path.name}: read {i}/{total} messages")
        for schema, channel, message in reader.iter_messages(topics=read, log_time_order=True):
            topic = channel.topic
            if count_here:
                counts[topic] = counts.get(topic, 0) + 1
            if not selected(topic):
                continue
            tick()
            kept.add(base(topic), decode(schema, message.data), int(message.log_time))
    return kept.run(path, scene, metadata, counts)
