"""``cable_sim_batch STUDY.yaml --out DIR [--scheduler ADDRESS | --workers N] [--serial]``."""

from __future__ import annotations

import argparse
import sys

from cable_sim.core.params import ParameterError

from .engine import run_study
from .study import load_study


def main(argv: list[str] | None = None) -> int:
    """Run a study from the command line; returns the exit code (2 for a bad study file)."""
    ap = argparse.ArgumentParser(prog="cable_sim_batch", description=__doc__)
    ap.add_argument("study", help="study YAML file")
    ap.add_argument("--out", required=True, help="output directory (resumable)")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--scheduler", help="address of an existing Dask scheduler, e.g. tcp://host:8786")
    g.add_argument("--workers", type=int, help="worker processes of the local cluster (default: CPUs)")
    g.add_argument("--serial", action="store_true", help="run in this process, no Dask")
    ap.add_argument("--no-plots", action="store_true", help="skip the plots")
    ap.add_argument("--max-cases", type=int, help="stop after this many new cases (partial run)")
    args = ap.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        ap.error(f"--workers = {args.workers}: must be an integer >= 1")
    try:
        study = load_study(args.study)
    except ParameterError as exc:
        print(f"cable_sim_batch: {exc}", file=sys.stderr)
        return 2
    path = run_study(study, args.out, scheduler=args.scheduler, workers=args.workers, serial=args.serial,
                     plots=not args.no_plots, max_cases=args.max_cases)
    from .engine import read_table

    rows = read_table(path)
    n_err = sum(r["status"] != "ok" for r in rows)
    print(f"{len(rows)} of {len(study.cases())} cases in {path} ({n_err} failed)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
