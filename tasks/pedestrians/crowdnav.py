"""`crowdnav`: CrowdNav's test scene (Chen et al., ICRA 2019; vita-epfl/CrowdNav).

Parameters from CrowdNav's crowd_nav/configs/env.config, crowd_sim/envs/crowd_sim.py and
policy/orca.py. `circle_crossing`: each human starts on a CIRCLE_RADIUS circle at a uniform
angle, each coordinate shifted by U(-0.5, 0.5) x its v_pref, its goal the start's antipode; a
start is redrawn while it or its goal lies within r_h + r_a + DISCOMFORT_DISTANCE of another
agent's (the robot's or an earlier human's) start or goal. `square_crossing`: each human starts
in a uniform half of a SQUARE_WIDTH square (redrawn near another start) and walks to a uniform
point of the other half (redrawn near another goal). The robot drives from (0, -r) to (0, r) of
the circle. Humans walk at most v_pref, slow down within 1 m of their goals and stop there
(walkers.ARRIVAL_TIME). The draws follow CrowdNav's order (random_sample per coordinate), so
that `case` k draws CrowdNav's test case k: its humans from RandomState(TEST_SEED + k), as its
test loop seeds numpy.
"""

import math

import numpy as np

from dcmppi.control.validation import array, flag, positive

from ..worlds.base import World, clearance, make_world, uniform_mean_std
from . import walkers
from .base import PedestrianNavigation
from .worlds import pedestrian_obstacle_model

SCENARIOS = ("circle_crossing", "square_crossing")
HUMANS = 5  # human_num
CIRCLE_RADIUS = 4.0  # [m] circle_radius: the humans' circle, the robot's start and goal
SQUARE_WIDTH = 10.0  # [m] square_width
HUMAN_RADIUS = 0.3  # [m]
V_PREF = 1.0  # [m/s] the humans' and the robot's
DISCOMFORT_DISTANCE = 0.2  # [m] discomfort_dist: the start spacing, the discomfort metric's gap
RANDOM_V_PREF, RANDOM_RADIUS = (0.5, 1.5), (0.3, 0.5)  # randomize_attributes' uniforms
TIME_LIMIT = 25.0  # [s] time_limit (CrowdNav's check ends its episodes at 24 s)
SUCCESS_DISTANCE = 0.3  # [m] the robot's centre this close to the goal (its radius there)
HALF_WIDTH = 10.0  # [m] the map is [-HALF_WIDTH, HALF_WIDTH]^2 (CrowdNav's has no edge)
TRIES = 1000  # draws per human before the scene counts as full
TEST_SEED = 1000  # CrowdNav seeds test case k with TEST_SEED + k (its val cases come first)
OBSTACLE_SIDES = 8  # a static cylinder is this polygon's walls for the humans


class CrowdNav(PedestrianNavigation):
    """CrowdNav's scene (module docstring): `n_humans` of radius `human_radius` and preferred
    speed `v_pref` (with `randomize_attributes`, each draws v_pref ~ U(RANDOM_V_PREF) then
    radius ~ U(RANDOM_RADIUS)), moving by `behavior` (default "orca": navground's ORCA with
    CrowdNav's settings, walkers), blind to the robot unless `robot_visible` (CrowdNav's `visible`,
    False in its papers' tests). The robot: holonomic (agent="unicycle" too), v_max V_PREF,
    radius 0.3 m, from (0, -circle_radius) to (0, circle_radius), done within SUCCESS_DISTANCE;
    time limit TIME_LIMIT. `obstacles` (K, 3) x, y, radius: static cylinders, which the humans see
    as walls (an OBSTACLE_SIDES-gon around each) and whose surface keeps DISCOMFORT_DISTANCE from
    the humans' starts and goals. `case` k (an int >= 0, or None): the world of CrowdNav's test
    case k whatever the episode's seed (its noise still follows the seed).
    """

    count_name, radius_name = "n_humans", "human_radius"
    time_factor = None
    goal_tolerance = SUCCESS_DISTANCE

    def __init__(
        self,
        scenario="circle_crossing",
        n_humans=HUMANS,
        human_radius=HUMAN_RADIUS,
        v_pref=V_PREF,
        randomize_attributes=False,
        behavior="orca",
        robot_visible=False,
        circle_radius=CIRCLE_RADIUS,
        square_width=SQUARE_WIDTH,
        obstacles=(),
        case=None,
        robot_radius=HUMAN_RADIUS,
        time_limit=TIME_LIMIT,
        **kwargs,
    ):
        if scenario not in SCENARIOS:
            raise ValueError(f"scenario must be one of {', '.join(SCENARIOS)}; got {scenario!r}")
        self.scenario = scenario
        self.randomize_attributes = flag("randomize_attributes", randomize_attributes)
        self.case = None if case is None else positive("case", case, integer=True, allow_zero=True)
        self.circle_radius = positive("circle_radius", circle_radius)
        self.square_width = positive("square_width", square_width)
        self.obstacles = array("obstacles", np.reshape(obstacles, (-1, 3)), ("K", 3), finite=True)
        if kwargs.get("agent") in (None, "holonomic", "unicycle"):
            kwargs.setdefault("v_max", V_PREF)
        speeds = RANDOM_V_PREF if randomize_attributes else (v_pref, v_pref)
        super().__init__(
            n_humans,
            human_radius,
            speeds,
            behavior,
            robot_visible,
            robot_radius=robot_radius,
            time_limit=time_limit,
            **kwargs,
        )
        self.num_static = max(1, len(self.obstacles))
        self._check_robot()

    def _check_robot(self):
        """A ValueError where the robot's start or goal touches an obstacle or leaves the map."""
        _check_obstacles(self.obstacles, self._robot_points(), self.robot_radius, self.behavior)
        if self.circle_radius + self.robot_radius >= HALF_WIDTH:
            raise ValueError(
                f"the robot's start and goal (0, -/+{self.circle_radius:g}) with its radius "
                f"{self.robot_radius:g} m leave the map [-{HALF_WIDTH:g}, {HALF_WIDTH:g}]^2: "
                "lower circle_radius or robot_radius"
            )
        spacing = 2.0 * self.robot_radius + DISCOMFORT_DISTANCE  # _apart's, robot to robot
        if 2.0 * self.circle_radius < spacing:
            raise ValueError(
                f"the robot's goal lies {2.0 * self.circle_radius:g} m from its start, closer "
                f"than the start spacing {spacing:g} m (2 robot_radius + {DISCOMFORT_DISTANCE:g}):"
                f" raise circle_radius to >= {0.5 * spacing:g}"
            )

    @property
    def map_bounds(self):
        return np.array([-HALF_WIDTH, -HALF_WIDTH, HALF_WIDTH, HALF_WIDTH])

    def _robot_points(self):
        """The robot's start and goal (2, 2)."""
        return np.array([[0.0, -self.circle_radius], [0.0, self.circle_radius]])

    def generate_world(self, random) -> World:
        if self.case is not None:
            random = np.random.RandomState(TEST_SEED + self.case)
        return generate_crowdnav(
            random,
            self.scenario,
            self.num_moving,
            self.radius,
            self.speed_range[0],
            self.randomize_attributes,
            self.robot_radius,
            self.behavior,
            self.robot_visible,
            self.circle_radius,
            self.square_width,
            self.obstacles,
            self.map_bounds,
        )


def generate_crowdnav(
    random,
    scenario="circle_crossing",
    n_humans=HUMANS,
    radius=HUMAN_RADIUS,
    v_pref=V_PREF,
    randomize_attributes=False,
    robot_radius=HUMAN_RADIUS,
    behavior="orca",
    robot_visible=False,
    circle_radius=CIRCLE_RADIUS,
    square_width=SQUARE_WIDTH,
    obstacles=(),
    bounds=(-HALF_WIDTH, -HALF_WIDTH, HALF_WIDTH, HALF_WIDTH),
) -> World:
    """One CrowdNav case (module docstring) drawn from `random` (a RandomState) in CrowdNav's
    order; humans start at rest, facing their goals.

    Raises:
      ValueError: a human found no start or goal in TRIES draws.
    """
    obstacles = np.reshape(np.asarray(obstacles, dtype=np.float64), (-1, 3))
    start = np.array([0.0, -circle_radius, 0.5 * math.pi])
    goal = np.array([0.0, circle_radius])
    agents = [(start[:2], goal, robot_radius)]  # (start, goal, radius) of those placed
    speeds, radii = np.zeros(n_humans), np.zeros(n_humans)
    draw = _circle_human if scenario == "circle_crossing" else _square_human
    size = circle_radius if scenario == "circle_crossing" else square_width
    for i in range(n_humans):
        speeds[i], radii[i] = v_pref, radius
        if randomize_attributes:
            speeds[i], radii[i] = random.uniform(*RANDOM_V_PREF), random.uniform(*RANDOM_RADIUS)
        placed = draw(random, size, speeds[i], radii[i], agents, obstacles)
        if placed is None:
            size_name = "circle_radius" if scenario == "circle_crossing" else "square_width"
            raise ValueError(
                f"only {i} of {n_humans} humans fit in {scenario} ({DISCOMFORT_DISTANCE:g} m "
                f"apart, clear of the robot and the obstacles): lower n_humans or raise {size_name}"
            )
        agents.append((*placed, radii[i]))
    xy = np.array([a[0] for a in agents[1:]]).reshape(-1, 2)
    goals = np.array([a[1] for a in agents[1:]]).reshape(-1, 2)
    heading = np.arctan2(goals[:, 1] - xy[:, 1], goals[:, 0] - xy[:, 0])
    mean_std = uniform_mean_std(*RANDOM_V_PREF) if randomize_attributes else (v_pref, 0.0)
    return make_world(
        start,
        goal,
        static=obstacles,
        moving=np.column_stack([xy, heading, radii]),
        speed=np.zeros(n_humans),
        bounds=bounds,
        obstacle_model=pedestrian_obstacle_model(*mean_std),
        behavior=behavior,
        moving_goal=goals,
        pref_speed=speeds,
        walls=obstacle_walls(obstacles),
        robot_visible=robot_visible,
        stop_at_goal=True,
    )


def _circle_human(random, circle_radius, v_pref, radius, agents, obstacles):
    """A start (2,) on the circle with noise, clear of the agents' starts and goals, and its
    antipode as goal; None after TRIES draws."""
    for _ in range(TRIES):
        angle = random.random_sample() * 2.0 * math.pi
        noise = (random.random_sample() - 0.5) * v_pref, (random.random_sample() - 0.5) * v_pref
        xy = circle_radius * np.array([np.cos(angle), np.sin(angle)]) + noise
        points = [(xy, a[0], a[2]) for a in agents] + [(xy, a[1], a[2]) for a in agents]
        if _apart(points, radius) and _clear_of(obstacles, radius, xy, -xy):
            return xy, -xy
    return None


def _square_human(random, width, v_pref, radius, agents, obstacles):
    """A start (2,) in a uniform half of the square clear of the agents' starts, and a goal (2,)
    in the other half clear of their goals; None after TRIES draws of either."""
    sign = -1.0 if random.random_sample() > 0.5 else 1.0
    chosen = []
    for side, column in ((sign, 0), (-sign, 1)):
        for _ in range(TRIES):
            xy = np.array(
                [
                    random.random_sample() * width * 0.5 * side,
                    (random.random_sample() - 0.5) * width,
                ]
            )
            if _apart([(xy, a[column], a[2]) for a in agents], radius) and _clear_of(
                obstacles, radius, xy
            ):
                chosen.append(xy)
                break
        else:
            return None
    return tuple(chosen)


def _apart(points, radius, spacing=DISCOMFORT_DISTANCE) -> bool:
    """Whether every (point, other, other's radius) of `points` lies at least radius + other's
    radius + spacing apart (CrowdNav's rule, centre to centre)."""
    return all(math.hypot(*(p - q)) >= radius + r + spacing for p, q, r in points)


def _clear_of(obstacles, radius, *points) -> bool:
    """Whether discs of `radius` at `points` (2,) keep DISCOMFORT_DISTANCE from every obstacle
    (K, 3)."""
    if not len(obstacles):
        return True
    return bool(clearance(np.array(points), obstacles, radius).min() >= DISCOMFORT_DISTANCE)


def obstacle_walls(obstacles) -> np.ndarray:
    """The walls (K x OBSTACLE_SIDES, 4) the humans see of the static cylinders (K, 3): a regular
    polygon around each (free side outside, counter-clockwise), its sides touching the circle."""
    walls = [np.zeros((0, 4))]
    angle = 2.0 * math.pi * np.arange(OBSTACLE_SIDES + 1) / OBSTACLE_SIDES
    for x, y, r in np.asarray(obstacles, dtype=np.float64).reshape(-1, 3):
        corner = r / math.cos(math.pi / OBSTACLE_SIDES)
        xy = np.column_stack([x + corner * np.cos(angle), y + corner * np.sin(angle)])
        walls.append(np.column_stack([xy[:-1], xy[1:]]))
    return np.concatenate(walls)


def _check_obstacles(obstacles, points, robot_radius, behavior):
    """A ValueError naming the first obstacle (K, 3) with radius <= 0 or touching the robot at
    its start or goal (points (2, 2), or (0, 2): drawn later), or obstacles for a behaviour
    blind to walls."""
    for k, (x, y, r) in enumerate(obstacles):
        if r <= 0:
            raise ValueError(f"obstacle {k} has radius {r:g}: give rows x, y, radius > 0")
        gap = clearance(points, obstacles[k : k + 1], robot_radius)[:, 0]
        for name, point, g in zip(("start", "goal")[: len(points)], points, gap, strict=True):
            if g <= 0:
                raise ValueError(
                    f"obstacle {k} at ({x:g}, {y:g}) of radius {r:g} m touches the robot at its "
                    f"{name} ({point[0]:g}, {point[1]:g}): move or shrink it"
                )
    if len(obstacles) and not walkers.BEHAVIOR.get(behavior).sees_walls:
        others = [b for b in walkers.WALKING if walkers.BEHAVIOR.get(b).sees_walls]
        raise ValueError(f"{behavior} ignores obstacles: with obstacles use {', '.join(others)}")
