"""The base of the tasks whose moving obstacles may be pedestrians who walk to goals: the crowd,
the corridor and the square (`PedestrianNavigation`)."""

from dcmppi.control.validation import flag, pair, positive

from ..navigation import Navigation
from ..worlds.base import BEHAVIOR_CONSTANT, MAP_SIZE, map_bounds
from . import walkers

TIME_FACTOR = 5.0  # the walkers' worlds: time limit / time to drive the map's longer side


class PedestrianNavigation(Navigation):
    """Navigation among moving obstacles that may walk (module docstring).

    count, radius [m]: the moving obstacles' number and radius (the task kwargs `count_name`
    and `radius_name`); speed_range (low, high) [m/s]: their speeds, low > 0 for walkers;
    `behavior`: how they move, one of walkers.WALKING, or with `walkers_only` False also
    "constant" (the crowd's Dubins arcs); `robot_visible`: whether they react to the robot
    (default False, as CrowdNav++). The robot is the `holonomic` agent by default.

    A subclass gives its map's `size` (x, y) [m], its world generator `generate`, which
    `generate_world` calls as generate(random, num_moving, robot_radius, behavior=,
    robot_visible=, **world_params()), and `world_params`. Time limit: by default `time_factor`
    x the time to drive the map's longer side at the agent's top speed, room to wait for a gap
    and to detour, while an episode stuck behind pedestrians still ends (None: Navigation's).
    """

    default_agent = "holonomic"
    count_name, radius_name = "n_pedestrians", "pedestrian_radius"
    walkers_only = True
    size = MAP_SIZE
    time_factor = TIME_FACTOR

    def __init__(self, count, radius, speed_range, behavior, robot_visible, **kwargs):
        count = positive(self.count_name, count, integer=True, allow_zero=True)
        self.radius = positive(self.radius_name, radius)
        (walkers.walking if self.walkers_only else walkers.BEHAVIOR.get)(behavior)
        self.behavior = behavior
        self.robot_visible = flag("robot_visible", robot_visible)
        super().__init__(**kwargs)
        walking = behavior != BEHAVIOR_CONSTANT  # walkers need a speed > 0
        self.speed_range = pair("speed_range", speed_range, low=0.0, strict=walking)
        self.num_moving = count

    @staticmethod
    def generate(random, n, robot_radius, **params):
        """The world generator of the subclass (a function of pedestrians.worlds or
        worlds.paper)."""
        raise NotImplementedError

    def world_params(self) -> dict:
        """The generator's keyword arguments of this task: radius, speeds."""
        raise NotImplementedError

    @property
    def map_bounds(self):
        return map_bounds(self.size)

    @property
    def time_limit(self) -> float:
        if self._time_limit is not None or self.time_factor is None:
            return super().time_limit
        xmin, ymin, xmax, ymax = self.map_bounds
        return self.time_factor * max(xmax - xmin, ymax - ymin) / self.agent.max_speed

    def generate_world(self, random):
        return self.generate(
            random,
            self.num_moving,
            self.robot_radius,
            behavior=self.behavior,
            robot_visible=self.robot_visible,
            **self.world_params(),
        )
