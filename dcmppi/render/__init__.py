"""Pictures: offscreen videos, controller overlays, side-by-side recordings, the paper's figures.

May import dcmppi.control and dcmppi.tasks; never dcmppi.bench. Episodes come in as objects
(dcmppi.bench.runner.Episode or anything with its attributes), so the benchmark drives them.
"""
