"""RealtimePacing on a stand-in node: real time starts at the first tick, so the node's start-up is
no backlog (no burst of catch-up steps, no overrun), and from there simulated time follows the wall
clock step by step; a real backlog beyond the tick budget still counts an overrun."""

from __future__ import annotations

import time
from types import SimpleNamespace

from cable_sim.ros.clock_modes import RealtimePacing
from cable_sim.ros.timing import RunClock, TickProfile

H = 0.01  # step [s]


class _Run:
    def __init__(self, sim: SimpleNamespace, step_wall: float) -> None:
        self.sim, self.step_wall, self.overruns, self.profile = sim, step_wall, 0, TickProfile()

    def running(self) -> bool:
        return True

    def step_once(self) -> bool:
        time.sleep(self.step_wall)
        self.sim.k += 1
        self.sim.t = self.sim.k * H
        return True


def _node(startup_wall: float, step_wall: float) -> SimpleNamespace:
    """A node whose clock started ``startup_wall`` seconds ago (its start-up), 50 Hz ticks (a
    budget of 16 ms of stepping per tick), steps that take ``step_wall`` seconds of wall time."""
    sim = SimpleNamespace(t=0.0, k=0)
    return SimpleNamespace(
        sim=sim, h=H, run=_Run(sim, step_wall), clock=RunClock(time.monotonic() - startup_wall),
        get_parameter=lambda name: SimpleNamespace(value=50.0),
        create_timer=lambda period, callback: None,
        get_logger=lambda: SimpleNamespace(warning=lambda *a, **k: None))


def test_start_up_is_no_backlog_and_time_is_followed_from_the_first_tick() -> None:
    node = _node(startup_wall=2.0, step_wall=2e-4)  # 200 steps: >= 40 ms, over the 16 ms budget
    pacing = RealtimePacing(node)
    before_first = time.monotonic()
    pacing.tick()
    after_first = time.monotonic()
    assert node.sim.k == 0 and node.run.overruns == 0
    node.run.step_wall = 0.0  # from here steps cost no wall time: only the pacing is looked at
    time.sleep(0.1)
    before_second = time.monotonic()
    pacing.tick()
    after_second = time.monotonic()
    # the steps due: the wall time between the two ticks in 10 ms steps, whatever the sleep took
    assert int((before_second - after_first) / H) <= node.sim.k, node.sim.k
    assert node.sim.k <= int((after_second - before_first) / H), node.sim.k
    assert node.run.overruns == 0


def test_a_backlog_beyond_the_tick_budget_counts_an_overrun() -> None:
    node = _node(startup_wall=0.0, step_wall=1e-3)
    pacing = RealtimePacing(node)
    pacing.tick()
    time.sleep(0.5)  # 50 steps due; 1 ms each cannot be done in the 16 ms budget of one tick
    pacing.tick()
    assert 1 <= node.sim.k < 50, node.sim.k
    assert node.run.overruns == 1
