"""Replay: loading a recording into arrays, plots, CSV, re-simulation from recorded inputs.

Recordings here come from :func:`cable_sim.analysis.replay.record_headless` (same topics and messages as
the node, no ROS graph); test_replay_node.py does the same against the real node process.
"""

import csv
import dataclasses

import numpy as np
import pytest

from cable_sim.analysis.replay import (
    compare,
    export_csv,
    load_run,
    main,
    record_headless,
    resimulate,
    summary,
)
from cable_sim.core import dynamics
from cable_sim.scene.scenes import load_scene

INPUTS = [(0.5, "heave_force", 5000.0), (1.0, "wave_elevation", 0.5), (2.0, "heave_force", -3000.0)]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "anchored.mcap"
    st = record_headless("paper_anchored_forced", path, 3.0, overrides={"n_links": 20}, inputs=INPUTS,
                         chunk_size=50_000)
    return path, st


@pytest.fixture(scope="module")
def run(recorded):
    return load_run(recorded[0])


def test_arrays_match_the_recorded_physics(run, recorded):
    _, st = recorded
    assert run.n_links == 20 and run.scene.name == "paper_anchored_forced"
    assert len(run.t) == st["published"]["/joint_states"] == 151
    assert np.array_equal(run.t_ns, np.arange(151) * 20_000_000)
    # absolute angles are the running sum of the relative joint positions
    assert np.array_equal(run.angles[:, 0], run.joint_position[:, 1])
    assert np.allclose(np.diff(run.angles, axis=1), run.joint_position[:, 2:], atol=1e-15, rtol=0)
    # the polyline starts at the platform and ends at the anchor (exact constraint)
    assert np.array_equal(run.polyline[:, 0, 1], run.heave)
    assert np.abs(run.tip - np.array([150.0, -150.0])).max() < 1e-6
    # link lengths are preserved
    seg = np.linalg.norm(np.diff(run.polyline, axis=1), axis=2)
    assert np.allclose(seg, 12.0, atol=1e-9)
    # inputs: received messages and held values, at the simulation times they were received
    assert np.array_equal(run.received["heave_force"].t, [0.5, 2.0])
    assert np.array_equal(run.received["heave_force"].v, [5000.0, -3000.0])
    assert np.array_equal(run.applied.v, [[5000.0, 0.0], [5000.0, 0.5], [-3000.0, 0.5]])
    # the heave effort is the applied heave force: scene sine + held topic value
    scene = load_scene("paper_anchored_forced")
    f = scene.input_function()
    k = np.searchsorted(run.t, 2.5)
    assert run.joint_effort[k, 0] == pytest.approx(f(run.t[k]).heave_force - 3000.0, abs=1e-9)
    # as in the node, the outputs stamped at the step an input arrives still show the old value
    k = np.searchsorted(run.t, 2.0)
    assert run.t[k] == 2.0
    assert run.joint_effort[k, 0] == pytest.approx(f(2.0).heave_force + 5000.0, abs=1e-9)
    assert run.joint_effort[k + 1, 0] == pytest.approx(f(run.t[k + 1]).heave_force - 3000.0, abs=1e-9)
    assert run.fairlead_tension.max() > 100.0 and len(run.anchor) == len(run.fairlead)


def test_resimulation_with_recorded_settings_is_bit_for_bit(run):
    rs = resimulate(run)
    d = compare(run, rs)
    assert rs.settings == {"kernel": "fast", "integrator": "rk4", "step": 0.002, "n_links": 20}
    assert d["identical_joint_states"] == 1.0
    assert np.array_equal(rs.joint_position, run.joint_position)
    assert np.array_equal(rs.joint_velocity, run.joint_velocity)
    assert np.array_equal(rs.joint_effort, run.joint_effort)
    assert all(d[k] == 0.0 for k in ("heave_max", "heave_rms", "tip_max", "tension_max", "tension_rms"))


def test_resimulation_uses_the_inputs_at_the_exact_step(run):
    # drop the recorded inputs: the heave changes by far more than round-off
    no_in = dataclasses.replace(run, applied=dataclasses.replace(run.applied, v=run.applied.v * 0.0))
    assert compare(run, resimulate(no_in))["heave_max"] > 1e-3
    # apply them one step late: no longer bitwise identical
    late = dataclasses.replace(run, applied_t_ns=run.applied_t_ns + 2_000_000)
    d = compare(run, resimulate(late))
    assert d["identical_joint_states"] == 0.0 and d["heave_max"] > 0.0


@pytest.mark.parametrize("kw,bound", [
    ({"step": 0.001}, 1e-8),        # halving an RK4 step: tiny change
    ({"kernel": "dense"}, 1e-9),    # same maths, other kernel: round-off only (CPU-dependent)
    ({"links": 10}, 0.01),          # coarser line: mm-level heave change
])
def test_resimulation_with_other_settings_reports_the_difference(run, kw, bound):
    rs = resimulate(run, **kw)
    d = compare(run, rs)
    if "kernel" in kw:  # round-off only: whether any bit differs depends on the CPU
        assert d["heave_max"] < bound
    else:
        assert d["identical_joint_states"] == 0.0
        assert 0.0 < d["heave_max"] < bound
    assert d["heave_rms"] <= d["heave_max"] and d["tension_rms"] <= d["tension_max"]
    if "links" in kw:
        assert rs.joint_position.shape == (len(run.t), 11)
        assert np.abs(rs.tip - np.array([150.0, -150.0])).max() < 1e-6


def test_csv_round_trip(run, tmp_path):
    out = export_csv(run, tmp_path / "run.csv")
    with open(out) as f:
        rows = list(csv.reader(f))
    assert rows[0][:4] == ["t", "heave", "tip_x", "tip_z"] and rows[0][-1] == "theta_20"
    data = np.array(rows[1:], dtype=float)
    assert data.shape == (len(run.t), 9 + 20)
    assert np.array_equal(data[:, 0], run.t) and np.array_equal(data[:, 1], run.heave)
    assert np.array_equal(data[:, 9:], run.angles)
    assert np.array_equal(data[:, 6], run.fairlead_tension)  # same stamps: no interpolation
    assert np.array_equal(data[:, 7], np.where(run.t >= 2.0, -3000.0, np.where(run.t >= 0.5, 5000.0, 0.0)))


def test_command_line_summary_plots_csv_resim(recorded, tmp_path, capsys):
    path, _ = recorded
    fr, te, gif, cs = (tmp_path / n for n in ("f.png", "t.png", "a.gif", "r.csv"))
    assert main([str(path), "--frames", str(fr), "--tension", str(te), "--gif", str(gif),
                 "--gif-interval", "0.5", "--csv", str(cs), "--resim"]) == 0
    out = capsys.readouterr().out
    assert "scene         paper_anchored_forced (n = 20" in out
    assert "joint states bitwise identical: yes" in out
    assert "heave            max 0.000e+00 m" in out
    for p in (fr, te):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 20_000
    assert gif.read_bytes()[:6] == b"GIF89a"
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 7  # t = 0, 0.5, ..., 3.0


def test_frames_pick_the_requested_times(run):
    from cable_sim.analysis.replay.plots import frame_indices

    idx = frame_indices(run, 0.5)
    assert np.allclose(run.t[idx], np.arange(0, 3.01, 0.5))
    with pytest.raises(ValueError, match="frame interval"):
        frame_indices(run, 0.0)


def test_command_line_recover(tmp_path, recorded, capsys):
    path, st = recorded
    data = path.read_bytes()
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(data[: len(data) * 2 // 3])  # cut mid-file (as after SIGKILL)
    fixed = tmp_path / "fixed.mcap"
    assert main(["--recover", str(bad), str(fixed)]) == 0
    assert "input was truncated" in capsys.readouterr().out
    r = load_run(fixed)
    assert 0 < len(r.t) < 151
    full = load_run(path)
    assert np.array_equal(r.joint_position, full.joint_position[: len(r.t)])


def test_polyline_uses_the_models_kinematics(run):
    m = run.scene.model()
    q = np.concatenate([[run.heave[7]], run.angles[7]])
    assert np.array_equal(run.polyline[7], dynamics.joint_positions(m, q))


def test_summary_of_a_run_without_diagnostics(run):
    """A node run that ended before its first /diagnostics message (1 Hz; e.g. stopped while
    still compiling) has no real-time factor, rejected-input or overrun counts to report: the
    summary says n/a, not nan or 0. (A headless recording always has one at t = 0, so the loaded
    run is stripped of its diagnostics as a recording without them would load.)"""
    counts = {k: v for k, v in run.counts.items() if k != "/diagnostics"}
    bare = dataclasses.replace(run, diagnostics={}, diagnostics_text={}, counts=counts)
    text = summary(bare)
    assert "real-time     n/a (no diagnostics recorded" in text
    assert "overruns      n/a" in text and "rejected      n/a" in text
    assert "nan" not in text


def test_summary_reports_the_recorded_counters(run):
    text = summary(run)
    assert run.counts["/diagnostics"] >= 2
    assert "overruns      0" in text and "rejected      0 inputs" in text
    assert "real-time     n/a" not in text
