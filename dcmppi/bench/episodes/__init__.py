"""One episode: a dcmppi.tasks environment driven by a controller, and what it measures.

    runner.py        EpisodeSpec, Episode, run_episode: one task, one controller, one seed
    plugins.py       controllers by name: built-ins, entry points, module:Class strings
    metrics.py       the field's per-episode metrics (clearance, jerk, path irregularity, ...)
    columns.py       every column of an episode's row, declared once; EpisodeResult
    futures.py       the moving obstacles' own futures (the oracle, reachability)
    reachability.py  which episodes an ideal robot could solve
    snapshot.py      one planning step of several controllers (paper Fig. 2 and 4)
    seeds.py         the seed of an experiment's environment i (its world, noise, sampling)

The bottom layer of dcmppi.bench: imports dcmppi.control and dcmppi.tasks only.
"""
