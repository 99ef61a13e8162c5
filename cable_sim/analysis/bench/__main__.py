"""``python -m cable_sim.analysis.bench``: the same as ``cable_sim_bench``."""

from .cli import main

raise SystemExit(main())
