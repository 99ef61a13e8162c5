"""Blow-ups are detected from physics, never accepted, published or recorded (issue 9, item 5),
and the step a user asks for is never changed silently (item 6).

The case: the paper's free fall (240 m, 60 kg load, paper drag) at n = 80 with RK4 at 3 and
4 ms, beyond its stability limit (stable at 2 ms). Physical bounds stated here, independent of
the code under test: the stable run (h = 2 ms, 31 s) has |qd| <= 2.5 rad/s (measured) and a
fairlead tension <= 1.1e4 N, about 6x the line's submerged weight (~1.9e3 N). We allow
``QD_MAX`` = 100 rad/s (a 3 m link turning 16 times a second; 40x the physical peak) and
``TENSION_MAX`` = 3e4 N (3x the stable peak). Before the fix, 1-3 steps with |qd| ~ 1e5 to 1e121
rad/s and tensions up to 4e230 N were accepted before the error.
"""

from __future__ import annotations

import logging
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from cable_sim.integrate import IntegrationError, make_integrator
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

QD_MAX = 100.0  # rad/s (and m/s for the heave rate)
TENSION_MAX = 3.0e4  # N
N_LINKS = 80


def _sim(step: float, kernel: str | None = None, n_links: int = N_LINKS) -> Simulation:
    return Simulation(load_scene("paper_free_fall"), n_links=n_links, integrator="rk4", step=step,
                      kernel=kernel)


@pytest.mark.parametrize("step", [0.003, 0.004])
def test_simulation_never_accepts_a_diverging_state(step: float) -> None:
    sim = _sim(step)
    n1 = sim.model.ndof
    qd_max = ten_max = 0.0
    with pytest.raises(IntegrationError) as info:
        while sim.t < 31.0:
            sim.step()  # raises before accepting a diverging state
            out = sim.outputs()  # every accepted state's outputs: finite, bounded
            assert np.all(np.isfinite(sim.y)) and np.all(np.isfinite(out.axial_tension))
            qd_max = max(qd_max, float(np.max(np.abs(sim.y[n1:]))))
            ten_max = max(ten_max, float(np.max(np.abs(out.axial_tension))), out.fairlead_tension)
    err = info.value
    print(f"\n[blow-up] rk4 h={step}: {err}; accepted max |qd| {qd_max:.3g} rad/s, "
          f"max tension {ten_max:.3g} N")
    assert 15.0 < err.t < 31.0  # the known onset (~24 s), not a spurious early stop
    assert "numerical instability" in err.reason and "reduce the step" in err.reason
    assert "anchor" not in err.reason and "snap" not in err.reason  # a free-end line
    assert qd_max < QD_MAX and ten_max < TENSION_MAX
    # the state is left at the last good step: its outputs are still plausible
    out = sim.outputs()
    assert np.max(np.abs(out.qd)) < QD_MAX and out.fairlead_tension < TENSION_MAX


def test_stable_step_is_not_flagged() -> None:
    """No false positive: the same scene at 2 ms runs its 31 s."""
    sim = _sim(0.002)
    sim.run_until(31.0)
    assert abs(sim.t - 31.0) < 1e-9
    assert np.max(np.abs(sim.y[sim.model.ndof:])) < QD_MAX


def test_outputs_refuse_an_implausible_state() -> None:
    sim = _sim(0.002, n_links=10)
    sim.run_until(0.1)
    sim.outputs()
    sim.y = sim.y.copy()
    sim.y[sim.model.ndof + 3] = 1e6  # rad/s: far beyond the scene's energy
    with pytest.raises(IntegrationError, match="numerical instability"):
        sim.outputs()
    sim.y[sim.model.ndof + 3] = np.nan
    with pytest.raises(IntegrationError, match="not finite"):
        sim.outputs()


def test_singular_step_on_a_free_end_does_not_blame_an_anchor() -> None:
    sim = _sim(0.002, kernel="dense", n_links=10)
    integ = sim.integrator

    def singular(t, y):
        raise np.linalg.LinAlgError("Singular matrix")

    sim.system.rhs = singular
    with pytest.raises(IntegrationError) as info:
        integ.step(0.0, sim.y0)
    assert "anchor" not in info.value.reason and "snap" not in info.value.reason
    assert "numerical instability" in info.value.reason


# --------------------------------------------------------------------------------------------
# item 6: the step actually used is reported and logged
# --------------------------------------------------------------------------------------------


def test_integrate_reports_and_logs_a_changed_step(caplog) -> None:
    sim = _sim(0.003, n_links=10)
    integ = make_integrator("rk4", sim.system, 0.003)
    with caplog.at_level(logging.WARNING, logger="cable_sim.integrate.base"):
        tr = integ.integrate(sim.y0, 0.0, 0.4, 0.04)
    assert tr.step_used == pytest.approx(0.04 / 14, rel=1e-12)  # 2.857 ms, not 3 ms
    assert any("0.003" in r.getMessage() and "0.00285714" in r.getMessage() for r in caplog.records)
    caplog.clear()
    integ = make_integrator("rk4", sim.system, 0.002)
    with caplog.at_level(logging.WARNING, logger="cable_sim.integrate.base"):
        tr = integ.integrate(sim.y0, 0.0, 0.4, 0.04)
    assert tr.step_used == pytest.approx(0.002, rel=1e-12) and not caplog.records
    # the same states as stepping with 2.857 ms by hand (the report is what was done)
    integ2 = make_integrator("rk4", sim.system, 0.04 / 14)
    tr2 = integ2.integrate(sim.y0, 0.0, 0.4, 0.04)
    integ3 = make_integrator("rk4", sim.system, 0.003)
    tr3 = integ3.integrate(sim.y0, 0.0, 0.4, 0.04)
    assert np.array_equal(tr2.y, tr3.y)


# --------------------------------------------------------------------------------------------
# the real node: nothing implausible published or recorded, ERROR diagnostic naming the cause
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("step", ["0.003", "0.004"])
def test_node_stops_on_instability_and_publishes_nothing_implausible(step: str, tmp_path: Path) -> None:
    rclpy = pytest.importorskip("rclpy")
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from ros_util import init_context, isolate_ros, kill_and_reap, spin_until, start_node
    from rosbags.highlevel import AnyReader
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    domain = isolate_ros()
    path = tmp_path / "blowup.mcap"
    ctx = init_context(domain)
    peer = rclpy.create_node("blowup_peer", context=ctx)
    states: list[tuple[float, float]] = []  # (max |velocity|, all finite)
    errors: list[str] = []

    def on_js(m: JointState) -> None:
        v = np.asarray(m.velocity, dtype=float)
        states.append((float(np.max(np.abs(v))) if v.size else 0.0, bool(np.all(np.isfinite(v)))))

    def on_diag(m: DiagnosticArray) -> None:
        for st in m.status:
            if st.level == DiagnosticStatus.ERROR:
                errors.append(st.message)

    qos = QoSProfile(depth=20000, reliability=ReliabilityPolicy.RELIABLE)
    peer.create_subscription(JointState, "joint_states", on_js, qos)
    peer.create_subscription(DiagnosticArray, "diagnostics", on_diag, 100)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(peer)
    proc = start_node("paper_free_fall", "clock_mode:=fast", "integrator:=rk4", f"step:={step}",
                      f"n_links:={N_LINKS}", "joint_state_rate:=1000.0", "diagnostics_rate:=5.0",
                      f"record_path:={path}", domain=domain, cwd=tmp_path)
    try:
        t0 = time.monotonic()
        # in fast mode the node may reach the blow-up (~24 s simulated) before discovery matches
        # this subscriber: once it is matched, reset the node so the whole run is seen live
        reset = peer.create_client(Trigger, "reset")
        assert spin_until(ex, lambda: (peer.count_publishers("/joint_states") > 0
                                       and reset.service_is_ready()) or proc.poll() is not None, 120)
        assert proc.poll() is None, "the node exited before the test could reset it"
        fut = reset.call_async(Trigger.Request())
        assert spin_until(ex, fut.done, 30) and fut.result().success
        states.clear()
        errors.clear()
        # (an ERROR of the run before the reset may still be in flight: wait for live states too)
        ok = spin_until(ex, lambda: (bool(errors) and len(states) > 100) or proc.poll() is not None, 240)
        assert ok and errors, f"no ERROR diagnostic after {time.monotonic() - t0:.0f} s"
        spin_until(ex, lambda: False, 1.0)  # drain the joint states still in flight
        proc.send_signal(signal.SIGINT)  # close the recording
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0, out
    finally:
        kill_and_reap(proc)
        ex.shutdown()
        peer.destroy_node()
        rclpy.try_shutdown(context=ctx)
    print(f"\n[node blow-up] h={step}: {errors[-1]}; {len(states)} joint states received")
    assert "numerical instability" in errors[-1], errors[-1]
    assert "snap" not in errors[-1] and "anchor" not in errors[-1]
    # published at every step (~24 s / h messages); in fast mode a Python subscriber drains only
    # part of them (DDS drops under load), the recording below has every one
    assert len(states) > 100
    assert all(fin for _, fin in states)
    assert max(v for v, _ in states) < QD_MAX
    recorded = []
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic == "/joint_states"]
        for c, _, raw in r.messages(connections=conns):
            m = r.deserialize(raw, c.msgtype)
            recorded.append(float(np.max(np.abs(np.asarray(m.velocity, dtype=float)))))
    rec = np.asarray(recorded)
    print(f"[node blow-up] h={step}: {rec.size} recorded joint states, max |velocity| {rec.max():.3g}")
    assert rec.size > 20.0 / float(step) * 0.9  # every step up to the failure at ~24 s
    assert np.all(np.isfinite(rec)) and rec.max() < QD_MAX


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(subprocess.call(["pytest", "-q", "-s", __file__]))
