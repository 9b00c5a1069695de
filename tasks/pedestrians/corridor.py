"""`corridor`: a robot against a two-way pedestrian flow between two walls (DRA-MPPI's scene)."""

from . import worlds
from .base import PedestrianNavigation


class Corridor(PedestrianNavigation):
    """20 x 6 m between walls at y = 0 and y = 6; the robot drives from x = 1 to x = 19.

    Half the `n_pedestrians` walk head-on toward the robot, half its way
    (`worlds.generate_corridor`); on arrival one reappears at its start end, 1 m
    outside the map, with a new goal at the far end, so the density stays. Preferred speeds:
    normal (mean, std) `speed` clipped to `speed_range`; the observation's `obstacle_model` is
    that normal's speeds with turn rates N(0, worlds.PEDESTRIAN_TURN_RATE_STD^2).
    Walls are static cylinder rows in the observation's static_obstacles (touching them is a
    collision). The robot is holonomic (v_max 1.5 m/s) of radius 0.3 m by default; see
    `PedestrianNavigation` for `behavior`, `robot_visible` and the time limit.
    """

    size = worlds.CORRIDOR_SIZE
    generate = staticmethod(worlds.generate_corridor)

    def __init__(
        self,
        n_pedestrians=worlds.CORRIDOR_PEDESTRIANS,
        pedestrian_radius=worlds.PEDESTRIAN_RADIUS,
        speed=worlds.CORRIDOR_SPEED,
        speed_range=worlds.CORRIDOR_SPEED_RANGE,
        behavior="social_force",
        robot_visible=False,
        robot_radius=worlds.PEDESTRIAN_RADIUS,
        **kwargs,
    ):
        super().__init__(
            n_pedestrians,
            pedestrian_radius,
            speed_range,
            behavior,
            robot_visible,
            robot_radius=robot_radius,
            **kwargs,
        )
        self.speed = _mean_std(speed, self.speed_range)
        self.num_static = len(worlds.wall_cylinders(worlds.corridor_walls()))

    def world_params(self) -> dict:
        return {
            "speed": self.speed,
            "speed_range": self.speed_range,
            "radius": self.radius,
        }

    def next_goal(self, random, i, position):
        """Pedestrian i reappears at its start end (1 m outside the map) at a uniform y of the
        lane, with a goal at the far end at another uniform y."""
        head_on = self.world.moving_goal[i, 0] < 0.5 * worlds.CORRIDOR_SIZE[0]
        start_x, goal_x = worlds.corridor_ends(head_on)
        lane = worlds.corridor_lane(self.world.moving[i, 3])
        y_start, y_goal = random.uniform(*lane, size=2)
        return (float(start_x), y_start), (float(goal_x), y_goal)


def _mean_std(value, speed_range):
    try:
        mean, std = (float(x) for x in value)
    except (TypeError, ValueError):
        raise ValueError(f"speed must be a pair (mean, std) [m/s], got {value!r}") from None
    lo, hi = speed_range
    if not lo <= mean <= hi or not std >= 0:
        raise ValueError(
            f"speed must be (mean, std) with {lo:g} <= mean <= {hi:g} (speed_range) and std >= 0, "
            f"got {value!r}"
        )
    return mean, std
