"""``line_tension_rate``: the n link tensions at their own rate (issue 13, "publish large arrays at
their own rates").

The node runs as a subprocess (installed console script) on ``mooring_line`` in fast clock mode,
recording, for 2 s of simulated time; the recording is decoded with rosbags. The expected times
are the simulated-time grid of each rate (every 1 / rate seconds from t = 0), which the test
derives from the rates it passes, not from the node.
"""

from __future__ import annotations

from pathlib import Path

from ros_util import isolate_ros, run_to_end
from rosbags.highlevel import AnyReader

DOMAIN = isolate_ros()
ROOT = Path(__file__).resolve().parents[2]
DURATION = 2.0


def _times(path: Path) -> dict[str, list[int]]:
    """Log times [ns] per topic."""
    out: dict[str, list[int]] = {}
    with AnyReader([path]) as r:
        for c, t, _raw in r.messages():
            out.setdefault(c.topic, []).append(t)
    return out


def _run(path: Path, *params: str) -> dict[str, list[int]]:
    run_to_end("mooring_line", "clock_mode:=fast", f"duration:={DURATION}", "exit_at_end:=true",
               f"record_path:={path}", "tension_rate:=20.0", *params, domain=DOMAIN, cwd=ROOT,
               timeout=180)
    return _times(path)


def _on_grid(times: list[int], period_ns: int) -> bool:
    return all(t % period_ns == 0 for t in times)


def test_line_tension_at_its_own_rate(tmp_path):
    times = _run(tmp_path / "slow.mcap", "line_tension_rate:=2.0")
    fair, line = times["/fairlead_tension"], times["/line_tension"]
    assert _on_grid(fair, 50_000_000) and _on_grid(line, 500_000_000)
    # every 0.5 s of the fairlead tension's 50 ms grid, and nothing else
    assert line == [t for t in fair if t % 500_000_000 == 0]
    assert len(line) >= int(DURATION / 0.5)
    assert len(fair) >= int(DURATION / 0.05)


def test_line_tension_with_the_tensions_by_default(tmp_path):
    times = _run(tmp_path / "default.mcap")
    assert times["/line_tension"] == times["/fairlead_tension"]
    assert _on_grid(times["/line_tension"], 50_000_000)
    assert len(times["/line_tension"]) >= int(DURATION / 0.05)
