"""The checks of what Controller.act observes: the robot's state and goal, and the moving
obstacles' observed velocities and futures (the predictors' inputs, predictors.base.INPUTS);
each returns the values checked or raises one ValueError naming the argument."""

import numpy as np

from dcmppi.control.validation import floats

MAX_COORDINATE = 1e6  # |state| and |goal| bound: far beyond, squared distances overflow


def state_and_goal(state, goal):
    """state (3,) and goal (2,) as float arrays; a ValueError where either has another shape or
    a coordinate is not finite or beyond MAX_COORDINATE."""
    state, goal = floats("state", state), floats("goal", goal)
    if state.shape != (3,) or goal.shape != (2,):
        raise ValueError(f"state must be (3,) and goal (2,); got {state.shape}, {goal.shape}")
    if not all(abs(v) < MAX_COORDINATE for v in (*state.tolist(), *goal.tolist())):  # nan too
        raise ValueError(
            f"state and goal must be finite and within {MAX_COORDINATE:.0e} (m, rad); "
            f"got {state}, {goal}"
        )
    return state, goal


def observed_rows(values, moving, name):
    """The rows of `values` (L, ...) that belong to rows of `moving` (L, 4) that are not padding
    (radius > 0), or None; checked only for their number of rows (the predictor checks the rest)."""
    if values is None:
        return None
    values = np.asarray(values, dtype=float)
    radius = np.zeros(0) if moving is None else np.asarray(moving, dtype=float)[:, 3]
    if values.ndim < 1 or len(values) != len(radius):
        raise ValueError(
            f"{name} must have one row per row of moving ({len(radius)}); got shape {values.shape}"
        )
    return values[radius > 0]


def observed_velocity(velocity, moving):
    """The (L', 2) velocities of the rows of `moving` that are not padding (radius > 0), or None.

    Args:
      velocity: (L, 2) world-frame velocities (nan: not observed), or None.
      moving: (L, 4) moving obstacles, already validated (costs.valid_cylinders), or None.
    """
    if velocity is None:
        return None
    velocity = np.asarray(velocity, dtype=float)
    rows = 0 if moving is None else len(moving)
    if velocity.shape != (rows, 2):
        raise ValueError(
            f"moving_velocity must have shape ({rows}, 2), one row per row of moving; "
            f"got {velocity.shape}"
        )
    if not rows:  # no moving obstacles: nothing to check or select
        return velocity
    infinite = np.isinf(velocity).any(axis=1)
    if infinite.any():
        raise ValueError(
            f"moving_velocity must be finite, or nan where not observed; infinite rows "
            f"{np.flatnonzero(infinite)}"
        )
    return observed_rows(velocity, moving, "moving_velocity")
