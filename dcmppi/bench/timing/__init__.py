"""`dcmppi timing`: median controller time per control step on fixed problems.

Problems (deterministic, the tasks' worlds drawn by their generators with seed 0 (`worlds`), the
defaults K = 500, N = 50); every act() sees what the task would observe, map bounds included:
- forest: the forest task's world (clusters of overlapping cylinders over 75 x 50 m, start and
  goal >= 30 m apart); `mppi`, `clustered` and `tube` drive the analytic model across it.
- forest+push (tube): the same, but after every step the real state is pushed along and across
  its heading and turned by a fixed seeded offset sequence (`push`, zero mean), so Tube-MPPI's
  nominal state differs from the real one: every step rolls out both (2K rollouts), and with
  reset_threshold = 0 the nominal is kept whenever the push set the real state back (most
  steps) and the LQR feedback runs too: Tube-MPPI's most expensive step. Without the push
  the nominal equals the real state after every reset, so one batch of K rollouts suffices and
  the feedback is zero.
- crowd: the crowd task's world, 100 moving cylinders moving as in the task (exact Dubins arcs,
  reflecting off the walls); `dc` with P = 25 (and the others for reference).
- corridor, crowd-sf: the corridor task's world (12 social-force pedestrians, its
  walls as static cylinder rows) and the crowd task's with behavior "social_force" (100
  walkers), the pedestrians (tasks.pedestrians.walkers) built and advanced once per control
  period as the task does, act() given their observed velocities (moving_velocity) too; the
  holonomic robot with the pedestrian experiments' shared parameters, `dc` with each predictor
  (prior, cv, social) and `mppi` for reference.
BLAS and OpenMP pools are limited to one thread; the figures are for one core. The cases of a
problem run interleaved in blocks of consecutive steps, so load changes on a shared machine hit
them alike.

`--against pytorch_mppi [--K K] [--N N]` times our mppi beside pytorch_mppi on the forest at that
size (dcmppi.bench.timing.peer), with `--threads T` also ours on T threads and what T threads at
once gain on this machine in a scalar, a vector and a streaming kernel (`cores`); `--scaling` the
controllers as K, N, the cylinders, the moving obstacles and P grow one at a time (`scaling`);
`--profile EXPERIMENT` where an experiment's bench episodes spend their time, end to end
(`episodes`).

Modules: `worlds` (the problems), `cases` (the table's rows and the variants), `loop` (a timed
closed loop, interleaved timing), `profile` (`--profile`, through the controllers' timer hook),
`episodes` (`--profile EXPERIMENT`: bench episodes, dcmppi.bench.episodes.runner's, end to end),
`fingerprint` (`--fingerprint`), `cores` (the machine's gains from threads), `scaling`
(`--scaling`: the curves, their fits and plot), `cli` (what each mode runs and prints; the
options are dcmppi.cli.timing's, a subcommand of the one `dcmppi` parser). May import
dcmppi.control, the tasks' world generators (dcmppi.tasks.worlds), their pedestrians and task
classes (for the pedestrian problems' worlds and next goals), dcmppi.bench.timing.peer,
dcmppi.bench's runner, results and experiments (the episode profile), and dcmppi.render (the
scaling plot, given plain numbers); never the command line (dcmppi.cli), which imports it.
"""

from dcmppi.bench.timing.worlds import forest, push, pushed

__all__ = ["forest", "push", "pushed"]
