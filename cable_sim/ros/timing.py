"""Wall-time bookkeeping of a run: tick times, time spent paused, the real-time factor.

May import numpy and the standard library.
"""

from __future__ import annotations

import math
import time
from collections import deque

import numpy as np

#: Tick wall times kept for the tick-interval diagnostics (120 s at the 50 Hz real-time tick).
TICK_HISTORY = 6000
#: Window of the reported real-time factor [s of wall time, pauses excluded].
RTF_WINDOW = 10.0
#: Interval between (wall, sim time) samples of the real-time factor [s]; RTF_SAMPLES bounds them.
RTF_SAMPLE_INTERVAL = 0.25
RTF_SAMPLES = int(RTF_WINDOW / RTF_SAMPLE_INTERVAL) + 8


class RunClock:
    """Active (not paused) wall time since the start and the real-time factor over it.

    Parameters
    ----------
    start_wall : float
        ``time.monotonic()`` at the start of the run.
    """

    def __init__(self, start_wall: float) -> None:
        self.start_wall = start_wall
        #: Wall times of the last timer ticks (bounded: memory must not grow over long runs).
        self.tick_times: deque[float] = deque(maxlen=TICK_HISTORY)
        #: Wall time spent paused [s] (finished pauses) and the start of the pause in progress.
        self.paused_wall = 0.0
        self.pause_started: float | None = None
        #: (active wall, sim time) samples for the windowed real-time factor (bounded).
        self.rtf_samples: deque[tuple[float, float]] = deque(maxlen=RTF_SAMPLES)
        self.active_base = 0.0  # active wall time at the start / the last reset

    def active_wall(self, now: float | None = None) -> float:
        """Wall time since the start [s] without the time spent paused."""
        now = time.monotonic() if now is None else now
        paused = self.paused_wall + (now - self.pause_started if self.pause_started is not None else 0.0)
        return now - self.start_wall - paused

    def tick(self, now: float, sim_t: float) -> None:
        """Record a timer tick at wall time ``now`` (simulated time ``sim_t``)."""
        self.tick_times.append(now)
        self.sample(now, sim_t)

    def sample(self, now: float, sim_t: float) -> None:
        """Add an (active wall, sim time) sample for the windowed real-time factor."""
        a = self.active_wall(now)
        if not self.rtf_samples or a - self.rtf_samples[-1][0] >= RTF_SAMPLE_INTERVAL:
            self.rtf_samples.append((a, sim_t))

    def set_paused(self, paused: bool, now: float) -> None:
        """Start (``paused``) or end a pause at wall time ``now``."""
        if paused:
            self.pause_started = now
        elif self.pause_started is not None:
            self.paused_wall += now - self.pause_started
            self.pause_started = None

    def reset(self) -> None:
        """Restart the real-time factor (simulated time starts again at 0)."""
        self.active_base = self.active_wall()
        self.rtf_samples.clear()

    def real_time_factor(self, sim_t: float, now: float | None = None) -> tuple[float, float]:
        """Real-time factor over the last :data:`RTF_WINDOW` s and since the start (or reset).

        Both are simulated time over *active* wall time: time spent paused does not count.
        Returns ``(windowed, mean)``; nan while no active wall time has passed.
        """
        now = time.monotonic() if now is None else now
        a = self.active_wall(now)
        since = a - self.active_base
        mean = sim_t / since if since > 1e-3 else math.nan
        a0, s0 = a - since, 0.0
        for aw, st in self.rtf_samples:  # oldest sample inside the window
            if a - aw <= RTF_WINDOW:
                a0, s0 = aw, st
                break
        windowed = (sim_t - s0) / (a - a0) if a - a0 > 1e-3 else mean
        return windowed, mean

    def tick_intervals(self) -> np.ndarray:
        """Intervals between the kept ticks [s] (one zero while fewer than three ticks)."""
        return np.diff(np.array(self.tick_times)) if len(self.tick_times) > 2 else np.zeros(1)


class TickProfile:
    """Where the node's wall time goes, part by part: the realtime benchmark's tick split.

    Parts (wall seconds, summed over the run): ``physics`` (integrator steps), ``outputs``
    (derived quantities of the state: tensions, positions, energy), ``messages`` (building and
    serialising the messages), ``publish`` (handing bytes to the middleware), ``record`` (handing
    them to the recorder); ``other`` is the rest of the timer ticks (pacing, executor, diagnostics).
    """

    PARTS = ("physics", "outputs", "messages", "publish", "record")

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget everything measured."""
        self.wall = dict.fromkeys(self.PARTS, 0.0)
        self.tick_wall = 0.0
        self.ticks = 0
        self.longest_tick = 0.0

    def add(self, part: str, seconds: float) -> None:
        """Count ``seconds`` of wall time to ``part`` (one of :attr:`PARTS`)."""
        self.wall[part] += seconds

    def tick(self, seconds: float) -> None:
        """Count one timer tick that took ``seconds`` of wall time in all."""
        self.tick_wall += seconds
        self.ticks += 1
        self.longest_tick = max(self.longest_tick, seconds)

    def split_us(self) -> dict[str, float]:
        """Mean wall time per tick of every part and of ``other`` [µs] (nan before a tick)."""
        if self.ticks == 0:
            return {p: math.nan for p in (*self.PARTS, "other")}
        per = {p: 1e6 * w / self.ticks for p, w in self.wall.items()}
        per["other"] = max(0.0, 1e6 * self.tick_wall / self.ticks - sum(per.values()))
        return per
