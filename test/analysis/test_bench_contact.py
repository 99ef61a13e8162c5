"""The benchmark's seabed-contact cost study (issue #11 item 6) on a small mooring line.

Independent checks: the physics of the two cases (with the seabed the reference line rests on the
floor within 5 cm; without it the chain sags below the anchor's depth, as an inextensible
catenary with the anchor at its lowest point must), the ladder's rule (the chosen run is the
first within 1 cm, walking down from the largest step) and the same-run ratio.
"""

from __future__ import annotations

import math

import pytest

from cable_sim.analysis.bench import contact_cost as cc
from cable_sim.analysis.bench.settings import ERROR_BOUND


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    return cc.contact_cost(6, 2.0, cache, ["rk4", "rosenbrock2"], [0.1, 0.05, 0.025], [], 30.0,
                           rtol=1e-11, repeats=2)


def test_chosen_rows_cover_both_cases(study):
    ladder, chosen = study
    assert {(r["integrator"], r["seabed"]) for r in chosen} == {
        (i, s) for i in ("rk4", "rosenbrock2") for s in ("on", "off")}
    for r in chosen:
        assert r["status"] == "ok" and r["within_bound"], r
        assert 0 <= r["error_m"] <= ERROR_BOUND
        assert r["rtf"] > 0 and r["repeats"] >= 1
        assert r["added_mass"].startswith("on")
    # the ratio is the same-run RTF of the two cases of one scheme
    by = {(r["integrator"], r["seabed"]): r for r in chosen}
    for integ in ("rk4", "rosenbrock2"):
        on, off = by[(integ, "on")], by[(integ, "off")]
        assert on["rtf_ratio_off_over_on"] == pytest.approx(off["rtf"] / on["rtf"])


def test_ladder_stops_at_the_first_step_within_the_bound(study):
    ladder, chosen = study
    for r in chosen:
        runs = [x for x in ladder if x["integrator"] == r["integrator"] and x["seabed"] == r["seabed"]]
        steps = [x["step"] for x in runs]
        assert steps == sorted(steps, reverse=True)
        assert [x["within_bound"] for x in runs] == [False] * (len(runs) - 1) + [True]
        assert r["step"] == steps[-1]


def test_reference_lines_lie_where_the_physics_puts_them(study):
    _, chosen = study
    low = {r["seabed"]: r["ref_lowest_z_m"] for r in chosen}
    assert low["on"] >= -100.0 - 0.05  # rests on the bed (about w / k_b = 1 cm deep)
    assert low["off"] < -100.0 - 1.0  # no bed: the 300 m chain sags below the anchor


def test_table_and_plot(study, tmp_path):
    _, chosen = study
    table = cc.contact_table(chosen)
    assert [r["integrator"] for r in table] == ["rk4", "rosenbrock2"]
    for r in table:
        assert r["seabed_on"].startswith("h ") and math.isfinite(r["rtf_off_over_on"])
    cc.contact_plot(tmp_path, chosen)
    assert (tmp_path / "contact_cost.png").stat().st_size > 0
