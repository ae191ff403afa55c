"""Running: a composed config to a run directory (single runs, jobs, ensembles, grids,
sweeps and their aggregation, the figure process)."""
