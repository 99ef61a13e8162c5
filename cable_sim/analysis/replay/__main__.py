"""``python -m cable_sim.analysis.replay``: the same as ``cable_sim_replay``."""

from .cli import main

raise SystemExit(main())
