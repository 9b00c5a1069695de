"""`crowd`: 100 moving Dubins cylinders (paper Sec. IV-B; docs/design.md)."""

from dcmppi.control.validation import positive

from . import navigation, worlds


class Crowd(navigation.Navigation):
    """Moving cylinders with uniform random speeds and turn rates, reflecting off the walls.

    The observation's `obstacle_model` is the Gaussian with the uniforms' mean and std. The
    robot is the velocity-controlled `holonomic` agent by default (paper Sec. IV-B); with
    agent="dubins" the crowd is the hard variant (a constant-speed car cannot stop).
    """

    default_agent = "holonomic"

    def __init__(
        self,
        n_obstacles=worlds.CROWD_SIZE,
        speed_range=worlds.OBSTACLE_SPEED_RANGE,
        turn_rate_range=worlds.OBSTACLE_TURN_RATE_RANGE,
        obstacle_radius=worlds.MOVING_OBSTACLE_RADIUS,
        **kwargs,
    ):
        n_obstacles = positive("n_obstacles", n_obstacles, integer=True, allow_zero=True)
        super().__init__(**kwargs)
        self.speed_range = _range("speed_range", speed_range, low=0.0)
        self.turn_rate_range = _range("turn_rate_range", turn_rate_range)
        self.obstacle_radius = positive("obstacle_radius", obstacle_radius)
        self.num_moving = n_obstacles

    def generate_world(self, random):
        return worlds.generate_crowd(
            random,
            self.num_moving,
            self.robot_radius,
            self.speed_range,
            self.turn_rate_range,
            self.obstacle_radius,
        )


def _range(name, value, low=None):
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not lo <= hi or (low is not None and lo < low):
        raise ValueError(
            f"{name} must satisfy {'' if low is None else f'{low} <= '}low <= high, got {value!r}"
        )
    return lo, hi
