"""`crowdnav_plus`: CrowdNav++'s test scene (Liu et al., ICRA 2023; Shuijing725/
CrowdNav_Prediction_AttnGraph).

Parameters from its crowd_nav/configs/config.py and crowd_sim/envs/crowd_sim_var_num.py (the
environment CrowdSimVarNum of its released test logs, trained_models/*/test). HUMANS humans of
radius 0.3 m and v_pref 1 m/s: each starts at a uniform angle on a CIRCLE_RADIUS circle, each
coordinate shifted by U(0, START_NOISE) (their noise_range, not centred), its goal the start's
antipode; a start is redrawn while it lies within r_h + r_a + DISCOMFORT_DISTANCE of another
agent's (the robot's or an earlier human's) position or goal. A human within its radius of its
goal respawns: a fresh draw by the same rule against the others' positions and goals now and
the robot's start and goal (theirs: the robot's position now; its start keeps the humans' paths
independent of the controller, as prediction "given" needs), keeping its velocity (theirs
restarts at rest; with a holonomic robot their end_goal_changing respawns whatever
end_goal_change_chance). Goals changed before arrival (their random_goal_changing, chance 0.5
in config.py; the configs of the released logs turn it off, as `goal_change_chance` 0 does
here): every GOAL_CHANGE_PERIOD each human in turn, with that chance, gets a goal on the circle
shifted by U(-v_pref / 2, v_pref / 2) per coordinate, drawn as crowdnav draws a start (at
DISCOMFORT_DISTANCE from the others' positions and goals and the robot's start and goal, theirs:
its position; here also clear of the obstacles). They
walk by ORCA with SAFETY_SPACE added to every disc, at most v_pref,
slowing within 1 m of the goal (walkers). The robot: start and goal uniform in
[-ARENA_SIZE, ARENA_SIZE]^2, redrawn until ROBOT_SPACING apart, holonomic, 1 m/s, radius 0.3 m,
unseen by the humans (robot_visible False), done within 0.3 m; TIME_LIMIT (theirs ends at 49 s).

Seeds: CrowdNav++'s test phase seeds numpy with TEST_SEED + its --seed (SEED in the logs of its
ORCA and social-force robots, 125 in its model's) + a counter; `case` k draws from
RandomState(TEST_SEED + SEED + k) in their order, so its robot and first humans are theirs of
counter k. Their test loop resets twice per episode and wraps the counter at 500: logged
episode j is counter 2j mod 500 (episodes j and j + 250 are the same case).
"""

import math

import numpy as np

from dcmppi.control.validation import positive

from ..worlds.base import World, make_world, uniform_mean_std
from .crowdnav import (
    HUMAN_RADIUS,
    RANDOM_RADIUS,
    RANDOM_V_PREF,
    TRIES,
    V_PREF,
    CrowdNav,
    _apart,
    _check_obstacles,
    _circle_human,
    _clear_of,
    obstacle_walls,
)
from .worlds import pedestrian_obstacle_model

HUMANS = 20  # sim.human_num
CIRCLE_RADIUS = 6.0 * math.sqrt(2.0)  # [m] sim.circle_radius
START_NOISE = 2.0  # [m] noise_range: each start coordinate + U(0, START_NOISE)
ARENA_SIZE = 6.0  # [m] sim.arena_size: the robot's start and goal in [-6, 6]^2
ROBOT_SPACING = 8.0  # [m] the robot's start and goal at least this far apart
DISCOMFORT_DISTANCE = 0.25  # [m] reward.discomfort_dist: the humans' start spacing
SAFETY_SPACE = 0.16  # [m] ORCA's radius + 0.01 + orca.safety_space (0.15)
TIME_LIMIT = 50.0  # [s] env.time_limit (their check ends episodes at 49 s)
TEST_SEED = 1000  # case_capacity["val"]: the test phase's seed offset
SEED = 425  # --seed of the logs of their ORCA and social-force robots (their model's: 125)
GOAL_CHANGE_PERIOD = 5.0  # [s] between their random_goal_changing rounds


class CrowdNavPlus(CrowdNav):
    """CrowdNav++'s scene (module docstring): `n_humans` on a `circle_radius` circle, the robot's
    start and goal drawn in [-arena_size, arena_size]^2 at least `robot_spacing` apart, ORCA's
    discs `safety_space` wider. The rest as `crowdnav` (human_radius, v_pref,
    randomize_attributes: each human draws v_pref then radius, and keeps them on respawning;
    behavior, robot_visible, obstacles: the robot's start and goal are redrawn off them too);
    `case` k: CrowdNav++'s test draw k (module docstring) whatever the episode's seed;
    goal_change_chance: each human's chance of a new goal every GOAL_CHANGE_PERIOD (0: none).
    """

    def __init__(
        self,
        n_humans=HUMANS,
        human_radius=HUMAN_RADIUS,
        v_pref=V_PREF,
        randomize_attributes=False,
        behavior="orca",
        robot_visible=False,
        circle_radius=CIRCLE_RADIUS,
        arena_size=ARENA_SIZE,
        robot_spacing=ROBOT_SPACING,
        safety_space=SAFETY_SPACE,
        obstacles=(),
        case=None,
        robot_radius=HUMAN_RADIUS,
        time_limit=TIME_LIMIT,
        goal_change_chance=0.0,
        **kwargs,
    ):
        self.goal_change_chance = positive(
            "goal_change_chance", goal_change_chance, allow_zero=True
        )
        if self.goal_change_chance > 1:
            raise ValueError(
                f"goal_change_chance must be a probability in [0, 1] (CrowdNav++'s: 0.5); got "
                f"{goal_change_chance!r}"
            )
        self.arena_size = positive("arena_size", arena_size)
        self.robot_spacing = positive("robot_spacing", robot_spacing)
        self.safety_space = positive("safety_space", safety_space, allow_zero=True)
        super().__init__(
            n_humans=n_humans,
            human_radius=human_radius,
            v_pref=v_pref,
            randomize_attributes=randomize_attributes,
            behavior=behavior,
            robot_visible=robot_visible,
            circle_radius=circle_radius,
            obstacles=obstacles,
            case=case,
            robot_radius=robot_radius,
            time_limit=time_limit,
            **kwargs,
        )
        self._physics = None
        self._goals = None

    @property
    def map_bounds(self):
        half = max(self.arena_size + self.robot_radius, self.circle_radius + START_NOISE) + 1.0
        return np.array([-half, -half, half, half])

    def _check_robot(self):
        diagonal = 2.0 * math.sqrt(2.0) * self.arena_size
        if self.robot_spacing >= diagonal:
            raise ValueError(
                f"robot_spacing {self.robot_spacing:g} m does not fit in the arena "
                f"[-{self.arena_size:g}, {self.arena_size:g}]^2 (diagonal {diagonal:.2f} m): "
                "lower robot_spacing or raise arena_size"
            )
        _check_obstacles(self.obstacles, np.zeros((0, 2)), self.robot_radius, self.behavior)

    def generate_world(self, random) -> World:
        if self.case is not None:
            random = np.random.RandomState(TEST_SEED + SEED + self.case)
        return generate_crowdnav_plus(
            random,
            self.num_moving,
            self.radius,
            self.speed_range[0],
            self.randomize_attributes,
            self.robot_radius,
            self.behavior,
            self.robot_visible,
            self.circle_radius,
            self.arena_size,
            self.robot_spacing,
            self.safety_space,
            self.obstacles,
            self.map_bounds,
        )

    def initialize_episode(self, physics):
        self._physics = physics
        super().initialize_episode(physics)
        self._goals = self.world.moving_goal.copy()
        if self.goal_change_chance > 0:
            physics.obstacle_motion.change_goals = self.change_goals

    def change_goals(self, random, step, position, goal):
        """The humans' goals (L, 2) after CrowdNav++'s round of goal changes (module docstring)
        where `step` control periods make a whole number of GOAL_CHANGE_PERIOD, else `goal`."""
        period = round(GOAL_CHANGE_PERIOD / self._physics.control_period)
        if step == 0 or step % period:
            return goal
        radii = self._physics.moving_obstacles()[:, 3]
        for i in range(len(goal)):
            if random.random_sample() <= self.goal_change_chance:
                others = [j for j in range(len(goal)) if j != i]
                agents = [(self.world.start[:2], self.world.goal, self.robot_radius)]
                agents += [(position[j], goal[j], radii[j]) for j in others]
                v_pref = self._physics.obstacle_motion.pref_speed[i]
                drawn = _circle_human(
                    random, self.circle_radius, v_pref, radii[i], agents, self.obstacles
                )
                goal[i] = goal[i] if drawn is None else drawn[0]
        self._goals = goal.copy()
        return goal

    def next_goal(self, random, i, position):
        """Human i respawns (module docstring): (start, goal), or (None, its goal) where no
        start fits in TRIES draws (it tries again next period)."""
        world, humans = self.world, self._physics.moving_obstacles()
        agents = [(world.start[:2], world.goal, self.robot_radius)]
        agents += [(humans[j, :2], self._goals[j], humans[j, 3]) for j in range(len(humans))]
        start = _start(random, self.circle_radius, humans[i, 3], agents, self.obstacles)
        if start is None:
            return None, self._goals[i]
        self._goals[i] = -start
        return start, -start


def generate_crowdnav_plus(
    random,
    n_humans=HUMANS,
    radius=HUMAN_RADIUS,
    v_pref=V_PREF,
    randomize_attributes=False,
    robot_radius=HUMAN_RADIUS,
    behavior="orca",
    robot_visible=False,
    circle_radius=CIRCLE_RADIUS,
    arena_size=ARENA_SIZE,
    robot_spacing=ROBOT_SPACING,
    safety_space=SAFETY_SPACE,
    obstacles=(),
    bounds=None,
) -> World:
    """One CrowdNav++ case (module docstring) drawn from `random` (a RandomState) in CrowdNav++'s
    order: the robot's start and goal, then each human (with randomize_attributes: their
    Agent's ORCA neighbour-distance draw, unused here, v_pref, radius; then its start); humans
    start at rest, facing their goals.

    Raises:
      ValueError: the robot or a human found no place in TRIES draws.
    """
    obstacles = np.reshape(np.asarray(obstacles, dtype=np.float64), (-1, 3))
    start, goal = _robot(random, arena_size, robot_spacing, robot_radius, obstacles)
    agents = [(start, goal, robot_radius)]
    speeds, radii = np.full(n_humans, float(v_pref)), np.full(n_humans, float(radius))
    for i in range(n_humans):
        if randomize_attributes:
            random.random_sample()  # their Agent's neighbor_dist ~ U(5, 10)
            speeds[i], radii[i] = random.uniform(*RANDOM_V_PREF), random.uniform(*RANDOM_RADIUS)
        xy = _start(random, circle_radius, radii[i], agents, obstacles)
        if xy is None:
            raise ValueError(
                f"only {i} of {n_humans} humans fit on the {circle_radius:g} m circle "
                f"({DISCOMFORT_DISTANCE:g} m apart, clear of the robot and the obstacles): "
                "lower n_humans"
            )
        agents.append((xy, -xy, radii[i]))
    xy = np.array([a[0] for a in agents[1:]]).reshape(-1, 2)
    heading = np.arctan2(-xy[:, 1], -xy[:, 0])
    mean_std = uniform_mean_std(*RANDOM_V_PREF) if randomize_attributes else (v_pref, 0.0)
    return make_world(
        np.array([*start, 0.5 * math.pi]),
        goal,
        static=obstacles,
        moving=np.column_stack([xy, heading, radii]),
        speed=np.zeros(n_humans),
        bounds=bounds,
        obstacle_model=pedestrian_obstacle_model(*mean_std),
        behavior=behavior,
        moving_goal=-xy,
        pref_speed=speeds,
        walls=obstacle_walls(obstacles),
        robot_visible=robot_visible,
        slow_at_goal=True,
        safety_space=safety_space,
    )


def _robot(random, arena_size, spacing, radius, obstacles):
    """The robot's start and goal (2,) each, uniform in the arena (px, py, gx, gy, as theirs)
    until `spacing` apart and clear of the obstacles."""
    for _ in range(TRIES):
        start_goal = random.uniform(-arena_size, arena_size, 4)
        start, goal = start_goal[:2], start_goal[2:]
        if math.hypot(*(start - goal)) >= spacing and _clear_of(obstacles, radius, start, goal):
            return start, goal
    raise ValueError(
        f"the robot found no start and goal {spacing:g} m apart in the arena clear of the "
        "obstacles: lower robot_spacing or move the obstacles"
    )


def _start(random, circle_radius, radius, agents, obstacles):
    """A human's start (2,) on the circle shifted by U(0, START_NOISE) per coordinate, it and
    its antipode clear of the obstacles, at DISCOMFORT_DISTANCE from the agents' (start, goal,
    radius) positions and goals; None after TRIES draws."""
    for _ in range(TRIES):
        angle = random.random_sample() * 2.0 * math.pi
        noise = random.uniform(0, 1) * START_NOISE, random.uniform(0, 1) * START_NOISE
        xy = circle_radius * np.array([np.cos(angle), np.sin(angle)]) + noise
        points = [(xy, a[0], a[2]) for a in agents] + [(xy, a[1], a[2]) for a in agents]
        if _apart(points, radius, DISCOMFORT_DISTANCE) and _clear_of(obstacles, radius, xy, -xy):
            return xy
    return None
