"""The bench's retiming of the cheap runs within 1 cm (``analysis/bench/retime.py``): which rows
are timed again, in what order, and that their cost becomes the median of all their timings.

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


def test_retime_takes_medians_round_robin() -> None:
    a, b, far = _row("a", 1.0), _row("b", 1.2, kind="adaptive"), _row("c", 2.0)
    stub = _Stub({"a": [14.0, 15.0, 13.0, 16.0], "b": [11.0, 12.0, 10.0, 13.0]})
    assert retime([a, b, far], budget=35.0, repeats=5, run=stub) == 2
    # round robin: a, b, a, b, ...
    assert [c[2] for c in stub.calls] == ["a", "b"] * 4
    assert stub.calls[1][3] == 1e-3  # the adaptive row is rerun at its rtol, the fixed at its step
    assert stub.calls[0][3] == 0.1
    # a's timings 10, 14, 15, 13, 16 -> median 14; b's 12, 11, 12, 10, 13 -> 12
    assert a["wall"] == 14.0 and a["cost"] == pytest.approx(1.4) and a["repeats"] == 5
    assert a["wall_spread"] == pytest.approx(16.0 / 10.0)
    assert b["wall"] == 12.0 and b["rtf"] == pytest.approx(10.0 / 12.0)
    assert a["us_per_step"] == pytest.approx(1e6 * 14.0 / 100)
    # the far row is left as measured
    assert far["wall"] == 20.0 and far["repeats"] == 1 and far["wall_spread"] == 1.0


def test_retime_keeps_the_single_timing_when_a_repeat_fails() -> None:
    a = _row("a", 1.0)
    stub = _Stub({"a": [30.0, None]})
    assert retime([a], budget=35.0, repeats=5, run=stub) == 0
    assert a["wall"] == 10.0 and a["repeats"] == 1
    assert len(stub.calls) == 2  # no further repeats after the failure


def test_retime_splits_the_drag_variant_label() -> None:
    m = _row("a", 1.0, scene="paper_free_fall+morison")
    stub = _Stub({"a": [10.0]})
    retime([m], budget=35.0, repeats=2, run=stub)
    assert stub.calls == [("paper_free_fall", 40, "a", 0.1, "morison")]
    assert m["scene"] == "paper_free_fall+morison" and m["repeats"] == 2
