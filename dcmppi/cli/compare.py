"""`dcmppi compare`: one episode under several controllers, side by side in one video."""

import sys

from dcmppi.cli.common import (
    CAMERA_HELP,
    SHARED,
    comma_list,
    command,
    episode_errors,
    key_values,
    params,
)
from dcmppi.render import CAMERAS


def add_parser(subparsers, names: dict) -> None:
    p = command(subparsers, "compare", "one episode under several controllers, side by side", run)
    p.add_argument("--task", required=True, help=f"one of {names['tasks']}")
    p.add_argument(
        "--controllers",
        default="mppi,clustered,dc",
        help=f"comma-separated: {names['controllers']}",
    )
    p.add_argument("--noise", default="none", help=f"noise profile: {names['noises']}")
    p.add_argument("--seed", type=int, default=0, help="environment seed")
    params(p, SHARED, names["task_param"])
    p.add_argument(
        "--video",
        required=True,
        metavar="PATH",
        help=".mp4 (every frame) or .gif (at most 120 frames, smaller tiles)",
    )
    p.add_argument("--camera", default="scene", choices=CAMERAS, help=CAMERA_HELP)
    p.add_argument("--width", type=int, help="tile width in pixels (default 640, GIF 320)")
    p.add_argument("--height", type=int, help="tile height in pixels (default 480, GIF 240)")
    p.add_argument("--no-legend", action="store_true", help="no colour legend in the video")


def run(args) -> int:
    from dcmppi.bench.episodes.runner import Episode, EpisodeSpec, check_specs
    from dcmppi.render.recording import compare
    from dcmppi.render.video import check_path

    check_path(args.video)
    controllers = comma_list(args.controllers)
    if not controllers:
        raise ValueError("--controllers needs at least one controller name")
    specs = [
        EpisodeSpec(
            task=args.task,
            controller=controller,
            noise=args.noise,
            seed=args.seed,
            task_params=key_values(args.task_param, "--task-param"),
            shared_params=key_values(args.param, "--param"),
        )
        for controller in controllers
    ]
    check_specs(specs, chosen=tuple(specs[0].shared_params))
    with episode_errors():
        results = compare(
            [Episode(spec) for spec in specs],
            args.video,
            camera=args.camera,
            width=args.width,
            height=args.height,
            legend=not args.no_legend,
        )
    for spec, result in zip(specs, results, strict=True):
        print(
            f"{spec.controller:10s} {result['outcome']:10s} {result['steps']:5d} steps, "
            f"min clearance {result['min_clearance']:.2f} m"
        )
    print(f"wrote {args.video}", file=sys.stderr)
    return 0
