"""Study file: a base scene, the cases (a grid and/or a list over scene keys) and the analysis settings.

A study file (YAML)::

    name: example
    base_scene: mooring_line          # a scene name or a path (relative to the study file)
    overrides: {n_links: 20, wave_source: jonswap}   # applied to every case
    grid:                              # cartesian product over scene keys
      wave_hs: [2.0, 4.0]
      wave_tp: [8.0, 11.0]
      wave_seed: [1, 2]
    cases:                             # and/or an explicit list (each entry: key -> value)
      - {wave_hs: 6.0, wave_tp: 12.0, wave_seed: 1}
    duration: 120.0                    # simulated time per case [s]
    transient: 20.0                    # start-up time discarded from statistics [s]
    output_interval: 0.1               # tension sampling interval [s]
    tn_curve: {type: studless_chain, nominal_diameter: 0.076}   # or a_d / m explicitly
    sea_state_keys: [wave_hs, wave_tp, wave_gamma]   # grouping for the extremes table
    record_mcap: []                    # case ids (or "all") to record as MCAP (node format)

Each case has a stable id: the first 16 hex digits of the SHA-256 of the canonical JSON of its
fully resolved scene key/values plus ``duration``, ``transient`` and ``output_interval``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from cable_sim.core.params import CableParams, ParameterError
from cable_sim.scene.scenes import SIM_DEFAULTS, read_parameter_file, scene_path

from .fatigue import TNCurve, tn_curve_from_dict

#: Scene keys read by the built-in input signals (cable_sim.core.inputs.make_signal), besides the
#: scene file's.
SIGNAL_KEYS = tuple(f"{p}_{k}" for p in ("wave", "heave_force")
                    for k in ("hs", "tp", "gamma", "seed", "ramp", "amplitude", "period", "phase", "value"))

#: Keys a study file may have.
STUDY_KEYS = ("name", "base_scene", "overrides", "grid", "cases", "duration", "transient",
              "output_interval", "tn_curve", "sea_state_keys", "record_mcap", "description")


class StudyError(ParameterError):
    """A study setting is outside its allowed range (names key, value and allowed range)."""


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def stable_hash(obj: Any, n: int = 16) -> str:
    """First ``n`` hex digits of the SHA-256 of the canonical JSON of ``obj``."""
    return hashlib.sha256(_canonical(obj).encode()).hexdigest()[:n]


@dataclass(frozen=True)
class Case:
    """One case of a study.

    Attributes
    ----------
    index : int
        Position in the study's case order.
    inputs : dict
        The keys varied by the study (grid and list entries) and their values.
    scene_values : dict
        Fully resolved flat scene key/values (base file + overrides + inputs).
    case_id : str
        Stable hash of the case's inputs (see module docstring).
    scene_hash : str
        Stable hash of ``scene_values`` alone.
    """

    index: int
    inputs: dict[str, Any]
    scene_values: dict[str, Any]
    case_id: str
    scene_hash: str


@dataclass
class Study:
    """A parsed, validated study.

    Attributes
    ----------
    name : str
        Study name.
    base_scene : str
        Scene name or path to its YAML file.
    overrides : dict
        Scene keys applied to every case.
    grid : dict
        Scene key -> list of values (cartesian product).
    case_list : list of dict
        Explicit cases (scene key -> value), run after the grid.
    duration, transient, output_interval : float
        Simulated time, discarded start-up and tension sampling interval [s].
    tn_curve : TNCurve
        T-N curve for the fatigue damage.
    sea_state_keys : list of str
        Inputs that define a sea state (extremes are grouped over the others, e.g. seeds).
    record_mcap : list of str
        Case ids to record as MCAP (``["all"]`` for all).
    """

    name: str
    base_scene: str
    overrides: dict[str, Any] = field(default_factory=dict)
    grid: dict[str, list[Any]] = field(default_factory=dict)
    case_list: list[dict[str, Any]] = field(default_factory=list)
    duration: float = 60.0
    transient: float = 0.0
    output_interval: float = 0.1
    tn_curve: TNCurve = field(default_factory=lambda: tn_curve_from_dict({}))
    sea_state_keys: list[str] = field(default_factory=lambda: ["wave_hs", "wave_tp", "wave_gamma"])
    record_mcap: list[str] = field(default_factory=list)

    def base_values(self) -> dict[str, Any]:
        """Flat key/values of the base scene file with the study's overrides applied."""
        values = read_parameter_file(scene_path(self.base_scene))
        values.update(self.overrides)
        return values

    def cases(self) -> list[Case]:
        """All cases, grid first (last key fastest), then the list."""
        base = self.base_values()
        keys = list(self.grid)
        combos = [dict(zip(keys, vals, strict=True))
                  for vals in itertools.product(*(self.grid[k] for k in keys))]
        if not keys:
            combos = []
        combos += [dict(c) for c in self.case_list]
        if not combos:
            combos = [{}]
        out = []
        for i, inputs in enumerate(combos):
            values = {**base, **inputs}
            scene_hash = stable_hash(values)
            cid = stable_hash({"scene": values, "duration": self.duration, "transient": self.transient,
                               "output_interval": self.output_interval})
            out.append(Case(i, inputs, values, cid, scene_hash))
        ids = [c.case_id for c in out]
        if len(set(ids)) != len(ids):
            dup = sorted({i for i in ids if ids.count(i) > 1})
            raise StudyError("cases", dup, "distinct cases (two cases resolve to the same inputs)")
        return out

    def input_keys(self) -> list[str]:
        """Keys varied by the study, in first-seen order."""
        keys = list(self.grid)
        for c in self.case_list:
            keys += [k for k in c if k not in keys]
        return keys


def _known_keys(base: dict[str, Any]) -> set[str]:
    return set(CableParams.field_names()) | set(SIM_DEFAULTS) | set(SIGNAL_KEYS) | set(base)


def _scalar(key: str, v: Any) -> Any:
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return v
    if isinstance(v, int):
        return v
    if isinstance(v, float):
        if not math.isfinite(v):
            raise StudyError(key, v, "a finite number")
        return v
    raise StudyError(key, v, "a scalar (number, string or bool)")


def _positive(d: dict[str, Any], key: str, default: float, allow_zero: bool = False) -> float:
    v = d.get(key, default)
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    if not ok or v < 0 or (v == 0 and not allow_zero):
        raise StudyError(key, v, "a finite number " + (">= 0" if allow_zero else "> 0") + " [s]")
    return float(v)


def study_from_dict(d: dict[str, Any], base_dir: Path | None = None) -> Study:
    """Validate a study mapping and build a :class:`Study`.

    Parameters
    ----------
    d : dict
        The parsed study file.
    base_dir : Path, optional
        Directory the study file lives in (a relative ``base_scene`` path is resolved from it).

    Raises
    ------
    StudyError
        For an unknown key, a bad value or an inconsistent setting (names key, value, allowed range).
    """
    if not isinstance(d, dict):
        raise StudyError("study", type(d).__name__, "a mapping of study keys")
    for k in d:
        if k not in STUDY_KEYS:
            raise StudyError(k, d[k], "not a study key; allowed: " + ", ".join(STUDY_KEYS))
    base_scene = d.get("base_scene")
    if not isinstance(base_scene, str) or not base_scene:
        raise StudyError("base_scene", base_scene, "a scene name or a path to a scene YAML file")
    if base_dir is not None and base_scene.endswith((".yaml", ".yml")):
        p = Path(base_scene)
        if not p.is_absolute() and (base_dir / p).exists():
            base_scene = str(base_dir / p)
    try:
        base = read_parameter_file(scene_path(base_scene))
    except FileNotFoundError as exc:
        raise StudyError("base_scene", base_scene, "an existing scene name or file") from exc
    known = _known_keys(base)

    def check_keys(section: str, mapping: Any) -> dict[str, Any]:
        if not isinstance(mapping, dict):
            raise StudyError(section, mapping, "a mapping scene key -> value")
        for k in mapping:
            if k not in known:
                raise StudyError(f"{section}.{k}", mapping[k],
                                 "a scene key (CableParams field, simulation key, input-signal key or "
                                 "a key of the base scene)")
        return mapping

    overrides = {k: _scalar(f"overrides.{k}", v)
                 for k, v in check_keys("overrides", d.get("overrides") or {}).items()}
    grid_in = check_keys("grid", d.get("grid") or {})
    grid: dict[str, list[Any]] = {}
    for k, vals in grid_in.items():
        if not isinstance(vals, list) or not vals:
            raise StudyError(f"grid.{k}", vals, "a non-empty list of values")
        grid[k] = [_scalar(f"grid.{k}", v) for v in vals]
    raw_cases = d.get("cases") or []
    if not isinstance(raw_cases, list):
        raise StudyError("cases", raw_cases, "a list of mappings scene key -> value")
    case_list = []
    for i, c in enumerate(raw_cases):
        c = check_keys(f"cases[{i}]", c)
        case_list.append({k: _scalar(f"cases[{i}].{k}", v) for k, v in c.items()})
    duration = _positive(d, "duration", 60.0)
    transient = _positive(d, "transient", 0.0, allow_zero=True)
    if transient >= duration:
        raise StudyError("transient", transient, f"0 <= transient < duration = {duration} [s]")
    interval = _positive(d, "output_interval", 0.1)
    if interval > duration - transient:
        raise StudyError("output_interval", interval,
                         f"0 < output_interval <= duration - transient = {duration - transient} [s]")
    tn = tn_curve_from_dict(d.get("tn_curve") or {})
    ssk = d.get("sea_state_keys", ["wave_hs", "wave_tp", "wave_gamma"])
    if not isinstance(ssk, list) or not all(isinstance(k, str) for k in ssk):
        raise StudyError("sea_state_keys", ssk, "a list of scene keys")
    rec = d.get("record_mcap") or []
    if rec == "all":
        rec = ["all"]
    if not isinstance(rec, list):
        raise StudyError("record_mcap", rec, "'all' or a list of case ids")
    name = str(d.get("name") or Path(base_scene).stem)
    return Study(name, base_scene, overrides, grid, case_list, duration, transient, interval, tn,
                 list(ssk), [str(r) for r in rec])


def load_study(path: str | Path) -> Study:
    """Read and validate a study YAML file (see the module docstring for the format)."""
    path = Path(path)
    try:
        d = yaml.safe_load(path.read_text())
    except FileNotFoundError as exc:
        raise StudyError("study", str(path), "an existing study YAML file") from exc
    return study_from_dict(d, base_dir=path.resolve().parent)


__all__ = ["Study", "Case", "StudyError", "study_from_dict", "load_study", "stable_hash"]
