"""The controllers by name: `register`, `controller_names`, `controller_class`, `make_controller`.

The built-in planners (mppi, clustered, dc, tube) register themselves when their modules are
imported; the registry imports them on first use, so `import dcmppi.control` (and the tasks,
which import its agents) does not load every planner, scikit-learn and scipy.
"""

from dcmppi.control.agents import Agent, agent_class
from dcmppi.control.predictors import predictor_class
from dcmppi.control.registry import Registry

BUILTIN = ("mppi", "clustered", "dc", "tube", "classical")  # classical: orca, hrvo, hl, dwa ...
CONTROLLERS = Registry("controller", builtins=[f"{__package__}.{m}" for m in BUILTIN])


def register(name):
    """Class decorator adding a controller to the registry under `name`."""
    return CONTROLLERS.register(name)


def controller_names():
    """Registered controller names, sorted."""
    return CONTROLLERS.names()


def controller_class(name):
    """The registered class of controller `name`; a ValueError names the valid ones."""
    return CONTROLLERS.get(name)


def make_controller(name, **params):
    """A controller by registry name ("mppi", "clustered", "dc", "tube") and keyword parameters.

    `agent` (default "dubins") names the analytic model, or is an Agent instance; `prediction`
    (default: the planner's) names the obstacle predictor. The agent's and the predictor's own
    parameters (e.g. v_max, measurement_std) are passed alongside the controller's.
    """
    cls = controller_class(name)
    valid = accepted_params(cls, params.get("agent", "dubins"), params.get("prediction"))
    unknown = sorted(set(params) - set(valid))
    if unknown:
        agent = params.get("agent", "dubins")
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown)} for controller {name!r} with agent "
            f"{getattr(agent, 'name', agent)!r} and prediction "
            f"{params.get('prediction') or cls.default_prediction!r}; valid parameters: "
            f"{', '.join(valid)}"
        )
    return cls(**params)


def accepted_params(cls, agent="dubins", prediction=None):
    """Keyword parameters of Controller subclass `cls` with `agent` (a name or an Agent) and
    `prediction` (a name; None: the class's default): its own, the agent's and the
    predictor's."""
    agent_params = () if isinstance(agent, Agent) else agent_class(agent).param_names
    own = predictor_class(prediction or cls.default_prediction).own_params
    names = list(cls.param_names())
    return names + [n for n in (*agent_params, *own) if n not in names]
