"""Live Foxglove view: the cable as a 3D scene, its tensions and the run's diagnostics over WebSocket.

:class:`FoxgloveView` serves the Foxglove WebSocket protocol (``foxglove.websocket.v1``) with the
optional ``foxglove-sdk`` package (imported lazily: nothing here is needed unless a view is
started). It never slows the real-time step down: :meth:`FoxgloveView.publish` only checks the
rate, copies a few small arrays and puts them on a bounded queue (dropping and counting when the
queue is full); a daemon thread builds the messages and hands them to the SDK, which buffers them
per client and drops the oldest for a slow client.

Channels (``prefix`` + name; the layout ``config/foxglove_layout.json`` opens them):

- ``/cable_sim/scene`` (``foxglove.SceneUpdate``, protobuf): the cable as a line strip coloured by
  tension (blue low, red high, per vertex), the platform as a cube, the load as a sphere (free end)
  or the anchor as a cube (anchored ends), the water surface as a thin translucent plate at the
  wave elevation and the seabed (when the model has one) as a brown plate with the touchdown point
  as a yellow sphere on it (deleted while nothing lies on the bed), all in ``frame_id``;
- ``/cable_sim/tension`` (JSON): fairlead and anchor tension [N] and the per-link tension array;
- ``/cable_sim/diagnostics`` (JSON): real-time factor, overruns, status and the view's own counts.

May import foxglove (lazily), numpy and the layers below (scene, core); no rclpy.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

#: Channel names below the prefix.
SCENE, TENSION, DIAGNOSTICS = "scene", "tension", "diagnostics"
DEFAULT_PREFIX = "/cable_sim/"

TENSION_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "cable_sim.Tension",
    "properties": {
        "t": {"type": "number", "description": "simulation time [s]"},
        "fairlead_tension": {"type": "number", "description": "|fairlead force| [N]"},
        "anchor_tension": {"type": "number", "description": "|anchor force| [N] (0 for a free end)"},
        "line_tension": {"type": "array", "items": {"type": "number"},
                         "description": "axial tension at the top of each link [N]"},
    },
}

DIAGNOSTICS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "cable_sim.Diagnostics",
    "properties": {
        "t": {"type": "number", "description": "simulation time [s]"},
        "real_time_factor": {"type": "number"},
        "real_time_factor_mean": {"type": "number"},
        "overruns": {"type": "number"},
        "status": {"type": "string"},
        "level": {"type": "number", "description": "0 OK, 1 WARN, 2 ERROR"},
        "view_sent": {"type": "number", "description": "scene updates handed to the server"},
        "view_dropped": {"type": "number", "description": "updates dropped: queue full"},
    },
    "additionalProperties": True,
}


def touchdown_x(pos: np.ndarray, seabed_z: float) -> float | None:
    """x [m] of the touchdown point of a polyline (n+1, 2) of (x, z) from the fairlead: where the
    first link that reaches below ``seabed_z`` crosses it (as ``cable_sim.core.seabed``'s
    ``touchdown_x``); None when no joint is below the bed."""
    below = np.nonzero(pos[:, 1] < seabed_z)[0]
    if not len(below):
        return None
    j = int(below[0])
    if j == 0:  # the fairlead itself below the bed (refused by the scene checks)
        return float(pos[0, 0])
    d_a, d_b = seabed_z - pos[j - 1, 1], seabed_z - pos[j, 1]
    frac = d_a / (d_a - d_b)
    return float(pos[j - 1, 0] + frac * (pos[j, 0] - pos[j - 1, 0]))


class FoxgloveUnavailable(ImportError):
    """The optional ``foxglove-sdk`` package is not installed."""


def import_foxglove(port: int | None = None) -> Any:
    """Import the ``foxglove`` module of ``foxglove-sdk``.

    Parameters
    ----------
    port : int, optional
        The ``foxglove_port`` value that asked for it (named in the error).

    Raises
    ------
    FoxgloveUnavailable
        When foxglove-sdk is missing, naming the parameter and the install command.
    """
    try:
        import foxglove
        import foxglove.channels  # noqa: F401
        import foxglove.messages  # noqa: F401
    except ImportError as exc:
        asked = f"foxglove_port={port}" if port is not None else "foxglove_port > 0"
        raise FoxgloveUnavailable(
            f"{asked} needs the optional package foxglove-sdk, which is not installed "
            f"({exc}): `pip install foxglove-sdk` (or `pip install cable_sim[foxglove]`), "
            "or set foxglove_port:=0 (allowed 0..65535; 0 = no live view)") from exc
    return foxglove


def tension_colours(tension: np.ndarray) -> np.ndarray:
    """Per-vertex (r, g, b, a) of the cable: vertex 0 takes link 1's tension, vertex i link i's.

    Blue at zero, red at the largest |tension| of the line (as the MarkerArray does).
    """
    ten = np.abs(np.asarray(tension, dtype=float))
    tmax = float(ten.max()) if len(ten) and ten.max() > 0 else 1.0
    a = np.concatenate([ten[:1], ten]) / tmax
    rgba = np.empty((len(a), 4))
    rgba[:, 0], rgba[:, 1], rgba[:, 2], rgba[:, 3] = a, 0.2, 1.0 - a, 1.0
    return rgba


class FoxgloveView:
    """A Foxglove WebSocket server showing a running simulation.

    Parameters
    ----------
    model : cable_sim.core.model.CableModel
        The simulated model (end type, anchor, seabed, link diameters).
    port : int
        TCP port, 0..65535 (0: the system picks a free one, see :attr:`port`).
    host : str
        Address to bind (default localhost only; ``0.0.0.0`` for other machines).
    rate : float
        Largest rate of scene and tension updates [Hz] of wall time, > 0.
    frame_id : str
        Frame of the scene entities (x-z plane, z up).
    prefix : str
        Topic prefix of the channels.
    queue_size : int
        Updates waiting for the sender thread; more are dropped and counted.
    name : str
        Server name shown by the client.

    Raises
    ------
    FoxgloveUnavailable
        Without foxglove-sdk.
    ValueError
        On a port outside 0..65535, a rate <= 0 or a queue size < 1.
    """

    def __init__(self, model: Any, port: int, host: str = "127.0.0.1", rate: float = 10.0,
                 frame_id: str = "world", prefix: str = DEFAULT_PREFIX, queue_size: int = 8,
                 name: str = "cable_sim") -> None:
        if not (isinstance(port, int) and 0 <= port <= 65535):
            raise ValueError(f"foxglove_port={port!r}: allowed 0..65535")
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
            raise ValueError(f"foxglove_rate={rate!r}: allowed > 0 Hz")
        if not (isinstance(queue_size, int) and queue_size >= 1):
            raise ValueError(f"queue_size={queue_size!r}: allowed >= 1")
        fg = import_foxglove(port)
        self._fg = fg
        self.model = model
        self.frame_id = frame_id
        self.period = 1.0 / float(rate)
        self.topics = {k: prefix + k for k in (SCENE, TENSION, DIAGNOSTICS)}
        self.sent = 0
        self.dropped = 0
        self.errors = 0
        self.last_error = ""
        self._next_due = -math.inf
        self._queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self._ctx = fg.Context()
        self._channels = {
            SCENE: fg.channels.SceneUpdateChannel(self.topics[SCENE], context=self._ctx),
            TENSION: fg.Channel(self.topics[TENSION], schema=TENSION_SCHEMA, context=self._ctx),
            DIAGNOSTICS: fg.Channel(self.topics[DIAGNOSTICS], schema=DIAGNOSTICS_SCHEMA,
                                    context=self._ctx),
        }
        self._server = fg.start_server(name=name, host=host, port=port, context=self._ctx)
        self.port: int = int(self._server.port)
        self._thread = threading.Thread(target=self._serve, name="foxglove_view", daemon=True)
        self._thread.start()

    # --- producer side (the real-time thread) ---------------------------------------------------
    def publish(self, outputs: Any, t: float | None = None) -> bool:
        """Hand the scene and tensions of ``outputs`` over, at most at the configured rate.

        Never waits: returns False when the update was not due or dropped (queue full).

        Parameters
        ----------
        outputs : cable_sim.scene.simulation.Outputs
            The current outputs.
        t : float, optional
            Simulation time [s] of the stamp (default ``outputs.t``).
        """
        now = time.monotonic()
        if now < self._next_due:
            return False
        # on schedule: the next slot; fallen behind by more than a period: restart from now
        behind = now - self._next_due >= self.period
        self._next_due = now + self.period if behind else self._next_due + self.period
        item = ("state", float(outputs.t if t is None else t),
                np.array(outputs.joint_positions, dtype=float),
                np.array(outputs.axial_tension, dtype=float),
                float(np.hypot(*outputs.fairlead_force)), float(np.hypot(*outputs.anchor_force)),
                float(outputs.inputs.wave_elevation))
        return self._offer(item)

    def publish_diagnostics(self, values: Mapping[str, Any], t: float, level: int = 0,
                            status: str = "") -> bool:
        """Hand the diagnostics over (numbers given as strings are sent as numbers); never waits."""
        return self._offer(("diagnostics", float(t), dict(values), int(level), str(status)))

    def _offer(self, item: tuple) -> bool:
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            return False
        return True

    # --- consumer side (daemon thread) ----------------------------------------------------------
    def _serve(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            try:
                if item[0] == "state":
                    self._send_state(*item[1:])
                else:
                    self._send_diagnostics(*item[1:])
            except Exception as exc:  # noqa: BLE001 - a viewer problem must not stop the simulation
                self.errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
            # hand the GIL back between updates: a waiting real-time thread waits at most for one
            # update's Python work, not for the interpreter's 5 ms switch interval
            time.sleep(0)

    def _stamp(self, t: float):
        sec = math.floor(t)
        return self._fg.messages.Timestamp(int(sec), int(round((t - sec) * 1e9)) % 1_000_000_000)

    def scene_update(self, t: float, pos: np.ndarray, tension: np.ndarray, wave: float) -> Any:
        """The ``foxglove.SceneUpdate`` of one state (positions (n+1, 2) as (x, z) [m])."""
        m = self._fg.messages
        stamp, frame = self._stamp(t), self.frame_id

        def entity(eid: str, **prims):
            return m.SceneEntity(timestamp=stamp, frame_id=frame, id=eid, frame_locked=True, **prims)

        def pose(x: float, z: float):
            return m.Pose(position=m.Vector3(x=float(x), y=0.0, z=float(z)),
                          orientation=m.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0))

        pts = [m.Point3(x=x, y=0.0, z=z) for x, z in pos.tolist()]
        cols = [m.Color(r=r, g=g, b=b, a=a) for r, g, b, a in tension_colours(tension).tolist()]
        line = m.LinePrimitive(type=m.LinePrimitiveLineType.LineStrip, thickness=3.0,
                               scale_invariant=True, points=pts, colors=cols)
        ents = [entity("cable", lines=[line]),
                entity("platform", cubes=[m.CubePrimitive(
                    pose=pose(*pos[0]), size=m.Vector3(x=8.0, y=8.0, z=3.0),
                    color=m.Color(r=0.9, g=0.5, b=0.1, a=1.0))])]
        grey = m.Color(r=0.3, g=0.3, b=0.3, a=1.0)
        if int(self.model.end) == 0:
            ents.append(entity("load", spheres=[m.SpherePrimitive(
                pose=pose(*pos[-1]), size=m.Vector3(x=2.0, y=2.0, z=2.0), color=grey)]))
        else:
            ents.append(entity("anchor", cubes=[m.CubePrimitive(
                pose=pose(*self.model.anchor), size=m.Vector3(x=2.0, y=2.0, z=2.0), color=grey)]))
        x0 = float(min(pos[:, 0].min(), 0.0)) - 20.0
        x1 = float(pos[:, 0].max()) + 20.0
        width = x1 - x0
        ents.append(entity("water", cubes=[m.CubePrimitive(
            pose=pose(0.5 * (x0 + x1), wave), size=m.Vector3(x=width, y=width, z=0.05),
            color=m.Color(r=0.1, g=0.4, b=1.0, a=0.25))]))
        deletions: list[Any] = []
        seabed_z = float(getattr(self.model, "seabed_z", -math.inf))
        if bool(getattr(self.model, "seabed", False)) and math.isfinite(seabed_z):
            ents.append(entity("seabed", cubes=[m.CubePrimitive(
                pose=pose(0.5 * (x0 + x1), seabed_z - 0.5), size=m.Vector3(x=width, y=width, z=1.0),
                color=m.Color(r=0.45, g=0.35, b=0.2, a=0.8))]))
            td = touchdown_x(pos, seabed_z)
            if td is not None:
                ents.append(entity("touchdown", spheres=[m.SpherePrimitive(
                    pose=pose(td, seabed_z), size=m.Vector3(x=3.0, y=3.0, z=3.0),
                    color=m.Color(r=1.0, g=0.85, b=0.0, a=1.0))]))
            else:
                deletions.append(m.SceneEntityDeletion(
                    timestamp=stamp, type=m.SceneEntityDeletionType.MatchingId, id="touchdown"))
        return m.SceneUpdate(deletions=deletions, entities=ents)

    def _send_state(self, t: float, pos: np.ndarray, tension: np.ndarray, fairlead: float,
                    anchor: float, wave: float) -> None:
        log_time = time.time_ns()
        self._channels[SCENE].log(self.scene_update(t, pos, tension, wave), log_time=log_time)
        self._channels[TENSION].log({"t": t, "fairlead_tension": fairlead, "anchor_tension": anchor,
                                     "line_tension": tension.tolist()}, log_time=log_time)
        self.sent += 1

    def _send_diagnostics(self, t: float, values: dict[str, Any], level: int, status: str) -> None:
        msg: dict[str, Any] = {"t": t}
        for k, v in values.items():
            if isinstance(v, bool) or v is None:
                msg[k] = v
                continue
            try:
                f = float(v)
            except (TypeError, ValueError):
                msg[k] = str(v)
                continue
            msg[k] = f if math.isfinite(f) else None  # JSON has no nan/inf
        msg.update(level=level, status=status, view_sent=self.sent, view_dropped=self.dropped)
        self._channels[DIAGNOSTICS].log(msg, log_time=time.time_ns())

    # --- lifetime -------------------------------------------------------------------------------
    @property
    def stats(self) -> dict[str, Any]:
        """Port and the counts of sent, dropped and failed updates."""
        return {"port": self.port, "sent": self.sent, "dropped": self.dropped, "errors": self.errors,
                "last_error": self.last_error}

    def close(self, timeout: float = 2.0) -> None:
        """Stop the sender thread (after the queued updates) and the server; idempotent."""
        if self._thread.is_alive():
            try:
                self._queue.put(None, timeout=timeout)
            except queue.Full:  # thread stuck: it is a daemon, the server stops anyway
                pass
            self._thread.join(timeout)
        if self._server is not None:
            self._server.stop()
            self._server = None
            for ch in self._channels.values():
                ch.close()

    def __enter__(self) -> FoxgloveView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def start_foxglove_view(node: Any) -> FoxgloveView | None:
    """The node's live view when its ``foxglove_port`` parameter is > 0, fed by its outputs.

    The view listens on 127.0.0.1:``foxglove_port``, takes every publication of the node's outputs
    (:attr:`cable_sim.ros.publishers.NodeOutputs.listeners`, rate-limited to ``foxglove_rate``) and
    the diagnostics (:class:`cable_sim.ros.diagnostics.NodeDiagnostics`); the node closes it.

    Parameters
    ----------
    node : cable_sim.ros.node.CableSimNode
        The node (its parameters, ``sim``, ``frame_id`` and ``outputs``).

    Raises
    ------
    ValueError
        Without foxglove-sdk, or when the port cannot be served (message names the parameter).
    """
    port = int(node.get_parameter("foxglove_port").value)
    if port == 0:
        return None
    rate = float(node.get_parameter("foxglove_rate").value)
    try:
        view = FoxgloveView(node.sim.model, port=port, rate=rate, frame_id=node.frame_id,
                            name=node.get_fully_qualified_name())
    except FoxgloveUnavailable as exc:
        raise ValueError(str(exc)) from exc
    except (OSError, RuntimeError) as exc:
        raise ValueError(f"foxglove_port={port}: cannot serve the live view on 127.0.0.1:{port} "
                         f"({exc}); choose a free port in 1..65535 or 0 (off)") from exc
    node.outputs.listeners.append(lambda out, stamp: view.publish(out, stamp * 1e-9))
    node.get_logger().info(f"live Foxglove view on ws://127.0.0.1:{view.port} (topics "
                           f"{', '.join(view.topics.values())}; {rate:g} Hz)")
    return view
