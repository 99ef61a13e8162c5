"""Headless recording: a scene run without ROS, recording what the node would publish.

Same topics, message types, stamps and metadata as the node (for documentation figures, the
recorder benchmark and tests of the recorder). Part of the analysis layer: may import every
layer; here scene (:class:`Simulation`, lazily) and ros (messages, recorder).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from cable_sim.ros.messages import (
    build_diagnostics,
    build_float_array,
    build_joint_state,
    build_markers,
    build_seabed_contact,
    build_wrench,
    clock_message,
    seabed_contact_values,
)
from cable_sim.scene.scenes import Scene, load_scene

from .load import Progress

#: Input topics a headless run can "receive".
INPUT_TOPICS = ("heave_force", "wave_elevation")


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


class _Outlet:
    """Publishes (if asked) and records one message under the namespaced topic, counting them."""

    def __init__(self, rec: Any, namespace: str, publish: Callable[[str, Any], None] | None,
                 serialize_once: bool) -> None:
        self.rec, self.publish, self.serialize_once = rec, publish, serialize_once
        self.ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
        self.published: dict[str, int] = {}

    def __call__(self, name: str, msg: Any, stamp: int) -> None:
        key = f"{self.ns}/{name}" if name != "clock" else "/clock"
        if self.serialize_once:
            from cable_sim.ros.recorder import serialize

            data = serialize(msg)
            if self.publish is not None:
                self.publish(key, data)
            self.rec.write(key, msg, stamp, stamp, serialized=data)
        else:
            if self.publish is not None:
                self.publish(key, msg)
            self.rec.write(key, msg, stamp, stamp)
        self.published[key] = self.published.get(key, 0) + 1


def _input_schedule(inputs: Iterable[tuple[float, str, float]], h: float
                    ) -> dict[int, list[tuple[str, float]]]:
    """``{step: [(topic, value), ...]}`` of the "received" inputs (t [s], topic, value)."""
    sched: dict[int, list[tuple[str, float]]] = {}
    for t_in, name, value in inputs:
        if name not in INPUT_TOPICS:
            raise ValueError(f"input topic {name!r}: allowed 'heave_force', 'wave_elevation'")
        sched.setdefault(int(round(t_in / h)), []).append((name, float(value)))
    return sched


def _publish_outputs(sim: Any, pub: _Outlet, want: list[bool], stamp: int, frame_id: str,
                     t0: float) -> None:
    """The outputs due at this step: [joint states + clock, markers, tensions (+ seabed_contact),
    diagnostics]."""
    if not any(want):
        return
    out = sim.outputs()
    seabed = seabed_contact_values(out, sim.model) if want[1] or want[2] else None
    if want[0]:
        pub("clock", clock_message(stamp), stamp)
        pub("joint_states", build_joint_state(out, stamp, frame_id), stamp)
    if want[1]:
        pub("cable_markers", build_markers(out, sim.model, stamp, frame_id, seabed=seabed), stamp)
    if want[2]:
        pub("fairlead_tension", build_wrench(-out.fairlead_force, stamp, frame_id), stamp)
        if sim.model.end != 0:
            pub("anchor_force", build_wrench(-out.anchor_force, stamp, frame_id), stamp)
        pub("line_tension", build_float_array(out.axial_tension), stamp)
        if seabed is not None:
            pub("seabed_contact", build_seabed_contact(seabed), stamp)
    if want[3]:
        wall = time.perf_counter() - t0
        st = pub.rec.stats
        pub("diagnostics", build_diagnostics({
            "real_time_factor": repr(sim.t / wall) if wall > 0 else "nan",
            "energy": repr(out.energy), "constraint_drift": repr(out.constraint_drift),
            "slack": repr(out.slack), "rejected_inputs": "0", "overruns": "0",
            "recorder_messages_written": str(st["messages_written"]),
            "recorder_messages_dropped": str(st["messages_dropped"]),
        }, stamp), stamp)


def _receive_inputs(sim: Any, pub: _Outlet, received: Sequence[tuple[str, float]], stamp: int) -> None:
    """Record the inputs received at this step, hold them, record ``applied_inputs`` if any."""
    if not received:
        return
    from std_msgs.msg import Float64

    for name, value in received:
        pub(name, Float64(data=value), stamp)
        if name == "heave_force":
            sim.set_heave_force(value)
        else:
            sim.set_wave_elevation(value)
    pub("applied_inputs", build_float_array([sim.held_heave_force, sim.held_wave_elevation]), stamp)


def record_headless(
    scene: Scene | str, path: str | Path | None, duration: float, *,
    kernel: str | None = None, integrator: str | None = None, step: float | None = None,
    n_links: int | None = None, overrides: dict[str, Any] | None = None,
    joint_state_rate: float = 50.0, marker_rate: float = 10.0, tension_rate: float = 50.0,
    diagnostics_rate: float = 1.0, inputs: Iterable[tuple[float, str, float]] = (),
    frame_id: str = "world", namespace: str = "", flush_period: float = 1.0,
    chunk_size: int | None = None, progress: Progress | None = None,
    publish: Callable[[str, Any], None] | None = None, serialize_once: bool = False,
) -> dict[str, Any]:
    """Simulate ``scene`` for ``duration`` s without ROS and record what the node would publish.

    Topics, message types, stamps and metadata follow the shared interface (joint_states,
    cable_markers, fairlead_tension, anchor_force, line_tension, seabed_contact (scenes with a
    seabed), diagnostics, applied_inputs, clock, and received heave_force / wave_elevation).
    ``inputs`` are (t [s], topic ``"heave_force"`` or ``"wave_elevation"``, value) "received"
    messages: each is recorded on its topic at the step it arrives and held from that step on
    (``applied_inputs`` recorded).
    With ``path=None`` every message is built but nothing is recorded (benchmark baseline).
    ``publish(topic, msg_or_bytes)``, if given, is called for every message (e.g. a real rclpy
    publisher); with ``serialize_once`` the message is serialised once
    (:func:`cable_sim.ros.recorder.serialize`) and the same bytes are published and recorded.

    Returns
    -------
    dict
        Recorder stats plus ``published`` (count per topic), ``steps``, ``wall``.
    """
    from cable_sim.ros.recorder import RunRecorder, run_metadata
    from cable_sim.scene.simulation import Simulation

    if isinstance(scene, str):
        scene = load_scene(scene, overrides)
    sim = Simulation(scene, kernel=kernel, integrator=integrator, step=step, n_links=n_links)
    h = sim.h
    integ = sim.choice.integrator if sim.choice is not None else (integrator or scene.sim["integrator"])
    meta = run_metadata(dict(scene.source), kernel=sim.kernel, integrator=integ, step=h,
                        n_links=sim.model.n, clock_mode="headless")
    periods = [max(1, int(round(1.0 / (rate * h))))
               for rate in (joint_state_rate, marker_rate, tension_rate, diagnostics_rate)]
    k_end = int(round(duration / h))
    sched = _input_schedule(inputs, h)
    chunking = {} if chunk_size is None else {"chunk_size": chunk_size}  # None: the recorder's default
    rec: Any = (RunRecorder(path, meta, flush_period=flush_period, **chunking)
                if path is not None else _NoRecorder())
    pub = _Outlet(rec, namespace, publish, serialize_once)
    t0 = time.perf_counter()
    last = time.monotonic()
    try:
        sim.reset()
        while True:
            k = sim.k
            stamp = int(round(k * h * 1e9))
            _publish_outputs(sim, pub, [k % p == 0 for p in periods], stamp, frame_id, t0)
            # inputs received at step k (after its outputs were published, as in the node)
            _receive_inputs(sim, pub, sched.get(k, ()), stamp)
            if k >= k_end:
                break
            sim.step()
            if progress is not None and time.monotonic() - last > 2.0:
                last = time.monotonic()
                progress(f"record_headless: t = {sim.t:.2f} / {k_end * h:.2f} s")
    finally:
        rec.close()
    return {**rec.stats, "published": pub.published, "steps": sim.k, "wall": time.perf_counter() - t0}
