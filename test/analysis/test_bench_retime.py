"""The bench's retiming of the cheap runs within 1 cm (``analysis/bench/retime.py``): which rows
are timed again, in what order, in blocks of back-to-back runs, and that their cost becomes the
median of the block means.

The simulations are replaced by a stub that hands out prescribed wall times, so the expected
medians are worked out by hand from those numbers, not by the code under test.
"""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from cable_sim.analysis.bench.retime import candidates, retime


def _row(integ: str, cost: float, error: float = 0.005, status: str = "ok", n: int = 40,
         scene: str = "paper_free_fall", kind: str = "fixed") -> dict:
    dur = 10.0
    return dict(scene=scene, n=n, integrator=integ, kind=kind,
                step=0.1 if kind == "fixed" else float("nan"),
                rtol=1e-3 if kind == "adaptive" else float("nan"), duration=dur, status=status,
                wall=cost * dur, wall_inputs=0.0, cost=cost, rtf=1.0 / cost,
                rtf_incl_inputs=1.0 / cost, us_per_step=1e6 * cost * dur / 100, error_m=error)


@dataclass
class _Done:
    wall: float
    wall_inputs: float = 0.0
    status: str = "ok"

    @property
    def ok(self) -> bool:
        return self.status == "ok"


class _Stub:
    """Stands in for ``simulate``: per integrator a queue of wall times (None: a failed run)."""

    def __init__(self, walls: dict[str, list[float | None]]) -> None:
        self.walls = {k: list(v) for k, v in walls.items()}
        self.calls: list[tuple] = []

    def __call__(self, scene, n, integ, setting, duration, budget, drag, kernel) -> _Done:
        self.calls.append((scene, n, integ, setting, drag))
        w = self.walls[integ].pop(0)
        return _Done(wall=0.0, status="failed") if w is None else _Done(wall=w)


def test_candidates_are_the_close_cheap_runs_within_the_bound() -> None:
    rows = [_row("a", 1.0), _row("b", 1.4), _row("c", 1.6), _row("d", 0.5, error=0.02),
            _row("e", 0.9, status="failed"), _row("f", 2.0, n=80)]
    picked = candidates(rows, bound=0.01, close=1.5)
    assert [r["integrator"] for r in picked[("paper_free_fall", 40)]] == ["a", "b"]
    assert [r["integrator"] for r in picked[("paper_free_fall", 80)]] == ["f"]


def test_retime_takes_medians_of_block_means_round_robin() -> None:
    a, b, far = _row("a", 1.0), _row("b", 1.2, kind="adaptive"), _row("c", 2.0)
    # blocks of >= 25 s of wall: a's runs 14+15 | 30 | 10+20, b's 26 | 12+13 | 11+27
    stub = _Stub({"a": [14.0, 15.0, 30.0, 10.0, 20.0], "b": [26.0, 12.0, 13.0, 11.0, 27.0]})
    assert retime([a, b, far], budget=35.0, repeats=3, run=stub, block_wall=25.0) == 2
    # a block at a time, round robin over the candidates
    assert [c[2] for c in stub.calls] == ["a", "a", "b", "a", "b", "b", "a", "a", "b", "b"]
    assert stub.calls[2][3] == 1e-3  # the adaptive row is rerun at its rtol, the fixed at its step
    assert stub.calls[0][3] == 0.1
    # a's block means 14.5, 30, 15 -> median 15; b's 26, 12.5, 19 -> 19; the ladder's single
    # timings (10, 12) only picked them
    assert a["wall"] == 15.0 and a["cost"] == pytest.approx(1.5) and a["repeats"] == 3
    assert a["block_runs"] == 5 and a["wall_spread"] == pytest.approx(30.0 / 14.5)
    assert b["wall"] == 19.0 and b["rtf"] == pytest.approx(10.0 / 19.0)
    assert b["wall_spread"] == pytest.approx(26.0 / 12.5)
    assert a["us_per_step"] == pytest.approx(1e6 * 15.0 / 100)
    # the far row is left as measured
    assert far["wall"] == 20.0 and far["repeats"] == 1 and far["wall_spread"] == 1.0
    assert far["block_runs"] == 0


def test_one_repeat_leaves_the_single_timings() -> None:
    a = _row("a", 1.0)
    stub = _Stub({"a": []})
    assert retime([a], budget=35.0, repeats=1, run=stub) == 0
    assert stub.calls == [] and a["wall"] == 10.0 and a["repeats"] == 1


def test_retime_keeps_the_single_timing_when_a_repeat_fails() -> None:
    a = _row("a", 1.0)
    stub = _Stub({"a": [30.0, None]})
    assert retime([a], budget=35.0, repeats=5, run=stub, block_wall=25.0) == 0
    assert a["wall"] == 10.0 and a["repeats"] == 1
    assert len(stub.calls) == 2  # no further repeats after the failure


def test_retime_splits_the_drag_variant_label() -> None:
    m = _row("a", 1.0, scene="paper_free_fall+morison")
    stub = _Stub({"a": [10.0, 10.0]})
    retime([m], budget=35.0, repeats=2, run=stub, block_wall=5.0)
    assert stub.calls == [("paper_free_fall", 40, "a", 0.1, "morison")] * 2
    assert m["scene"] == "paper_free_fall+morison" and m["repeats"] == 2
