"""Pictures: offscreen videos, controller overlays, side-by-side recordings, the paper's figures.

May import dcmppi.control and dcmppi.tasks; never dcmppi.bench. Episodes come in as objects
(dcmppi.bench.runner.Episode or anything with its attributes), so the benchmark drives them.
"""

# The cameras of dcmppi.render.video (here so that the command line lists them without
# importing MuJoCo): the region of start, goal and obstacles between, the whole map, behind
# the robot.
CAMERAS = ("scene", "top", "chase")
