"""Batch engine: serial == 2-worker Dask == direct Simulation; resume after a killed driver; faults."""

from __future__ import annotations

import functools
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from cable_sim.analysis.batch.case import SIMULATED_COLUMNS, run_case
from cable_sim.analysis.batch.engine import read_table, run_study
from cable_sim.analysis.batch.study import load_study, study_from_dict
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

REPO = Path(__file__).resolve().parents[2]

SMALL = {
    "name": "small", "base_scene": "mooring_line",
    "overrides": {"n_links": 12, "wave_source": "jonswap", "wave_ramp": 5.0},
    "grid": {"wave_hs": [2.0, 4.0], "wave_seed": [1, 2]},
    "duration": 20.0, "transient": 5.0, "output_interval": 0.1,
    "tn_curve": {"type": "studless_chain", "nominal_diameter": 0.076},
    "sea_state_keys": ["wave_hs"],
}


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


@pytest.fixture(scope="module")
def cluster():
    """A 2-worker LocalCluster shared by the Dask tests (closed at the end)."""
    from dask.distributed import LocalCluster

    c = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    try:
        yield c
    finally:
        c.close()


@pytest.fixture(scope="module")
def serial_rows(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    run_study(study_from_dict(SMALL), out, serial=True, progress=False, plots=True)
    assert (out / "plots" / "max_tension_heatmap.png").exists() is False  # no wave_tp in this grid
    assert (out / "plots" / "exceedance.png").exists()
    return read_table(out / "results.parquet")


def test_dask_equals_serial_equals_direct(cluster, serial_rows, tmp_path):
    study = study_from_dict(SMALL)
    run_study(study, tmp_path, scheduler=cluster.scheduler_address, progress=False, plots=False)
    dask_rows = read_table(tmp_path / "results.parquet")
    assert [r["case_id"] for r in dask_rows] == [c.case_id for c in study.cases()]
    assert all(r["status"] == "ok" for r in dask_rows)
    for a, b in zip(serial_rows, dask_rows, strict=True):
        for col in SIMULATED_COLUMNS:
            assert _same(a[col], b[col]), (a["case_id"], col, a[col], b[col])
    # each row against a direct Simulation run of the case (written here, not via case.py)
    for case, row in zip(study.cases(), dask_rows, strict=True):
        sim = Simulation(load_scene("mooring_line", {**SMALL["overrides"], **case.inputs}))
        fair, anch = [], []
        for k in range(201):
            sim.run_until(k * 0.1)
            if k * 0.1 >= 5.0 - 1e-9:
                o = sim.outputs()
                fair.append(o.fairlead_tension)
                anch.append(float(np.hypot(*o.anchor_force)))
        assert row["n_samples"] == len(fair) == 151
        assert row["fairlead_max"] == max(fair)
        assert row["anchor_max"] == max(anch)
        assert row["fairlead_mean"] == float(np.mean(fair))
        assert row["anchor_std"] == float(np.std(anch))


def kill_worker_once(spec, marker: str):
    """Case runner that kills its own worker process the first time it meets case index 1."""
    if spec["index"] == 1 and not Path(marker).exists():
        Path(marker).write_text(str(os.getpid()))
        os._exit(1)
    return run_case(spec)


def test_worker_killed_mid_study_keeps_its_case(cluster, serial_rows, tmp_path):
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    marker = tmp_path / "killed"
    out = tmp_path / "out"
    run_study(study_from_dict(SMALL), out, scheduler=cluster.scheduler_address, progress=False,
              plots=False, case_fn=functools.partial(kill_worker_once, marker=str(marker)))
    assert marker.exists()  # a worker process really died
    rows = read_table(out / "results.parquet")
    assert len(rows) == len(serial_rows)
    for a, b in zip(serial_rows, rows, strict=True):
        assert all(_same(a[col], b[col]) for col in SIMULATED_COLUMNS)


def raise_on_case_0(spec):
    """Case runner whose task itself fails for case 0 (as a task lost beyond its retries would)."""
    if spec["index"] == 0:
        raise RuntimeError("task failed on purpose")
    return run_case(spec)


def test_failed_task_becomes_error_row(cluster, tmp_path):
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    d = dict(SMALL, grid={"wave_hs": [2.0, 3.0]}, duration=6.0, transient=1.0)
    run_study(study_from_dict(d), tmp_path, scheduler=cluster.scheduler_address, progress=False,
              plots=False, case_fn=raise_on_case_0, retries=1)
    rows = read_table(tmp_path / "results.parquet")
    assert [r["status"] for r in rows] == ["error", "ok"]
    assert "task failed on purpose" in rows[0]["error"]


def test_resume_after_killed_driver(tmp_path):
    study_file = tmp_path / "s.yaml"
    d = dict(SMALL, grid={"wave_hs": [2.0, 3.0, 4.0], "wave_seed": [1, 2]})
    study_file.write_text(yaml.safe_dump(d))
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "cable_sim.analysis.batch.cli", str(study_file),
                             "--out", str(out), "--serial", "--no-plots"], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            preexec_fn=lambda: (signal.signal(signal.SIGINT, signal.SIG_DFL),
                                                signal.signal(signal.SIGTERM, signal.SIG_DFL)))
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and len(list((out / "cases").glob("*.json"))) < 2:
            time.sleep(0.02)
        proc.kill()
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    first = {p.name: p.stat().st_mtime_ns for p in (out / "cases").glob("*.json")}
    assert 2 <= len(first) < 6, f"driver not stopped halfway ({len(first)} of 6 cases)"
    assert not (out / "results.parquet").exists()
    study = load_study(study_file)
    run_study(study, out, serial=True, progress=False, plots=False)
    rows = read_table(out / "results.parquet")
    ids = [r["case_id"] for r in rows]
    assert ids == [c.case_id for c in study.cases()] and len(set(ids)) == 6
    for name, mtime in first.items():  # cases written before the kill were not run again
        assert (out / "cases" / name).stat().st_mtime_ns == mtime


def test_failing_cases_become_rows(tmp_path):
    d = dict(SMALL, grid={}, cases=[{"wave_hs": 2.0}, {"step": 2.0}, {"n_links": 0}])
    run_study(study_from_dict(d), tmp_path, serial=True, progress=False, plots=True)
    rows = read_table(tmp_path / "results.parquet")
    assert [r["status"] for r in rows] == ["ok", "error", "error"]
    assert "IntegrationError" in rows[1]["error"] and "step" in rows[1]["error"]
    assert rows[1]["error_time"] > 0
    assert "n_links" in rows[2]["error"] and "allowed" in rows[2]["error"]
    assert math.isnan(rows[1]["fairlead_max"])
    for r in rows:
        assert r["package_version"] and len(r["scene_hash"]) == 16 and r["wall_time"] > 0


def test_marked_case_recorded_as_mcap(tmp_path):
    from cable_sim.analysis.replay import load_run

    d = dict(SMALL, grid={"wave_hs": [2.0, 3.0]}, duration=10.0, transient=2.0)
    study = study_from_dict(d)
    first = study.cases()[0].case_id
    study = study_from_dict(dict(d, record_mcap=[first]))
    run_study(study, tmp_path, serial=True, progress=False, plots=False)
    rows = read_table(tmp_path / "results.parquet")
    assert rows[0]["mcap_error"] is None and rows[1]["mcap_path"] is None
    run = load_run(rows[0]["mcap_path"])
    assert run.t[-1] == pytest.approx(10.0)
    tr = run.fairlead.t
    rec = np.hypot(run.fairlead.v[:, 0], run.fairlead.v[:, 1])
    on_grid = (tr >= 2.0 - 1e-9) & (np.abs(tr * 10 - np.round(tr * 10)) < 1e-6)  # the row's 0.1 s samples
    assert on_grid.sum() == rows[0]["n_samples"]
    assert rec[on_grid].max() == pytest.approx(rows[0]["fairlead_max"], rel=1e-12)
    assert rec[tr >= 2.0 - 1e-9].max() >= rows[0]["fairlead_max"]
    assert not list((tmp_path / "mcap").glob(f"{rows[1]['case_id']}*"))
