"""cable_sim: a real-time submerged cable (mooring line, umbilical) for ROS 2.

Layers, lowest first (see the README's layout table): :mod:`cable_sim.core`,
:mod:`cable_sim.integrate`, :mod:`cable_sim.scene`, :mod:`cable_sim.ros`, :mod:`cable_sim.analysis`.

Importing the package points numba's on-disk cache at a folder keyed by this copy's path and
the text of every compiled module: numba checks only the file a function is defined in, so after
an edit of a shared sweep a function inlining it from another file would otherwise keep running
the old code from the cache. ``NUMBA_CACHE_DIR`` set by the user wins (numba reads it when it is
first imported, which is after this).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path


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
    return base / "cable_sim" / "numba" / digest.hexdigest()[:16]


#: Marks a NUMBA_CACHE_DIR this package chose (a child process running another copy of the
#: package, e.g. a test's installed node, chooses its own instead of inheriting it).
_AUTO = "CABLE_SIM_NUMBA_CACHE_AUTO"

if not os.environ.get("NUMBA_CACHE_DIR") or os.environ.get(_AUTO) == os.environ["NUMBA_CACHE_DIR"]:
    os.environ["NUMBA_CACHE_DIR"] = os.environ[_AUTO] = str(_numba_cache_dir())
