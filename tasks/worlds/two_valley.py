"""`blocked` and `crossing`: one obstacle on the straight line from start to goal (paper Fig. 1-4).

The robot starts facing the goal, `distance` metres away, in the middle of the 75 x 50 m map.
Averaging a left and a right detour drives into the obstacle: the two-valley case that
rollout clustering is for.
"""

import numpy as np

from dcmppi.control.kernels.dynamics import wrap_angle
from dcmppi.control.validation import finite, positive

from ..navigation import Navigation
from .arcs import dubins_pose
from .base import make_world, map_bounds
from .paper import MOVING_OBSTACLE_RADIUS


def _line(distance, bounds):
    """Start pose (3,) and goal (2,) on a horizontal line through the map centre."""
    centre = 0.5 * (bounds[:2] + bounds[2:])
    start = np.array([centre[0] - 0.5 * distance, centre[1], 0.0])
    return start, start[:2] + [distance, 0.0]


class Blocked(Navigation):
    """A static cylinder of `obstacle_radius` halfway between start and goal.

    `lateral_jitter` > 0 shifts it sideways by U(-lateral_jitter, lateral_jitter) per episode.
    """

    def __init__(self, distance=20.0, obstacle_radius=2.0, lateral_jitter=0.0, **kwargs):
        super().__init__(**kwargs)
        self.distance = positive("distance", distance)
        self.obstacle_radius = positive("obstacle_radius", obstacle_radius)
        self.lateral_jitter = positive("lateral_jitter", lateral_jitter, allow_zero=True)

    def generate_world(self, random):
        bounds = map_bounds()
        start, goal = _line(self.distance, bounds)
        offset = random.uniform(-self.lateral_jitter, self.lateral_jitter)
        middle = 0.5 * (start[:2] + goal)
        static = np.array([[middle[0], middle[1] + offset, self.obstacle_radius]])
        return make_world(start, goal, static=static, bounds=bounds)


class Crossing(Navigation):
    """One moving cylinder that reaches the robot's straight path just when the robot does.

    If the robot drove straight at its top speed, the obstacle's centre would be on the robot's
    centre at `meet_fraction` of the way, moving in direction `approach_angle` relative to
    the robot's heading (pi: head-on, the paper's Fig. 4; pi/2: from the right). The
    obstacle's start is found by running its Dubins arc backwards from that meeting.
    """

    def __init__(
        self,
        distance=20.0,
        meet_fraction=0.5,
        approach_angle=np.pi,
        obstacle_speed=1.0,
        obstacle_turn_rate=0.0,
        obstacle_radius=MOVING_OBSTACLE_RADIUS,
        **kwargs,
    ):
        super().__init__(**kwargs)
        self.distance = positive("distance", distance)
        self.meet_fraction = positive("meet_fraction", meet_fraction)
        if self.meet_fraction > 1.0:
            raise ValueError(f"meet_fraction must be in (0, 1], got {meet_fraction}")
        self.approach_angle = finite("approach_angle", approach_angle)
        self.obstacle_speed = positive("obstacle_speed", obstacle_speed)
        self.obstacle_turn_rate = finite("obstacle_turn_rate", obstacle_turn_rate)
        self.obstacle_radius = positive("obstacle_radius", obstacle_radius)
        self.num_moving = 1

    def generate_world(self, random):
        bounds = map_bounds()
        start, goal = _line(self.distance, bounds)
        t_meet = self.meet_fraction * self.distance / self.agent.max_speed
        meet = [
            *(start[:2] + [self.meet_fraction * self.distance, 0.0]),
            start[2] + self.approach_angle,
        ]
        x, y, heading = dubins_pose(meet, self.obstacle_speed, self.obstacle_turn_rate, -t_meet)
        moving = np.array([[x, y, wrap_angle(heading), self.obstacle_radius]])
        return make_world(
            start,
            goal,
            moving=moving,
            speed=[self.obstacle_speed],
            turn_rate=[self.obstacle_turn_rate],
            bounds=bounds,
        )
