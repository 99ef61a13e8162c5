"""Pacing of the simulation in the three clock modes.

- ``realtime``: a 50 Hz (or faster) timer advances the simulation to the wall clock, within a
  budget of 0.8 tick; falling behind counts an overrun, more than 1 s behind drops the backlog.
  Real time starts at the first tick: the node's start-up after its clock started (first
  messages, timers, the executor's first spin) is not a backlog to catch up;
- ``fast``: a 0.5 ms timer steps for up to 10 ms per tick and publishes ``/clock``;
- ``lockstep``: once a controller is connected both ways, joint_states(t0) is published and each
  ``heave_force`` message advances one control period, then ``/clock`` and ``joint_states``.

May import rclpy and the layers below.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

from cable_sim.core.params import ParameterError

if TYPE_CHECKING:
    from rclpy.node import Node


def control_steps(control_period: float, h: float, lockstep: bool) -> int:
    """Physics steps per control period; in lockstep the period must be a multiple of the step ``h``.

    Raises
    ------
    ParameterError
        In lockstep, when ``control_period`` is not a whole number of steps.
    """
    steps = max(1, int(round(control_period / h)))
    if lockstep and abs(steps * h - control_period) > 1e-9 * control_period:
        raise ParameterError("control_period", control_period, f"a multiple of the step {h} s")
    return steps


def _timed_tick(node: Node, advance: Callable[[], None]) -> None:
    """Run one timer tick's ``advance`` and count its wall time in the node's tick profile."""
    w = time.perf_counter()
    try:
        advance()
    finally:
        node.run.profile.tick(time.perf_counter() - w)


class RealtimePacing:
    """Advance the simulation to the wall clock on every tick (see the module docstring)."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.tick_period = min(0.02, 1.0 / node.get_parameter("joint_state_rate").value)
        #: (wall, sim time) pair that paces real time; set at the first tick (see the module docstring)
        self.sim_wall_base: tuple[float, float] | None = None
        node.create_timer(self.tick_period, self.tick)

    def rebase(self, now: float) -> None:
        """Pace from the current simulated time at wall time ``now`` (pause, reset)."""
        self.sim_wall_base = (now, self.node.sim.t)

    def tick(self) -> None:
        _timed_tick(self.node, self._advance)

    def _advance(self) -> None:
        node, sim, run = self.node, self.node.sim, self.node.run
        now = time.monotonic()
        node.clock.tick(now, sim.t)
        if self.sim_wall_base is None:
            self.rebase(now)
        if not run.running():
            return
        wall0, sim0 = self.sim_wall_base
        target = sim0 + (now - wall0)
        budget_end = time.perf_counter() + 0.8 * self.tick_period
        while (sim.k + 1) * node.h <= target + 1e-12:
            if not run.step_once():
                return
            if time.perf_counter() > budget_end:
                break
        if target - sim.t > self.tick_period:
            run.overruns += 1
            if target - sim.t > 1.0:  # hopelessly behind: drop the backlog, keep pacing
                self.sim_wall_base = (now, sim.t)
                node.get_logger().warning("simulation is more than 1 s behind wall time: "
                                          "dropping the backlog", throttle_duration_sec=5.0)


class FastPacing:
    """Step as fast as possible (10 ms of stepping per 0.5 ms tick), publishing ``/clock``."""

    def __init__(self, node: Node) -> None:
        self.node = node
        node.create_timer(0.0005, self.tick)

    def rebase(self, now: float) -> None:
        """Nothing to re-pace: fast mode does not follow the wall clock."""

    def tick(self) -> None:
        _timed_tick(self.node, self._advance)

    def _advance(self) -> None:
        node = self.node
        node.clock.tick(time.monotonic(), node.sim.t)
        if not node.run.running():
            return
        end = time.perf_counter() + 0.01
        while time.perf_counter() < end:
            if not node.run.step_once():
                break
        node.outputs.publish_clock()


class LockstepPacing:
    """One control period per ``heave_force`` message, after the controller is connected."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.steps_per_control = node.steps_per_control
        self.started = False
        self.queue: deque[float] = deque()
        self.pending_wave: float | None = None
        self._peers_since: float | None = None
        self._waiting_since = time.monotonic()
        self._start_timer = node.create_timer(0.05, self.try_start)

    def rebase(self, now: float) -> None:
        """Nothing to re-pace: lockstep follows the controller."""

    def clear(self) -> None:
        """Drop queued inputs (reset)."""
        self.queue.clear()
        self.pending_wave = None

    def try_start(self) -> None:
        """Lockstep start: publish joint_states(t0) once a controller is connected both ways.

        A message published before the subscriber is matched is lost, and the controller would
        wait for it forever; so the node waits until ``joint_states`` has a subscriber and
        ``heave_force`` a publisher, for 0.5 s (both directions of discovery), then publishes
        the state at t = 0 and advances one control period per ``heave_force`` message after it.
        """
        node = self.node
        now = time.monotonic()
        if (node.outputs.pub["joint_states"].get_subscription_count() == 0
                or node.inputs.sub_heave_force.get_publisher_count() == 0):
            self._peers_since = None
            if now - self._waiting_since > 5.0:
                node.get_logger().warning(
                    "lockstep: waiting for a controller (a subscriber of joint_states and a "
                    "publisher of heave_force)", throttle_duration_sec=10.0)
            return
        if self._peers_since is None:
            self._peers_since = now
        if now - self._peers_since < 0.5:
            return
        self._start_timer.cancel()
        self.started = True
        node.outputs.publish_clock()
        node.outputs.publish_joint_states()
        node.get_logger().info("lockstep: controller connected; published joint_states at "
                               f"t = {node.sim.t:g} s, advancing one control period per heave_force")

    def on_heave_force(self, value: float) -> None:
        """An accepted heave force: held before the start, else queued and advanced."""
        sim = self.node.sim
        if not self.started:  # before joint_states(t0): held, advances nothing
            if value != sim.held_heave_force:
                sim.set_heave_force(value)
                self.node.outputs.publish_applied()
            return
        self.queue.append(value)
        self.advance()

    def advance(self) -> None:
        """Advance one control period per queued heave force (while running)."""
        node, sim = self.node, self.node.sim
        node.clock.sample(time.monotonic(), sim.t)
        while self.queue and node.run.running():
            value = self.queue.popleft()
            changed = value != sim.held_heave_force
            sim.set_heave_force(value)
            if self.pending_wave is not None:
                changed |= self.pending_wave != sim.held_wave_elevation
                sim.set_wave_elevation(self.pending_wave)
                self.pending_wave = None
            if changed:
                node.outputs.publish_applied()
            for _ in range(self.steps_per_control):
                if not node.run.step_once():
                    return
            node.outputs.publish_clock()
            node.outputs.publish_joint_states()


PACING = {"realtime": RealtimePacing, "fast": FastPacing, "lockstep": LockstepPacing}
