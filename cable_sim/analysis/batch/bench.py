"""Scaling benchmark: cases per minute of a study with 1 and 2 Dask workers (LocalCluster).

``python -m cable_sim.analysis.batch.bench [--study FILE] [--workers 1 2] [--out results/batch]``
writes ``scaling.csv`` and ``scaling.png``. Each worker count gets a fresh cluster; every worker
first runs a short warm-up case (imports, numba cache load), then the study's cases are timed
from the first submit to the last row written (``steady``), and the whole ``run_study`` call
including cluster start-up is reported too (``total``). ``mean_case_wall_s`` (time inside a case)
and ``worker_busy_fraction`` separate scheduling overhead from CPU contention by other processes
(the machine's 1-minute load average is recorded with each figure).
"""

from __future__ import annotations

import argparse
import csv
import os
import tempfile
import time
from pathlib import Path

from .case import case_spec, run_case
from .engine import read_table, run_study
from .study import load_study

REPO = Path(__file__).resolve().parents[3]


def _warm(client, study) -> None:
    case = study.cases()[0]
    spec = dict(case_spec(study, case), duration=1.0, transient=0.0, output_interval=0.5)
    client.run(run_case, spec)  # once on every worker


def measure(study_file: Path, workers: int) -> dict[str, float]:
    """Time the study on a fresh ``workers``-process LocalCluster; returns the figures."""
    from dask.distributed import Client, LocalCluster

    study = load_study(study_file)
    n = len(study.cases())
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        try:
            with Client(cluster) as client:
                _warm(client, study)
            t1 = time.perf_counter()
            path = run_study(study, tmp, scheduler=cluster.scheduler_address, progress=False, plots=False)
            t2 = time.perf_counter()
            busy = sum(r["wall_time"] for r in read_table(path))
        finally:
            cluster.close()
    return {"workers": workers, "cases": n, "steady_s": t2 - t1, "total_s": t2 - t0,
            "cases_per_min": 60.0 * n / (t2 - t1), "cases_per_min_total": 60.0 * n / (t2 - t0),
            "mean_case_wall_s": busy / n, "worker_busy_fraction": busy / (workers * (t2 - t1)),
            "load_avg_1min": os.getloadavg()[0]}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and write CSV + plot."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", default=str(REPO / "config" / "studies" / "example_study.yaml"))
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--out", default=str(REPO / "results" / "batch"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for w in args.workers:
        r = measure(Path(args.study), w)
        rows.append(r)
        print(", ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()))
    base = rows[0]["cases_per_min"]
    for r in rows:
        r["speedup"] = r["cases_per_min"] / base
    with open(out / "scaling.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.5, 3.5))
    ws = [r["workers"] for r in rows]
    ax.plot(ws, [r["cases_per_min"] for r in rows], "o-", label="steady (workers warm)")
    ax.plot(ws, [r["cases_per_min_total"] for r in rows], "s--", label="incl. cluster start-up")
    ax.plot(ws, [base * w for w in ws], ":", color="gray", label="ideal")
    ax.set_xlabel("Dask workers (1 thread each)")
    ax.set_ylabel("cases per minute")
    ax.set_xticks(ws)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "scaling.png", dpi=120)
    print(f"wrote {out / 'scaling.csv'} and {out / 'scaling.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
