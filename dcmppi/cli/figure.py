"""`dcmppi figure`: value and rollout figures of one step under several controllers."""

import sys

from dcmppi.cli.common import SHARED, comma_list, command, key_values, params


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers, "figure", "value and rollout figures of one step (paper Fig. 2, 4)", run
    )
    p.add_argument("--task", default="crossing", help=f"one of {names['tasks']}")
    p.add_argument(
        "--controllers",
        default="mppi,clustered,dc",
        help=f"comma-separated: {names['controllers']}",
    )
    p.add_argument("--seed", type=int, default=0, help="environment seed")
    params(p, SHARED, names["task_param"])
    p.add_argument("--out", default="figures", help="output directory")


def run(args) -> int:
    import dataclasses

    import numpy as np

    from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs, controller_for
    from dcmppi.bench.episodes.snapshot import first_step
    from dcmppi.render.figures import require_diagnostics, write_figures

    controllers = comma_list(args.controllers)
    if not controllers:
        raise ValueError("--controllers needs at least one controller name")
    spec = EpisodeSpec(
        task=args.task,
        controller=controllers[0],
        noise="none",
        seed=args.seed,
        task_params=key_values(args.task_param, "--task-param"),
        shared_params=key_values(args.param, "--param"),
    )
    specs = {c: dataclasses.replace(spec, controller=c) for c in controllers}
    check_specs(list(specs.values()), chosen=tuple(spec.shared_params))
    require_diagnostics({c: controller_for(s) for c, s in specs.items()})  # before the episode
    observation, runs, _ = first_step(spec, controllers)
    result = write_figures(observation, runs, args.out, f"{spec.task}, seed {spec.seed}")
    for name, action in result["actions"].items():
        controls = ", ".join(f"{u:+.4f}" for u in np.atleast_1d(action))
        print(f"{name:10s} applies u = ({controls})")
    print("wrote " + ", ".join(result["files"]), file=sys.stderr)
    return 0
