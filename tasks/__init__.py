"""dm_control tasks of the dcmppi benchmark: the worlds, the MuJoCo plant, the task suite.

    from dcmppi import tasks
    env = tasks.load("forest", task_kwargs={"random": 0, "noise": "control"})

Every task takes `random`, `noise` (one of NOISE_PROFILES: "none" | "control" | "process"),
the robot's `agent` ("dubins", "unicycle", "holonomic") with its parameters (dubins: v, r_min;
others: v_max, omega_max) and `robot_radius`, the control-noise variances `Sigma`, the
process-noise stds `process_velocity_std` and `process_yaw_rate_std`, `time_limit` [s],
`obstacle_measurement_std` [m] (noisy moving-obstacle positions, headings and velocities nan),
plus its own kwargs; tasks with pedestrians (`crowd`, `corridor`, `square`, `crowdnav`,
`crowdnav_plus`) take `behavior` (one of pedestrians.walkers.BEHAVIORS) and `robot_visible`;
`replay` puts the robot in a recorded crowd (`scene`, `path` or $DCMPPI_CROWDS, `episode`,
`reactive`).

    __init__.py    the suite: `load`, TASKS, the tagged registry
    _gl.py         the OpenGL backend, chosen before MuJoCo loads
    physics.py     the plant `Physics`: obstacle slots, contacts, clearance
    navigation.py  the task `Navigation`: physics timestep, noise profiles, termination
    robots.py      agent -> actuators of the robot's MJCF model
    worlds/        the `World` contract, sampling, the paper's forest and crowd, the Dubins
                   arcs; the tasks forest, blocked, crossing, layout, and BARN's score
    pedestrians/   the walkers' behaviours, the corridor's and square's worlds; the tasks
                   corridor, square, crowd, crowdnav and crowdnav_plus on one base
    replay/        the ETH/UCY recordings, their scenes and episodes, the recorded people's
                   motion; the task replay

May import MuJoCo, dm_control, numpy, navground and, of the rest of dcmppi, only the robot
models dcmppi.control.agents (with dcmppi.control.kernels.dynamics, their motion), the social
force dcmppi.control.kernels.social (compiled, shared with the `social` predictor), and
dcmppi.control's defaults, validation (the checks of task kwargs) and registry: no controller,
nothing of dcmppi.bench or dcmppi.render (tests/test_architecture.py). Installed, this folder is
the subpackage dcmppi.tasks (see dcmppi/__init__.py).
"""

from ._gl import choose_backend

choose_backend()  # before dm_control imports MuJoCo

import inspect  # noqa: E402

from dm_control.utils import containers  # noqa: E402

from dcmppi.control.agents import agent_param_names  # noqa: E402

from .navigation import NOISE_PROFILES, Navigation, make_environment  # noqa: E402
from .pedestrians.corridor import Corridor  # noqa: E402
from .pedestrians.crowd import Crowd  # noqa: E402
from .pedestrians.crowdnav import CrowdNav  # noqa: E402
from .pedestrians.crowdnav_plus import CrowdNavPlus  # noqa: E402
from .pedestrians.square import Square  # noqa: E402
from .physics import Physics  # noqa: E402
from .replay.task import Replay  # noqa: E402
from .worlds.forest import Forest  # noqa: E402
from .worlds.layout import Layout  # noqa: E402
from .worlds.two_valley import Blocked, Crossing  # noqa: E402

SUITE = containers.TaggedTasks()


_CLASSES = {}


def _register(name, cls, description, *tags):
    _CLASSES[name] = cls

    def factory(task_kwargs=None, environment_kwargs=None):
        return _build(cls, task_kwargs, environment_kwargs)

    factory.__name__ = factory.__qualname__ = name
    factory.__doc__ = description
    SUITE.add(*tags)(factory)


_register(
    "forest",
    Forest,
    "Static random forest, 75 x 50 m, clusters of overlapping cylinders (n_clusters=65).",
    "static",
    "benchmark",
)
_register(
    "crowd",
    Crowd,
    "100 moving Dubins cylinders reflecting off the walls (n_obstacles, speed/turn ranges; "
    "behavior=social_force, orca, ...: walkers).",
    "dynamic",
    "benchmark",
)
_register(
    "corridor",
    Corridor,
    "20 x 6 m corridor with walls, 12 social-force pedestrians both ways (n_pedestrians, "
    "behavior, robot_visible).",
    "dynamic",
    "pedestrians",
)
_register(
    "square",
    Square,
    "8 x 8 m square, 7 ORCA pedestrians at 1-2 m/s between random points, robot at 1 m/s "
    "(n_pedestrians, behavior, robot_visible).",
    "dynamic",
    "pedestrians",
)
_register(
    "crowdnav",
    CrowdNav,
    "CrowdNav's test scene: 5 ORCA humans crossing a 4 m circle to its antipodes, blind to a "
    "holonomic robot driving (0, -4) -> (0, 4) (scenario, n_humans, behavior, robot_visible, "
    "randomize_attributes, obstacles).",
    "dynamic",
    "pedestrians",
)
_register(
    "crowdnav_plus",
    CrowdNavPlus,
    "CrowdNav++'s test scene: 20 ORCA humans crossing a 6*sqrt(2) m circle and respawning, blind "
    "to a holonomic robot between random points of [-6, 6]^2 at least 8 m apart (n_humans, "
    "behavior, robot_visible, randomize_attributes, case).",
    "dynamic",
    "pedestrians",
)
_register(
    "blocked",
    Blocked,
    "One static cylinder on the start-goal line (distance=20, obstacle_radius=2).",
    "static",
    "two_valley",
)
_register(
    "crossing",
    Crossing,
    "One moving cylinder that meets the robot's straight path (approach_angle=pi: head-on).",
    "dynamic",
    "two_valley",
)
_register(
    "replay",
    Replay,
    "The robot replaces one recorded person of an ETH/UCY scene among the others' recorded "
    "tracks (scene, path or $DCMPPI_CROWDS, episode; reactive=true: ORCA, no longer a "
    "recording).",
    "dynamic",
    "pedestrians",
    "recorded",
)
_register(
    "layout",
    Layout,
    "Cylinders, start and goal from a CSV/JSON file or a BARN world (path=, world=).",
    "static",
)

TASKS = {name: factory.__doc__ for name, factory in SUITE.items()}


def load(name, task_kwargs=None, environment_kwargs=None):
    """The dm_control Environment of task `name` (see TASKS).

    Raises:
      ValueError: unknown task name, unknown or bad task kwargs.
    """
    if name not in SUITE:
        raise ValueError(f"unknown task {name!r}; valid tasks: {', '.join(TASKS)}")
    return SUITE[name](task_kwargs, environment_kwargs)


def task_kwargs(cls) -> list[str]:
    """Names of the keyword arguments a task class accepts (its own, every task's, and the
    agents' parameters, which go to the task's agent)."""
    names = []
    for klass in (cls, Navigation):
        for p in inspect.signature(klass.__init__).parameters.values():
            if p.kind == p.KEYWORD_ONLY or p.kind == p.POSITIONAL_OR_KEYWORD:
                if p.name != "self" and p.name not in names:
                    names.append(p.name)
    return names + [n for n in agent_param_names() if n not in names]


def task_class(name) -> type:
    """The Task class of task `name` (its constructor's keywords are the task kwargs)."""
    if name not in SUITE:
        raise ValueError(f"unknown task {name!r}; valid tasks: {', '.join(TASKS)}")
    return _CLASSES[name]


def default_agent(name) -> str:
    """The agent task `name` simulates unless task_kwargs say otherwise."""
    return task_class(name).default_agent


def robot(name, kwargs=None) -> dict:
    """The robot task `name` simulates with task kwargs `kwargs`, its defaults included: {"agent",
    the agent's parameters (e.g. v_max), "robot_radius"}, what a planner must plan with."""
    task = _task(task_class(name), kwargs)
    return {"agent": task.agent.name, **task.agent.params, "robot_radius": task.robot_radius}


def _task(cls, kwargs):
    """Task class `cls` built with `kwargs`; unknown names are one ValueError listing the
    valid ones."""
    kwargs = dict(kwargs or {})
    unknown = sorted(set(kwargs) - set(task_kwargs(cls)))
    if unknown:
        raise ValueError(
            f"unknown task_kwargs {unknown} for {cls.__name__}; "
            f"valid: {', '.join(task_kwargs(cls))}"
        )
    return cls(**kwargs)


def _build(cls, kwargs, environment_kwargs):
    return make_environment(_task(cls, kwargs), environment_kwargs)


__all__ = [
    "NOISE_PROFILES",
    "SUITE",
    "TASKS",
    "default_agent",
    "load",
    "robot",
    "task_class",
    "task_kwargs",
    "Navigation",
    "Physics",
    "Forest",
    "Crowd",
    "CrowdNav",
    "CrowdNavPlus",
    "Corridor",
    "Square",
    "Blocked",
    "Crossing",
    "Layout",
    "Replay",
    "make_environment",
]
