"""Many episodes into a results database, and episodes rerun from one.

    execution.py     run specs in process, on worker processes or on Ray, crash-isolated
    replay.py        rerun a recorded episode from its configuration and seed; the gallery

May import dcmppi.bench's episodes, experiments and results, and dcmppi.render (videos).
"""
