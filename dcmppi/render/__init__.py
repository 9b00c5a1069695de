"""Pictures: every video, figure and plot of dcmppi, drawn from what the caller hands in.

- video: offscreen MuJoCo frames of an episode to MP4 / GIF; overlay: a controller's rollouts,
  clusters, plan and obstacle futures drawn into those frames; recording: episode videos,
  side-by-side comparisons;
- figures: the paper's Fig. 2 and 4 of one planning step; plots: the report's failure rates,
  controller times and paths; ekf: the EKF error plot; draw: the matplotlib helpers they share
  (matplotlib is the optional extra `dcmppi[plots]`, imported when a plot is drawn);
- html: self-contained HTML pages (tables, the report's text, the style and scripts of web/);
  viewer: the episode viewer, a page that plays an episode in 2-D with the controller's plans,
  rollouts and predicted futures; files: output paths checked before an episode runs for them.

May import dcmppi.control and dcmppi.tasks; never dcmppi.bench (tests/test_architecture.py
checks this). The benchmark computes the numbers (summaries, paths, filter errors) and passes
them in as arrays and dicts; episodes come in as objects (dcmppi.bench.episodes.runner.Episode or
anything with its attributes).
"""

# The cameras of dcmppi.render.video (here so that the command line lists them without
# importing MuJoCo): the region of start, goal and obstacles between, the whole map, behind
# the robot.
CAMERAS = ("scene", "top", "chase")
