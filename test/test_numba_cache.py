"""The numba cache folder chosen on import (``cable_sim/__init__.py``): keyed by the compiled
modules' text, and the folders of other versions unused for two weeks removed."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import cable_sim
from cable_sim import _numba_cache_dir, _prune_stale_caches

DAY = 86400.0


def _folder(base: Path, name: str, age_days: float, now: float) -> Path:
    p = base / name
    (p / "sub").mkdir(parents=True)
    (p / "sub" / "f.nbi").write_bytes(b"x")
    os.utime(p, (now - age_days * DAY, now - age_days * DAY))
    return p


def test_stale_sibling_folders_are_removed_and_the_chosen_one_marked(tmp_path: Path) -> None:
    now = 2_000_000_000.0
    chosen = _folder(tmp_path, "0123456789abcdef", 30.0, now)  # old, but in use: kept
    old = _folder(tmp_path, "fedcba9876543210", 15.0, now)
    recent = _folder(tmp_path, "00000000000000aa", 13.0, now)
    foreign = _folder(tmp_path, "not-a-cache-dir", 400.0, now)  # not named like ours: kept
    removed = _prune_stale_caches(chosen, 14.0 * DAY, now=now)
    assert removed == [old]
    assert not old.exists()
    assert recent.exists() and foreign.exists() and (chosen / "sub" / "f.nbi").exists()
    assert chosen.stat().st_mtime == now


def test_a_missing_chosen_folder_is_created(tmp_path: Path) -> None:
    chosen = tmp_path / "numba" / "0123456789abcdef"
    assert _prune_stale_caches(chosen, 14.0 * DAY) == []
    assert chosen.is_dir()


def test_key_changes_with_the_text_of_a_compiled_module(tmp_path: Path, monkeypatch) -> None:
    """A copy of the package gets another key than the tree; editing one of its numba modules
    changes the key again, editing a module without numba does not."""
    src = Path(cable_sim.__file__).resolve().parent
    copy = tmp_path / "cable_sim"
    shutil.copytree(src, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    k_tree = _numba_cache_dir()
    monkeypatch.setattr(cable_sim, "__file__", str(copy / "__init__.py"))
    k0 = _numba_cache_dir()
    assert k0.parent == tmp_path / "cache" / "cable_sim" / "numba"
    assert k0.name != k_tree.name and len(k0.name) == 16
    plain = copy / "core" / "params.py"
    assert b"numba" not in plain.read_bytes()
    plain.write_text(plain.read_text() + "\n# edited\n")
    assert _numba_cache_dir() == k0
    compiled = copy / "core" / "kernel" / "sweeps.py"
    assert b"numba" in compiled.read_bytes()
    compiled.write_text(compiled.read_text() + "\n# edited\n")
    assert _numba_cache_dir() != k0
