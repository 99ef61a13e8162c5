"""The real-time factor in diagnostics ignores paused wall time (issue 9, item 9).

The default scene runs in real time in a subprocess node (``ros_util.start_node``: default signal
handling; killed and reaped in ``finally``): 4 s running, 6 s paused through the ``pause`` service,
then running again. A node that keeps up must report a real-time factor near 1 (the old figure,
simulated time over all wall time since the start, would read about 0.4 here), and ``paused_time``
must match the pause as timed by this test.
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from ros_util import diag_values, init_context, isolate_ros, kill_and_reap, spin_until, start_node
from std_srvs.srv import SetBool

# wall-clock rates and real-time factors: run apart from the parallel part of `make test`
pytestmark = pytest.mark.realtime

DOMAIN = isolate_ros()
PAUSE_S = 6.0


def test_real_time_factor_after_a_pause_is_near_one(tmp_path):
    proc = start_node("mooring_line", "clock_mode:=realtime", "record:=false", "diagnostics_rate:=2.0",
                      domain=DOMAIN, cwd=tmp_path)
    ctx = init_context(DOMAIN)
    node = rclpy.create_node("rtf_observer", context=ctx)
    diags: list[tuple[float, dict[str, str]]] = []
    node.create_subscription(DiagnosticArray, "diagnostics",
                             lambda m: diags.append((time.monotonic(), diag_values(m))), 10)
    client = node.create_client(SetBool, "pause")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)

    def call(data: bool) -> bool:
        fut = client.call_async(SetBool.Request(data=data))
        assert spin_until(ex, fut.done, 10), "pause service did not answer"
        return fut.result().success

    def running_for(seconds: float) -> None:
        t0 = time.monotonic()
        spin_until(ex, lambda: time.monotonic() - t0 > seconds, seconds + 5)

    out = ""
    try:
        assert client.wait_for_service(timeout_sec=60) and spin_until(ex, lambda: len(diags) > 0, 60)
        running_for(4.0)
        t_pause = time.monotonic()
        assert call(True)
        running_for(PAUSE_S)
        assert call(False)
        t_resume = time.monotonic()
        running_for(4.0)
        n = len(diags)
        assert spin_until(ex, lambda: len(diags) > n + 1, 10)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                out, _ = proc.communicate(timeout=20)
        kill_and_reap(proc)
    v = diags[-1][1]
    print(f"pause {t_resume - t_pause:.2f} s; last diagnostics: {v}; node output tail: {out[-500:]}")
    assert v["paused"] == "False" and not v["failure"], v
    assert 0.9 <= float(v["real_time_factor"]) <= 1.1, v
    assert 0.9 <= float(v["real_time_factor_mean"]) <= 1.1, v
    assert abs(float(v["paused_time"]) - (t_resume - t_pause)) < 0.5, v
    # simulated time stood still during the pause: it is about the wall time spent running
    assert float(v["sim_time"]) < float(v["wall_time"]) - 0.8 * PAUSE_S, v
