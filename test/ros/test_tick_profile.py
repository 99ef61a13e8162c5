"""TickProfile: per-part wall time per tick, `other` the remainder of the ticks, nan before a tick."""

from __future__ import annotations

import math

import pytest

from cable_sim.ros.timing import TickProfile


def test_split_is_the_mean_per_tick_and_other_the_remainder() -> None:
    p = TickProfile()
    assert all(math.isnan(v) for v in p.split_us().values())
    p.add("physics", 0.004)
    p.add("outputs", 0.001)
    p.add("record", 0.0005)
    p.tick(0.010)
    p.add("physics", 0.002)
    p.tick(0.004)
    split = p.split_us()
    assert split["physics"] == pytest.approx(3000.0)
    assert split["outputs"] == pytest.approx(500.0)
    assert split["record"] == pytest.approx(250.0)
    assert split["messages"] == 0.0
    assert split["other"] == pytest.approx(7000.0 - 3750.0)
    assert p.longest_tick == 0.010
    with pytest.raises(KeyError):
        p.add("rendering", 1.0)
    p.reset()
    assert p.ticks == 0 and math.isnan(p.split_us()["other"])
