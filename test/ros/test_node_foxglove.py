"""The node's live Foxglove view (parameter foxglove_port): a WebSocket client of the Foxglove
protocol receives the server info, the advertised channels and scene updates at foxglove_rate from
the real node, and the node stays real time on the default scene with the server on and the
client connected (real_time_factor and overruns from /diagnostics over 20 s)."""

from __future__ import annotations

import signal
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from ros_util import diag_values, init_context, isolate_ros, spin_until, start_node, stop

pytest.importorskip("foxglove")
pytest.importorskip("websockets")
from test_foxglove_view import Client, free_port, protobuf_class  # noqa: E402

# wall-clock rates and real-time factors: run apart from the parallel part of `make test`
pytestmark = pytest.mark.realtime

DOMAIN = isolate_ros()
SCENE_TOPIC, TENSION_TOPIC, DIAG_TOPIC = "/cable_sim/scene", "/cable_sim/tension", "/cable_sim/diagnostics"


def _connect(port: int, proc, timeout: float = 60.0) -> Client:
    """Connect once the node's server listens (the node compiles its kernels first)."""
    end = time.monotonic() + timeout
    while True:
        try:
            return Client(port)
        except OSError:
            if proc.poll() is not None or time.monotonic() > end:
                raise
            time.sleep(0.2)


def test_node_serves_live_view_and_stays_real_time(tmp_path):
    port = free_port()
    proc = start_node("mooring_line", f"foxglove_port:={port}", "foxglove_rate:=10.0",
                      "clock_mode:=realtime", "record:=false", domain=DOMAIN, cwd=tmp_path)
    ctx = init_context(DOMAIN)
    node = rclpy.create_node("foxglove_observer", context=ctx)
    diags: list[DiagnosticArray] = []
    node.create_subscription(DiagnosticArray, "diagnostics", diags.append, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    client = None
    try:
        client = _connect(port, proc)
        client.handshake([SCENE_TOPIC, TENSION_TOPIC, DIAG_TOPIC], timeout=10.0)
        subs = client.subscribe([SCENE_TOPIC, TENSION_TOPIC, DIAG_TOPIC])
        client.start_reading()
        assert spin_until(ex, lambda: len(diags) >= 1, 30)
        t0 = time.monotonic()
        first = len(diags)
        spin_until(ex, lambda: time.monotonic() - t0 > 20.0, 30)
        t1 = time.monotonic()
    finally:
        if client is not None:
            client.close()
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        code, out = stop(proc, signal.SIGINT)
    assert code == 0, out
    assert client.server_info is not None
    assert {SCENE_TOPIC, TENSION_TOPIC, DIAG_TOPIC} <= set(client.channels)

    scene = [(f[0], f[3]) for f in client.frames if subs[f[1]] == SCENE_TOPIC and t0 <= f[0] <= t1]
    rate = len(scene) / (t1 - t0)
    SceneUpdate = protobuf_class(client.channels[SCENE_TOPIC])
    upd = SceneUpdate.FromString(scene[-1][1])
    cable = next(e for e in upd.entities if e.id == "cable")
    n_points = len(cable.lines[0].points)
    fox_diags = [f for f in client.frames if subs[f[1]] == DIAG_TOPIC]

    v0, v1 = diag_values(diags[first - 1]), diag_values(diags[-1])
    rtf, rtf_mean = float(v1["real_time_factor"]), float(v1["real_time_factor_mean"])
    overruns = int(v1["overruns"]) - int(v0["overruns"])
    print(f"foxglove view on, client connected, {t1 - t0:.1f} s: scene {rate:.2f} Hz, "
          f"{n_points} points; real_time_factor {rtf:.4f} (mean {rtf_mean:.4f}), overruns in window "
          f"{overruns} (total {v1['overruns']}), tick p99 {v1['tick_interval_p99_ms']} ms, "
          f"max {v1['tick_interval_max_ms']} ms")
    assert abs(rate - 10.0) <= 3.0, rate
    assert n_points == 41  # mooring_line: 40 links
    assert fox_diags, "no diagnostics on the Foxglove channel"
    assert np.isfinite(rtf) and abs(rtf - 1.0) <= 0.02, rtf
