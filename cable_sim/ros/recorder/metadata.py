"""Metadata records of a run (scene as JSON, integrator, clock mode, package version).

May import only the standard library (numpy lazily, to encode its scalars and arrays).
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from typing import Any


def _str_dict(data: dict[str, Any]) -> dict[str, str]:
    return {str(k): str(v) for k, v in data.items()}



def run_metadata(
    scene_values: dict[str, Any], *, kernel: str, integrator: str, step: float, n_links: int,
    clock_mode: str, start: datetime | None = None, node: str | None = None,
) -> dict[str, dict[str, str]]:
    """The ``"scene"`` and ``"run"`` metadata records of the shared recording format.

    ``node`` (the recording node's fully qualified name, e.g. ``/leg1/cable_sim_node``) is
    stored as ``run["node"]`` when given.
    """
    version = package_version()
    start = start or datetime.now(UTC)
    run = {
        "kernel": str(kernel), "integrator": str(integrator), "step": repr(float(step)),
        "n_links": str(int(n_links)), "clock_mode": str(clock_mode),
        "start_wall_time_iso": start.isoformat(), "cable_sim_version": str(version),
    }
    if node is not None:
        run["node"] = str(node)
    return {
        "scene": {"json": json.dumps(scene_values, default=_json_default, sort_keys=True)},
        "run": run,
    }


def package_version() -> str:
    """Installed cable_sim version (``"unknown"`` when not installed)."""
    try:
        from importlib.metadata import PackageNotFoundError, version

        return version("cable_sim")
    except (ImportError, PackageNotFoundError):
        return "unknown"


def _json_default(o: Any) -> Any:
    try:
        import numpy as np

        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    return str(o)
