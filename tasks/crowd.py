"""`crowd`: 100 moving Dubins cylinders (paper Sec. IV-B; docs/design.md), or walkers."""

from dcmppi.control.validation import flag, pair, positive

from . import pedestrians, worlds
from .navigation import Navigation
from .world_base import BEHAVIOR_CONSTANT, OBSTACLE_SPEED_RANGE, OBSTACLE_TURN_RATE_RANGE


class Crowd(Navigation):
    """Moving cylinders with uniform random speeds and turn rates, reflecting off the walls.

    The observation's `obstacle_model` is the Gaussian with the uniforms' mean and std. The
    robot is the velocity-controlled `holonomic` agent by default (paper Sec. IV-B); with
    agent="dubins" the crowd is the hard variant (a constant-speed car cannot stop).

    `behavior`: "constant" (default) moves them on Dubins arcs (`arcs.DubinsObstacles`);
    any other of pedestrians.BEHAVIORS makes them pedestrians that walk to uniform random
    goals in the map (a new one on arrival) at preferred speeds drawn from `speed_range`
    (`worlds.generate_crowd`), reacting to the robot if `robot_visible`.
    """

    default_agent = "holonomic"

    def __init__(
        self,
        n_obstacles=worlds.CROWD_SIZE,
        speed_range=OBSTACLE_SPEED_RANGE,
        turn_rate_range=OBSTACLE_TURN_RATE_RANGE,
        obstacle_radius=worlds.MOVING_OBSTACLE_RADIUS,
        behavior=BEHAVIOR_CONSTANT,
        robot_visible=False,
        **kwargs,
    ):
        n_obstacles = positive("n_obstacles", n_obstacles, integer=True, allow_zero=True)
        pedestrians.BEHAVIOR.get(behavior)
        self.behavior = behavior
        self.robot_visible = flag("robot_visible", robot_visible)
        super().__init__(**kwargs)
        walking = behavior != BEHAVIOR_CONSTANT  # pedestrians need a speed > 0
        self.speed_range = pair("speed_range", speed_range, 0.0, walking)
        self.turn_rate_range = pair("turn_rate_range", turn_rate_range)
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
            behavior=self.behavior,
            robot_visible=self.robot_visible,
        )
