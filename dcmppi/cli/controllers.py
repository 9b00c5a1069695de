"""`dcmppi controllers`: the controllers (built-in, installed), agents and predictors."""

from dcmppi.cli.common import command


def add_parser(subparsers, names: dict) -> None:
    command(subparsers, "controllers", "list the controllers (built-in, installed) and agents", run)


def run(args) -> int:
    from dcmppi.bench.episodes.plugins import ENTRY_POINT_GROUP, entry_points
    from dcmppi.control import controller_class, controller_names
    from dcmppi.control.agents import agent_class, agent_names
    from dcmppi.control.predictors import predictor_class, predictor_names

    print("controllers (--controller NAME, or package.module:ClassName for your own class):")
    every = ", ".join(agent_names())
    for name in controller_names():
        cls = controller_class(name)
        agents = ", ".join(getattr(cls, "agents", None) or ()) or every  # MPPI's: every agent
        print(f"  {name:12s} built-in: {_summary(cls)} (agents: {agents})")
    for name, ep in sorted(entry_points().items()):
        if name not in controller_names():
            dist = f", from {ep.dist.name} {ep.dist.version}" if ep.dist else ""
            print(f"  {name:12s} entry point {ep.value} ({ENTRY_POINT_GROUP}{dist})")
    print("agents (--task-param agent=NAME):")
    for name in agent_names():
        print(f"  {name:12s} {_summary(agent_class(name))}")
    print("predictors (--param prediction=NAME, or package.module:ClassName for your own):")
    for name in predictor_names():
        print(f"  {name:12s} {_summary(predictor_class(name))}")
    return 0


def _summary(cls) -> str:
    return (cls.__doc__ or cls.__name__).strip().splitlines()[0]
