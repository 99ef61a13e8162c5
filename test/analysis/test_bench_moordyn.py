"""The MoorDyn peer of the benchmark (issue #13): the input file built from the scene, the cable_sim
side of the comparison, and (when the optional ``moordyn`` package is installed) MoorDyn's own
reading of that file and its static fairlead tension.

Independent checks: the line properties are compared with config/mooring_line.yaml read here
with yaml and converted by MoorDyn's documented conventions (seabed per area = per length / d,
water depth = seabed depth below MoorDyn's shifted surface); MoorDyn's static fairlead tension with
an inextensible catenary with touchdown solved in the test (MODEL.md's closed form).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import brentq

from cable_sim.analysis.bench import moordyn_input, moordyn_peer
from cable_sim.analysis.bench.moordyn_run import moordyn_version
from cable_sim.scene.scenes import load_scene

HAS_MOORDYN = moordyn_version() is not None  # installed and importable
needs_moordyn = pytest.mark.skipif(not HAS_MOORDYN, reason="moordyn not installed (optional bench "
                                   "extra: pip install moordyn==2.7.2)")
CONFIG = Path(__file__).resolve().parents[2] / "config" / "mooring_line.yaml"
FAIRLEAD_Z = -0.29  # m, near the scene's static buoy position


def _yaml() -> dict:
    return yaml.safe_load(CONFIG.read_text())["/**"]["ros__parameters"]


def _line(**kw) -> moordyn_input.MoorDynLine:
    return moordyn_input.line_from_scene(load_scene("mooring_line"), FAIRLEAD_Z, **kw)


def test_input_file_has_the_scene_line():
    y = _yaml()
    d = y["diameter"]
    text = moordyn_input.input_text(_line(), nseg=37, dt=7.5e-4)
    parsed = moordyn_input.parse_input(text)
    lt = parsed["LINE TYPES"]["line"]
    assert float(lt["Diam"]) == pytest.approx(d, rel=1e-12)
    assert float(lt["Mass/m"]) == pytest.approx(y["mass_per_length"], rel=1e-12)
    assert float(lt["Cd"]) == pytest.approx(y["drag_cn"], rel=1e-12)
    assert float(lt["CdAx"]) == pytest.approx(y["drag_ct"], rel=1e-12)  # both codes: pi d area
    assert float(lt["Ca"]) == pytest.approx(y["added_mass_cn"], rel=1e-12)
    assert float(lt["CaAx"]) == pytest.approx(y["added_mass_ct"], rel=1e-12)
    assert float(lt["EI"]) == pytest.approx(y["bending_stiffness"], rel=1e-12)
    # inextensible within 0.1 % at twice the scene's ~160 kN fairlead tension
    assert 320e3 / float(lt["EA"]) < 1e-3
    shift = moordyn_input.SHIFT_DEFAULT
    pts = parsed["POINT PROPERTIES"]
    assert pts["1"]["Type"] == "Fixed" and pts["2"]["Type"] == "Coupled"
    anchor = [float(pts["1"][k]) for k in ("X", "Y", "Z")]
    fair = [float(pts["2"][k]) for k in ("X", "Y", "Z")]
    assert anchor == pytest.approx([y["anchor_x"], 0.0, y["anchor_z"] - shift], abs=1e-9)
    assert fair == pytest.approx([0.0, 0.0, FAIRLEAD_Z - shift], abs=1e-9)
    ln = parsed["LINES"]["1"]
    assert float(ln["UnstrLen"]) == pytest.approx(y["total_length"], rel=1e-12)
    assert int(ln["NumSegs"]) == 37
    opt = parsed["OPTIONS"]
    assert float(opt["dtM"]) == 7.5e-4
    assert float(opt["kBot"]) == pytest.approx(y["seabed_stiffness"] / d, rel=1e-12)
    assert float(opt["cBot"]) == pytest.approx(y["seabed_damping"] / d, rel=1e-12)
    assert float(opt["WtrDpth"]) == pytest.approx(shift - y["seabed_depth"], rel=1e-12)
    assert float(opt["WtrDnsty"]) == y["water_density"] and float(opt["g"]) == y["gravity"]
    assert float(opt["FrictionCoefficient"]) == 0.0


def test_mapping_refuses_what_moordyn_peer_cannot_express():
    with pytest.raises(moordyn_input.MoorDynMappingError, match="drag_model"):
        moordyn_input.line_from_scene(load_scene("mooring_line", {"drag_model": "paper"}), 0.0)
    with pytest.raises(moordyn_input.MoorDynMappingError, match="seabed"):
        moordyn_input.line_from_scene(load_scene("mooring_line", {"seabed": False}), 0.0)


def test_tension_error_definition():
    conv = np.array([100.0, 110.0, 120.0])
    assert moordyn_peer.tension_error(conv + [0.0, 1.2, -0.6], conv) == pytest.approx(0.01)
    assert math.isnan(moordyn_peer.tension_error(conv[:2], conv))
    assert math.isnan(moordyn_peer.tension_error(np.array([1.0, np.nan, 1.0]), conv))


def test_peer_skips_without_moordyn(monkeypatch):
    monkeypatch.setattr(moordyn_peer, "moordyn_version", lambda: None)
    res = moordyn_peer.moordyn_peer(moordyn_peer.PeerSettings(duration=1.0))
    assert res.ladder == [] and res.summary == []


def test_cable_sim_side_ladder():
    """The cable_sim ladder on the scene: a coarse n whose time-converged tension is off by more
    than 1 % is not walked; at an adequate n the largest step within 1 % is accepted."""
    ps = moordyn_peer.PeerSettings(duration=2.0, cs_n=(4, 12), cs_integs=("rk4",), cs_steps=(0.05, 0.025))
    conv = moordyn_peer.simulate("mooring_line", 12, "rk4", 0.025, 2.0).tension
    rows = moordyn_peer._cable_sim(ps, conv)
    assert rows and all(r["code"] == "cable_sim" and r["status"] == "ok" for r in rows)
    fine = {r["segments"]: r for r in rows if r["role"] == "time-converged"}
    assert set(fine) == {4, 12} and all(r["step"] == moordyn_peer.CS_FINE[1] for r in fine.values())
    assert fine[4]["tension_rel_error"] > moordyn_peer.TENSION_BOUND  # 4 links: too coarse
    assert fine[12]["tension_rel_error"] < 1e-3  # same n, rk4 at 5 ms vs 25 ms
    ladder = [r for r in rows if r["role"] == "ladder"]
    assert [(r["segments"], r["step"], r["accepted"]) for r in ladder] == [(12, 0.05, True)]
    # static fairlead tension (t = 0) within 5 % of the inextensible catenary with touchdown
    assert ladder[0]["static_tension_N"] == pytest.approx(_catenary_tension(-0.29), rel=0.05)


def test_walk_tries_only_counts_adequate_when_time_converged():
    """A coarse n whose error dips under the bound at one step (time and discretisation errors
    cancelling) is not walked: its time-converged run is over the bound. At the first adequate n
    the largest step within the bound is accepted and the walk ends."""
    err = {(10, 0.1): 0.05, (10, 0.05): 0.004, (10, 0.001): 0.017,
           (20, 0.1): float("nan"), (20, 0.05): 0.008, (20, 0.025): 0.006, (20, 0.001): 0.006,
           (40, 0.1): 0.001, (40, 0.001): 0.001}
    calls = []

    def runner(n, h):
        calls.append((n, h))
        e = err[(n, h)]
        status = "ok" if math.isfinite(e) else "failed: blow-up"
        return dict(status=status, tension_rel_error=e, wall_per_sim_s=1.0, wall=1.0,
                    within_bound=bool(status == "ok" and e <= moordyn_peer.TENSION_BOUND))

    fine = moordyn_peer._fine(runner, 0.001, "test")
    rows = moordyn_peer._walk(runner, fine, (10, 20, 40), (0.1, 0.05, 0.025), "test")
    assert calls == [(10, 0.001), (20, 0.001), (20, 0.1), (20, 0.05)]
    assert [r["accepted"] for r in rows] == [False, True] and rows[1]["tension_rel_error"] == 0.008
    assert moordyn_peer._best(rows) is rows[1]
    assert set(fine.done) == {10, 20} and fine.done[10]["role"] == "time-converged"


def _catenary_tension(fairlead_z: float) -> float:
    """Fairlead tension of the inextensible chain with touchdown (MODEL.md), from the yaml."""
    y = _yaml()
    area = math.pi * y["diameter"] ** 2 / 4
    w = (y["mass_per_length"] - y["water_density"] * area) * y["gravity"]
    v = fairlead_z - y["anchor_z"]
    span, length = y["anchor_x"], y["total_length"]

    def f(a: float) -> float:
        ls = math.sqrt(v * v + 2 * a * v)
        return a * math.asinh(ls / a) - (span - (length - ls))

    a = brentq(f, 1.0, 1e6)
    return math.hypot(w * a, w * math.sqrt(v * v + 2 * a * v))


@needs_moordyn
def test_moordyn_reads_the_line_and_its_static_tension_matches_the_catenary():
    import moordyn

    from cable_sim.analysis.bench.moordyn_run import run_moordyn

    line = _line()
    run = run_moordyn(line, 40, 1e-3, 1.0, lambda t: np.full(np.shape(t), FAIRLEAD_Z))
    assert run.ok, run.status
    assert run.tension[0] == pytest.approx(_catenary_tension(FAIRLEAD_Z), rel=0.01)
    assert np.all(np.abs(run.tension - run.tension[0]) < 0.01 * run.tension[0])  # at rest
    # MoorDyn's own reading of the file
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/line.txt"
        Path(path).write_text(moordyn_input.input_text(line, 40, 1e-3))
        s = moordyn.Create(path)
        try:
            moordyn.SetVerbosity(s, moordyn.LEVEL_NONE)
            assert moordyn.Init(s, list(line.fairlead), [0.0, 0.0, 0.0]) == 0
            ml = moordyn.GetLine(s, 1)
            assert moordyn.GetLineN(ml) == 40
            assert moordyn.GetLineUnstretchedLength(ml) == pytest.approx(300.0)
            assert moordyn.GetLineNodePos(ml, 0) == pytest.approx([250.0, 0.0, -120.0], abs=1e-6)
        finally:
            moordyn.Close(s)
