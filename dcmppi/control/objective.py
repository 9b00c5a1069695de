"""The objective of one control step: what a planner minimises over a batch of rollouts.

Every state x_0 .. x_N of a rollout pays the same cost (the paper's running cost psi for
i = 0..N-1 and terminal cost phi = psi for x_N, Alg. 2; docs/design.md):

    c(x_i) = |p_i - goal| + alpha 1[x_i in the static cost map]
             + w sum_j 1[|p_i - o_j(t_i)| <= d_j]   (the moving-obstacle term)

plus, when a Pace is given, its terms for time to the goal (dcmppi.control.pace; off by default).

The static map is the planner's OccupancyGrid of the static cylinders (and the map bounds). The
tracks o_j, their distances d_j and the weight w come from the step's Prediction (a predictor's:
frozen obstacles with w = alpha, or P sampled futures per obstacle with w = beta / P).
"""

import numpy as np

from dcmppi.control.kernels.costs import TrackIndex, goal_distance, static_costs
from dcmppi.control.predictors import Prediction

NO_TRACKS = TrackIndex(np.zeros((0, 1, 2)), np.zeros(0))


class Objective:
    """c summed over each rollout's states, for one control step.

    Args:
      goal: (2,) float x, y. grid: OccupancyGrid of the static map. alpha: static collision
        weight.
      prediction: the step's Prediction of the moving obstacles.
      pace: a Pace (dcmppi.control.pace) whose terms J adds, or None; start: (2,) the step's
        position (its path_align line starts there), with a pace.
    """

    def __init__(self, goal, grid, alpha, prediction, pace=None, start=None):
        if not isinstance(prediction, Prediction):
            raise TypeError(
                f"a predictor must return a dcmppi.control.Prediction; got "
                f"{type(prediction).__name__}"
            )
        self.goal = goal
        self.grid = grid
        self.alpha = alpha
        self.prediction = prediction
        self.pace, self.start = pace, start
        self.weight = float(prediction.weight)
        self.tracks = (
            TrackIndex(prediction.tracks, prediction.distance)
            if len(prediction.tracks)
            else NO_TRACKS
        )

    def __call__(self, states, moving=False, cols=None):
        """J (R,) of the rollouts states (3, N + 1, R) (x, y, theta; only x, y are used); with
        moving=True also the moving-obstacle term (R,) inside J, or None where it is 0.
        cols = (j0, j1): only those rollouts' J (j1 - j0,) (and term)."""
        x, y = states[0], states[1]
        if self.grid.empty or not self.alpha:
            J = goal_distance(x, y, self.goal, cols)
        else:
            J = static_costs(x, y, self.goal, self.grid, self.alpha, cols)
        if self.pace is not None:
            J += self.pace(x, y, self.start, self.goal, cols)
        term = None
        if not self.tracks.empty:
            term = self.weight * self.tracks.count(x, y, cols)
            J += term
        return (J, term) if moving else J

    def moving(self, states):
        """The moving-obstacle term (R,) alone: weight x the collisions with the tracks."""
        if self.tracks.empty:
            return np.zeros(states.shape[2])
        return self.weight * self.tracks.count(states[0], states[1])
