"""The benchmark: it runs episodes and computes every number the results and plots show.

In layers, each importing only those before it (tests/test_architecture.py):

    episodes/        one episode: runner, plugins (users' controllers), metrics, futures,
                     reachability, snapshot (one step of every controller)
    experiments/     the TOML definitions of experiments and their checks
    results/         the SQLite database, provenance, statistics
    runs/            many episodes into a database (processes or Ray), replay, the gallery
    reports/         tables, CSV, plots, `dcmppi outcomes`
    timing/          `dcmppi timing`: speed, profiles, fingerprints, the pytorch_mppi peer

May import dcmppi.control, dcmppi.tasks and dcmppi.render. Nothing in dcmppi.control,
dcmppi.tasks or dcmppi.render imports it.
"""
