"""The results database and what is computed from its rows.

    database.py      ResultsDB: SQLite (WAL), one row per finished episode, one per run
    provenance.py    what a run ran: code, parameters, input files, libraries, machine
    stats.py         failure rates with Wilson intervals, paired McNemar tests, medians

May import dcmppi.bench.episodes (and dcmppi.control, dcmppi.tasks); nothing that runs many
episodes or writes reports.
"""
