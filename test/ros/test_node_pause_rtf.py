"""The real-time factor in diagnostics ignores paused wall time (issue 9, item 9).

The default scene runs in real time in a subprocess node (default signal handling, killed and
reaped in ``finally``): 4 s running, 6 s paused through the ``pause`` service, then running
again. A node that keeps up must report a real-time factor near 1 (the old figure, simulated
time over all wall time since the start, would read about 0.4 here), and ``paused_time`` must
match the pause as timed by this test.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from ros_util import CONFIG, diag_values, init_context, isolate_ros, node_executable, spin_until
from std_srvs.srv import SetBool

DOMAIN = isolate_ros()
PAUSE_S = 6.0


def _default_signals() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def test_real_time_factor_after_a_pause_is_near_one(tmp_path):
    cmd = [node_executable(), "--ros-args", "--params-file", str(CONFIG / "mooring_line.yaml"),
           "-p", "clock_mode:=realtime", "-p", "record:=false", "-p", "diagnostics_rate:=2.0"]
    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, preexec_fn=_default_signals)
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
            try:
                out, _ = proc.communicate(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()
    v = diags[-1][1]
    print(f"pause {t_resume - t_pause:.2f} s; last diagnostics: {v}; node output tail: {out[-500:]}")
    assert v["paused"] == "False" and not v["failure"], v
    assert 0.9 <= float(v["real_time_factor"]) <= 1.1, v
    assert 0.9 <= float(v["real_time_factor_mean"]) <= 1.1, v
    assert abs(float(v["paused_time"]) - (t_resume - t_pause)) < 0.5, v
    # simulated time stood still during the pause: it is about the wall time spent running
    assert float(v["sim_time"]) < float(v["wall_time"]) - 0.8 * PAUSE_S, v
