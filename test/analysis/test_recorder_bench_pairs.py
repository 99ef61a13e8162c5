"""``recorder_bench.node_overhead``: recording off / on in pairs whose first run alternates, the
overhead the median of the per-pair overheads.

The node runs are replaced by a stub that hands out prescribed steps/s, so the expected overhead
is worked out by hand from those numbers, not by the code under test.
"""

from __future__ import annotations

import pytest

from cable_sim.analysis import recorder_bench


def test_pairs_alternate_which_run_goes_first(monkeypatch, tmp_path) -> None:
    order: list[bool] = []
    # steps/s in call order: pair 1 off 100, on 90; pair 2 on 80, off 100; pair 3 off 100, on 70
    rates = iter([100.0, 90.0, 80.0, 100.0, 100.0, 70.0])

    def fake_run(scene, n_links, seconds, record, tmpdir) -> dict:
        order.append(record)
        return {"steps_per_s": next(rates)}

    monkeypatch.setattr(recorder_bench, "node_fast_mode", fake_run)
    rows = recorder_bench.node_overhead("mooring_line", 80, 1.0, 3, tmp_path)
    assert order == [False, True, True, False, False, True]
    over = [r for r in rows if r["kind"] == "node_overhead"][0]
    # per-pair overheads 0.1, 0.2, 0.3 -> median 0.2
    assert over["overhead"] == pytest.approx(0.2)
    assert over["overhead_min"] == pytest.approx(0.1) and over["overhead_max"] == pytest.approx(0.3)
    assert over["pairs"] == 3
    med = {r["mode"]: r["steps_per_s"] for r in rows if r["kind"] == "node_fast"}
    assert med == {"no record": 100.0, "record": 80.0}
