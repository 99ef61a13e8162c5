"""Replay of the seabed outputs (issue 11, "Outputs"): the recorded ``seabed_contact`` topic, its
loading and the summary's touchdown excursion and laid-length ranges.

Recordings come from :func:`cable_sim.analysis.replay.record_headless` (the node's messages without
a ROS graph). Expected values are read from the file with ``mcap_ros2``'s generic decoder
(independent of the package's hand-written CDR reader) and, for the no-contact convention, from the
recorded joint states.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from cable_sim.analysis.replay import load_run, main, record_headless, summary, summary_values
from cable_sim.analysis.replay.cdr import decoders, fast_decoders

LABEL = "touchdown_arc_length_m,touchdown_x_m,laid_length_m,seabed_reaction_N"  # interface.yaml


def _decoded(path, topic: str) -> list[tuple[int, object]]:
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(m.log_time, dec) for _, _, m, dec in reader.iter_decoded_messages(topics=[topic])]


@pytest.fixture(scope="module")
def moving(tmp_path_factory):
    """The mooring line (n = 20) under its wave without the ramp: the touchdown moves."""
    path = tmp_path_factory.mktemp("seabed") / "mooring.mcap"
    record_headless("mooring_line", path, 4.0, overrides={"n_links": 20, "wave_ramp": 0.0},
                    tension_rate=20.0)
    return path


@pytest.fixture(scope="module")
def lifted(tmp_path_factory):
    """A free-hanging line over a seabed far below it: nothing ever touches."""
    path = tmp_path_factory.mktemp("seabed") / "free.mcap"
    record_headless("control_experiment", path, 1.0, overrides={"seabed": True, "seabed_depth": -1000.0},
                    tension_rate=20.0)
    return path


def test_recorded_values_and_layout(moving):
    msgs = _decoded(moving, "/seabed_contact")
    assert len(msgs) == 81  # 20 Hz over 4 s, both ends
    for _, m in msgs:
        assert [(d.label, d.size, d.stride) for d in m.layout.dim] == [(LABEL, 4, 4)]
        assert len(m.data) == 4 and all(math.isfinite(v) for v in m.data)
    v = np.array([m.data for _, m in msgs])
    assert np.ptp(v[:, 1]) > 0.1  # the touchdown does move under the wave
    assert np.all(v[:, 0] >= v[:, 2] - 1e-9)  # all laid chain lies between anchor and touchdown


def test_fast_reader_equals_the_generic_decoder(moving):
    fast, generic = fast_decoders(), decoders()
    with open(moving, "rb") as f:
        n = 0
        for schema, _, message in make_reader(f).iter_messages(topics=["/seabed_contact"]):
            assert np.array_equal(fast(schema, message.data).data, generic(schema, message.data).data)
            n += 1
    assert n == 81


def test_summary_ranges_are_min_and_max_of_the_recording(moving, capsys):
    v = np.array([m.data for _, m in _decoded(moving, "/seabed_contact")])
    run = load_run(moving)
    assert np.array_equal(run.seabed.v, v)
    s = summary_values(run)
    assert (s["touchdown_x_min"], s["touchdown_x_max"]) == (v[:, 1].min(), v[:, 1].max())
    assert s["touchdown_excursion"] == v[:, 1].max() - v[:, 1].min()
    assert (s["touchdown_arc_min"], s["touchdown_arc_max"]) == (v[:, 0].min(), v[:, 0].max())
    assert (s["laid_length_min"], s["laid_length_max"]) == (v[:, 2].min(), v[:, 2].max())
    assert s["seabed_reaction_max"] == v[:, 3].max()
    assert (s["seabed_samples"], s["seabed_contact_samples"]) == (81, 81)
    # the command line's summary (it reads only what it prints) shows the same ranges
    assert main([str(moving)]) == 0
    text = capsys.readouterr().out
    assert text.splitlines() == summary(run).splitlines()[:len(text.splitlines())]
    assert (f"touchdown     x {v[:, 1].min():.6g} .. {v[:, 1].max():.6g} m (excursion "
            f"{v[:, 1].max() - v[:, 1].min():.4g} m)") in text
    assert f"laid length   {v[:, 2].min():.6g} .. {v[:, 2].max():.6g} m" in text


def test_markers_draw_the_seabed_and_the_touchdown(moving):
    sc = {t: m.data for t, m in _decoded(moving, "/seabed_contact")}
    checked = 0
    for t, arr in _decoded(moving, "/cable_markers"):
        mk = {m.ns: m for m in arr.markers}
        assert mk["seabed"].points[0].z == mk["seabed"].points[1].z == -100.0
        td = mk["touchdown"]
        assert td.action == 0 and td.pose.position.z == -100.0  # ADD, on the bed
        if t in sc:
            assert td.pose.position.x == sc[t][1]
            checked += 1
    assert checked >= 10


def test_nothing_on_the_bed_follows_the_documented_convention(lifted):
    msgs = _decoded(lifted, "/seabed_contact")
    assert len(msgs) == 21
    run = load_run(lifted)
    same_step = 0
    for t, m in msgs:
        arc, x_td, laid, reaction = m.data
        assert (arc, laid, reaction) == (0.0, 0.0, 0.0)
        # touchdown at the line's end: x of the last joint (polyline from the joint states)
        k = int(np.searchsorted(run.t_ns, t))
        if k < len(run.t_ns) and run.t_ns[k] == t:
            assert x_td == pytest.approx(run.polyline[k, -1, 0], abs=1e-9)
            same_step += 1
    assert same_step >= 10
    for _, arr in _decoded(lifted, "/cable_markers"):
        assert {m.ns: m.action for m in arr.markers}["touchdown"] == 2  # DELETE while nothing touches
    s = summary_values(run)
    assert (s["laid_length_min"], s["laid_length_max"], s["seabed_contact_samples"]) == (0.0, 0.0, 0)
    assert "line on the bed in 0 of 21 samples" in summary(run)


def test_a_run_without_seabed_has_no_seabed_summary(tmp_path):
    path = tmp_path / "free.mcap"
    record_headless("control_experiment", path, 0.5)
    run = load_run(path)
    assert len(run.seabed) == 0 and run.seabed.v.shape == (0, 4)
    assert "touchdown_x_min" not in summary_values(run)
    assert "touchdown" not in summary(run) and "laid length" not in summary(run)
