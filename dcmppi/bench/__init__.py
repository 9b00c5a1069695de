"""The benchmark: episodes, executors, experiments, the results database, reports, plots, timing.

Joins dcmppi.tasks (MuJoCo) with dcmppi.control; may import dcmppi.render for drawing.
Nothing in dcmppi.control or dcmppi.render imports it.
"""
