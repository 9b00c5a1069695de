"""`crowd`: 100 moving Dubins cylinders (paper Sec. IV-B; docs/design.md), or walkers."""

from dcmppi.control.validation import pair

from ..worlds import paper
from ..worlds.base import BEHAVIOR_CONSTANT, OBSTACLE_SPEED_RANGE, OBSTACLE_TURN_RATE_RANGE
from .base import PedestrianNavigation


class Crowd(PedestrianNavigation):
    """Moving cylinders with uniform random speeds and turn rates, reflecting off the walls.

    The observation's `obstacle_model` is the Gaussian with the uniforms' mean and std. The
    robot is the velocity-controlled `holonomic` agent by default (paper Sec. IV-B); with
    agent="dubins" the crowd is the hard variant (a constant-speed car cannot stop). The map
    and the time limit are the forest's (Navigation's).

    `behavior`: "constant" (default) moves them on Dubins arcs (`worlds.arcs.DubinsObstacles`);
    any other of walkers.BEHAVIORS makes them pedestrians that walk to uniform random
    goals in the map (a new one on arrival) at preferred speeds drawn from `speed_range`
    (`worlds.paper.generate_crowd`), reacting to the robot if `robot_visible`.
    """

    count_name, radius_name = "n_obstacles", "obstacle_radius"
    walkers_only = False
    time_factor = None
    generate = staticmethod(paper.generate_crowd)

    def __init__(
        self,
        n_obstacles=paper.CROWD_SIZE,
        speed_range=OBSTACLE_SPEED_RANGE,
        turn_rate_range=OBSTACLE_TURN_RATE_RANGE,
        obstacle_radius=paper.MOVING_OBSTACLE_RADIUS,
        behavior=BEHAVIOR_CONSTANT,
        robot_visible=False,
        **kwargs,
    ):
        super().__init__(
            n_obstacles, obstacle_radius, speed_range, behavior, robot_visible, **kwargs
        )
        self.turn_rate_range = pair("turn_rate_range", turn_rate_range)

    def world_params(self) -> dict:
        return {
            "speed_range": self.speed_range,
            "turn_rate_range": self.turn_rate_range,
            "obstacle_radius": self.radius,
        }
