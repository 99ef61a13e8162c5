"""Batch design studies: sea states x seeds run on a Dask cluster, extreme and fatigue tension.

Modules: :mod:`.study` (study file, cases, validation), :mod:`.case` (one case headless through
:class:`cable_sim.scene.simulation.Simulation`), :mod:`.fatigue` (rainflow + Miner), :mod:`.extremes`
(peaks, most probable maximum), :mod:`.engine` (Dask / serial, resumable), :mod:`.plots`,
:mod:`.cli` (``cable_sim_batch``), :mod:`.bench` (scaling benchmark).
"""

from .engine import run_study
from .study import Study, StudyError, load_study, study_from_dict

__all__ = ["Study", "StudyError", "load_study", "study_from_dict", "run_study"]
