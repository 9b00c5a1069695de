"""The objective of one control step: what a planner minimises over a batch of rollouts.

Every state x_0 .. x_N of a rollout pays the same cost (the paper's running cost psi for
i = 0..N-1 and terminal cost phi = psi for x_N, Alg. 2; docs/design.md):

    c(x_i) = |p_i - goal| + alpha 1[x_i in the static cost map]
             + w sum_j 1[|p_i - o_j(t_i)| <= d_j]   (the moving-obstacle term)

plus, when a Pace is given, terms for time to the goal (off by default). Far from the goal a
sideways step costs almost nothing (a lateral offset y at distance D adds about y^2 / 2D). Pace
adds, per rollout from p_0 (the step's position) to the goal g,

    cost_to_go   * |p_N - g|                            (the distance left at the horizon)
    path_align   * sum_i dist(p_i, line p_0 -> g)        (nav2's PathAlignCritic on the straight
                                                          path to the goal)
    speed_weight * sum_i (v_max - |p_{i+1} - p_i| / dt)  (speed below the top speed)

in the cost's units (the goal term: 1 per metre per state); a weight 0 turns a term off. With
predicted futures, Pace's way_weight adds a term for standing in a person's way (CrowdNav++'s
intrusion: the robot now where a person will be within seconds):

    way_weight * sum_i sum_s sum_j 1[|p_i - m_j(t_i + s)| <= d_j],  s = WAY_STEP .. WAY_HORIZON

with m_j the mean of obstacle j's sampled futures (held at its last step); the planner counts
it in the moving-obstacle term.

The static map is the planner's OccupancyGrid of the static cylinders (and the map bounds). The
tracks o_j, their distances d_j and the weight w come from the step's Prediction (a predictor's:
frozen obstacles with w = alpha, or P sampled futures per obstacle with w = beta / P).
"""

import dataclasses

import numpy as np

from dcmppi.control.kernels.costs import TrackIndex, goal_distance, static_costs
from dcmppi.control.predictors import Prediction
from dcmppi.control.validation import positive

NO_TRACKS = TrackIndex(np.zeros((0, 1, 2)), np.zeros(0))
WAY_STEP, WAY_HORIZON = 0.2, 1.2  # [s] the instants ahead of a person that are their way


class Objective:
    """c summed over each rollout's states, for one control step.

    Args:
      goal: (2,) float x, y. grid: OccupancyGrid of the static map. alpha: static collision
        weight.
      prediction: the step's Prediction of the moving obstacles.
      pace: a Pace whose terms J adds, or None; start: (2,) the step's
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
        self.way = NO_TRACKS
        if pace is not None and pace.way_weight and prediction.futures is not None:
            self.way = way_tracks(prediction, pace.dt)

    def _moving(self, x, y, cols):
        """The moving-obstacle term (j1 - j0,) of the rollouts x, y (N + 1, R) in cols."""
        term = self.weight * self.tracks.count(x, y, cols)
        if not self.way.empty:
            term = term + self.pace.way_weight * self.way.count(x, y, cols)
        return term

    def __call__(self, states, moving=False, cols=None):
        """J (R,) of the rollouts states (3, N + 1, R) (x, y, theta; only x, y are used); with
        moving=True also the moving-obstacle term (R,) inside J, or None where it is 0.
        cols = (j0, j1): only those rollouts' J (j1 - j0,) (and term)."""
        x, y = states[0], states[1]
        if self.grid.empty or not self.alpha:
            J = goal_distance(x, y, self.goal, cols)
        else:
            J = static_costs(x, y, self.goal, self.grid, self.alpha, cols)
        if self.pace is not None and self.pace.timed:
            J += self.pace(x, y, self.start, self.goal, cols)
        term = None
        if not self.tracks.empty:
            term = self._moving(x, y, cols)
            J += term
        return (J, term) if moving else J

    def moving(self, states):
        """The moving-obstacle term (R,) alone: weight x the collisions with the tracks (plus
        the way term)."""
        if self.tracks.empty:
            return np.zeros(states.shape[2])
        return self._moving(states[0], states[1], None)


def way_tracks(prediction, dt):
    """TrackIndex of the obstacles' ways: the mean of each one's futures (L, F, N + 1, 2) at
    t_i + s for every s = WAY_STEP .. WAY_HORIZON (rounded to distinct steps of dt, at least
    one), against state i. The futures must be the tracks grouped by obstacle (Prediction)."""
    futures = np.asarray(prediction.futures, dtype=float)
    distance = np.asarray(prediction.distance, dtype=float)
    if futures.ndim != 4 or futures.shape[0] * futures.shape[1] != len(distance):
        raise ValueError(
            f"way_weight needs a prediction whose futures (L, F, N + 1, 2) are its tracks grouped "
            f"by obstacle; got futures {futures.shape} for {len(distance)} tracks: give them so, "
            "or set way_weight = 0"
        )
    mean = futures.mean(axis=1)  # (L, N + 1, 2)
    steps = np.arange(mean.shape[1])
    count = round(WAY_HORIZON / WAY_STEP)
    shifts = sorted({max(1, round(k * WAY_STEP / dt)) for k in range(1, count + 1)})
    tracks = np.concatenate([mean[:, np.minimum(steps + s, steps[-1])] for s in shifts])
    distance = distance.reshape(futures.shape[:2])[:, 0]
    return TrackIndex(tracks, np.tile(distance, len(shifts)))


PACE_PARAMS = ("cost_to_go", "path_align", "speed_weight", "way_weight")


@dataclasses.dataclass(frozen=True)
class Pace:
    """The weights of the terms above, the agent's top speed v_max [m/s] and the period dt [s].

    Build with Pace.of(cost_to_go=..., ...), which checks the weights."""

    cost_to_go: float = 0.0
    path_align: float = 0.0
    speed_weight: float = 0.0
    way_weight: float = 0.0
    v_max: float = 1.0
    dt: float = 0.1

    @classmethod
    def of(cls, v_max, dt, **weights):
        """Pace of the weights (None: 0), each a number >= 0 (a ValueError names a bad one)."""
        checked = {
            n: positive(n, 0.0 if weights.get(n) is None else weights[n], allow_zero=True)
            for n in PACE_PARAMS
        }
        return cls(**checked, v_max=float(v_max), dt=float(dt))

    @property
    def on(self):
        """Whether any term has a weight."""
        return self.timed or bool(self.way_weight)

    @property
    def timed(self):
        """Whether a term for time to the goal (the ones __call__ sums) has a weight."""
        return bool(self.cost_to_go or self.path_align or self.speed_weight)

    def __call__(self, x, y, start, goal, cols=None):
        """The time terms' sum (R,) for the rollouts x, y (N + 1, R) from the step's position
        start (2,) to goal (2,); only the columns cols = (j0, j1) when given (the way term is
        the Objective's, in its moving-obstacle term)."""
        if cols is not None:
            x, y = x[:, cols[0] : cols[1]], y[:, cols[0] : cols[1]]
        gx, gy = float(goal[0]), float(goal[1])
        out = np.zeros(x.shape[1])
        if self.cost_to_go:
            out += self.cost_to_go * np.hypot(x[-1] - gx, y[-1] - gy)
        if self.path_align:
            x0, y0 = float(start[0]), float(start[1])
            ex, ey = gx - x0, gy - y0
            norm = np.hypot(ex, ey)
            if norm > 0:
                lateral = np.abs((x - x0) * (ey / norm) - (y - y0) * (ex / norm))
                out += self.path_align * lateral.sum(axis=0)
        if self.speed_weight:
            speed = np.hypot(np.diff(x, axis=0), np.diff(y, axis=0)) / self.dt
            out += self.speed_weight * (self.v_max - speed).sum(axis=0)
        return out
