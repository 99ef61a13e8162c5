"""cable_sim: a real-time submerged cable (mooring line, umbilical) for ROS 2.

Layers, lowest first (see the README's layout table): :mod:`cable_sim.core`,
:mod:`cable_sim.integrate`, :mod:`cable_sim.scene`, :mod:`cable_sim.ros`, :mod:`cable_sim.analysis`.

Importing the package points numba's on-disk cache at a folder keyed by this copy's path and
the text of every compiled module: numba checks only the file a function is defined in, so after
an edit of a shared sweep a function inlining it from another file would otherwise keep running
the old code from the cache. ``NUMBA_CACHE_DIR`` set by the user wins (numba reads it when it is
first imported, which is after this). Each import marks its folder as used; folders of other
versions unused for :data:`STALE_CACHE_DAYS` days are removed then (one per code change would
otherwise pile up, 5-10 MB each).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import time
from pathlib import Path

#: Days after which the numba cache folder of another version of the package is removed.
STALE_CACHE_DAYS = 14.0

#: Hex digits of the cache folder's name (the key of :func:`_numba_cache_dir`).
_KEY_DIGITS = 16


def _numba_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/cable_sim/numba/<hash>`` (default ``~/.cache``), the hash covering this
    package's location and every module that uses numba."""
    root = Path(__file__).resolve().parent
    digest = hashlib.sha256(str(root).encode())
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text:
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(text)
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "cable_sim" / "numba" / digest.hexdigest()[:_KEY_DIGITS]


def _prune_stale_caches(chosen: Path, max_age_s: float, now: float | None = None) -> list[Path]:
    """Mark ``chosen`` as used (its modification time) and remove the sibling cache folders
    (named like :func:`_numba_cache_dir`'s) unused for longer than ``max_age_s`` seconds.

    Returns the folders removed. Errors (a folder removed by another process, permissions) are
    ignored: the cache only saves compile time, and numba recreates a missing folder.
    """
    now = time.time() if now is None else now
    removed: list[Path] = []
    try:
        chosen.mkdir(parents=True, exist_ok=True)
        os.utime(chosen, (now, now))
        siblings = list(chosen.parent.iterdir())
    except OSError:
        return removed
    for other in siblings:
        if other == chosen or not re.fullmatch(f"[0-9a-f]{{{_KEY_DIGITS}}}", other.name):
            continue
        try:
            if other.is_dir() and now - other.stat().st_mtime > max_age_s:
                shutil.rmtree(other)
                removed.append(other)
        except OSError:
            continue
    return removed


#: Marks a NUMBA_CACHE_DIR this package chose (a child process running another copy of the
#: package, e.g. a test's installed node, chooses its own instead of inheriting it).
_AUTO = "CABLE_SIM_NUMBA_CACHE_AUTO"

if not os.environ.get("NUMBA_CACHE_DIR") or os.environ.get(_AUTO) == os.environ["NUMBA_CACHE_DIR"]:
    _chosen = _numba_cache_dir()
    os.environ["NUMBA_CACHE_DIR"] = os.environ[_AUTO] = str(_chosen)
    _prune_stale_caches(_chosen, STALE_CACHE_DAYS * 86400.0)
