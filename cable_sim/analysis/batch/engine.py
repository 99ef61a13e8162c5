"""Run a study's cases serially or on a Dask distributed cluster; resumable, one file per case.

Layout of the output directory::

    out/cases/<case_id>.json     one row per finished case, written atomically as it arrives
    out/results.parquet          all rows of the study, in case order (rebuilt at the end)
    out/extremes.parquet         per-sea-state Gumbel MPM table
    out/study.json               the study's settings and case ids
    out/mcap/<case_id>.mcap      recording of each case the study marks (``record_mcap``)
    out/plots/*.png              heat map, exceedance curves, damage contributions

A restarted study skips every case whose ``cases/<case_id>.json`` exists, so each case is run and
written exactly once. With Dask, each case is a task submitted with ``retries`` (an unexpected
exception is retried); a worker process that dies mid-case is detected by the scheduler, which
re-runs the task on another worker (``distributed.scheduler.allowed-failures``).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .case import case_spec, run_case
from .extremes import sea_state_table
from .study import Study


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def case_file(out: Path, case_id: str) -> Path:
    """Path of a case's row file."""
    return out / "cases" / f"{case_id}.json"


def write_row(out: Path, row: dict[str, Any]) -> Path:
    """Write one row as JSON (floats round-trip exactly; nan as NaN)."""
    p = case_file(out, row["case_id"])
    _write_atomic(p, json.dumps(row, sort_keys=True))
    return p


def read_row(path: Path) -> dict[str, Any]:
    """Read a row written by :func:`write_row`."""
    return json.loads(path.read_text())


def _columns(rows: list[dict[str, Any]]) -> dict[str, list[Any]]:
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    cols = {k: [r.get(k) for r in rows] for k in keys}
    for k, vals in cols.items():  # a column of ints and floats (e.g. nan on error rows) -> float
        kinds = {type(v) for v in vals if v is not None}
        if kinds and kinds <= {int, float} and float in kinds:
            cols[k] = [None if v is None else float(v) for v in vals]
    return cols


def write_table(path: Path, rows: list[dict[str, Any]]) -> None:
    """Write rows as one Parquet table (pyarrow)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    tmp = path.with_name(f".{path.name}.tmp")
    pq.write_table(pa.table(_columns(rows)) if rows else pa.table({}), tmp)
    os.replace(tmp, path)


def read_table(path: Path) -> list[dict[str, Any]]:
    """Rows of a Parquet table written by :func:`write_table`."""
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist()


def _progress(total: int, initial: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="case", file=sys.stderr, disable=not enabled,
                dynamic_ncols=True)


def _make_client(scheduler: str | None, workers: int | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                           processes=True, dashboard_address=None)
    return Client(cluster), cluster


def _lost_row(spec: dict[str, Any], exc: BaseException) -> dict[str, Any]:
    """Error row for a case whose task itself failed (worker lost more often than allowed)."""
    from .case import SIMULATED_COLUMNS, package_version

    row: dict[str, Any] = {"case_id": spec["case_id"], "case_index": spec["index"], **spec["inputs"]}
    row.update({c: float("nan") for c in SIMULATED_COLUMNS[4:]})
    row.update({"status": "error", "error": f"{type(exc).__name__}: {exc}", "error_time": float("nan"),
                "n_samples": 0, "wall_time": float("nan"), "sim_time": 0.0,
                "real_time_factor": float("nan"), "package_version": package_version(),
                "scene_hash": spec["scene_hash"], "host": ""})
    return row


def run_study(
    study: Study,
    out: str | Path,
    scheduler: str | None = None,
    workers: int | None = None,
    serial: bool = False,
    progress: bool = True,
    plots: bool = True,
    max_cases: int | None = None,
    case_fn: Callable[[dict[str, Any]], dict[str, Any]] = run_case,
    retries: int = 2,
) -> Path:
    """Run every case of ``study`` not yet written under ``out``; write the tables and plots.

    Parameters
    ----------
    study : Study
        The study.
    out : path
        Output directory (created).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); default: a LocalCluster.
    workers : int, optional
        Worker processes of the LocalCluster (default: the number of CPUs).
    serial : bool
        Run in this process, no Dask.
    progress : bool
        Progress bar on stderr.
    plots : bool
        Write the plots.
    max_cases : int, optional
        Stop after this many newly finished cases (a partial run; tables are still written).
    case_fn : callable
        The case runner (default :func:`~cable_sim.analysis.batch.case.run_case`).
    retries : int
        Dask retries per case.

    Returns
    -------
    Path
        ``out/results.parquet``.
    """
    out = Path(out)
    (out / "cases").mkdir(parents=True, exist_ok=True)
    cases = study.cases()
    _write_atomic(out / "study.json", json.dumps({
        "name": study.name, "base_scene": study.base_scene, "overrides": study.overrides,
        "grid": study.grid, "cases": study.case_list, "duration": study.duration,
        "transient": study.transient, "output_interval": study.output_interval,
        "tn_curve": study.tn_curve.as_dict(), "case_ids": [c.case_id for c in cases]}, indent=1))
    done = {c.case_id for c in cases if case_file(out, c.case_id).exists()}
    mcap_dir = str((out / "mcap").resolve())
    pending = [case_spec(study, c, mcap_dir) for c in cases if c.case_id not in done]
    if max_cases is not None:
        pending = pending[:max_cases]
    bar = _progress(len(cases), len(done), progress)
    try:
        if serial or not pending:
            for spec in pending:
                write_row(out, case_fn(spec))
                bar.update(1)
        else:
            from dask.distributed import as_completed

            client, cluster = _make_client(scheduler, workers)
            try:
                futures = {client.submit(case_fn, spec, key=f"case-{spec['case_id']}", pure=False,
                                         retries=retries): spec for spec in pending}
                for fut in as_completed(futures):
                    try:
                        row = fut.result()
                    except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker after repeated losses
                        row = _lost_row(futures[fut], exc)
                    write_row(out, row)
                    bar.update(1)
                    fut.release()
            finally:
                client.close()
                if cluster is not None:
                    cluster.close()
    finally:
        bar.close()
    return finalize(study, out, plots=plots)


def finalize(study: Study, out: str | Path, plots: bool = True) -> Path:
    """Combine the case files of ``study`` into results.parquet, extremes.parquet and the plots."""
    out = Path(out)
    rows = [read_row(case_file(out, c.case_id)) for c in study.cases() if case_file(out, c.case_id).exists()]
    rows.sort(key=lambda r: r["case_index"])
    path = out / "results.parquet"
    write_table(path, rows)
    keys = [k for k in study.sea_state_keys if k in study.input_keys()]
    write_table(out / "extremes.parquet", sea_state_table(rows, keys))
    if plots and rows:
        from .plots import write_plots

        write_plots(rows, keys, out / "plots")
    return path


__all__ = ["run_study", "finalize", "write_row", "read_row", "write_table", "read_table", "case_file"]
