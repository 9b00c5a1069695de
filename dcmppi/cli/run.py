"""`dcmppi run`: one episode, its outcome printed (or one JSON object), optionally a video."""

import json

from dcmppi.cli.common import CAMERA_HELP, command, episode_errors, key_values, params
from dcmppi.render import CAMERAS


def add_parser(subparsers, names: dict) -> None:
    p = command(subparsers, "run", "run one episode and print its outcome", run)
    p.add_argument("--task", required=True, help=f"one of {names['tasks']}")
    p.add_argument("--controller", required=True, help=f"one of {names['controllers']}")
    p.add_argument("--noise", default="none", help=f"noise profile: {names['noises']}")
    p.add_argument("--seed", type=int, default=0, help="environment seed")
    params(p, "controller parameter, e.g. K=1000 (repeatable)", names["task_param"])
    p.add_argument(
        "--video",
        metavar="PATH",
        help="also render the episode to PATH (.mp4: every frame, 1280x720; .gif: at most 120 "
        "frames, 480x270)",
    )
    p.add_argument("--camera", default="scene", choices=CAMERAS, help=CAMERA_HELP)
    p.add_argument("--no-legend", action="store_true", help="no colour legend in the video")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def run(args) -> int:
    from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs, run_episode

    spec = EpisodeSpec(
        task=args.task,
        controller=args.controller,
        noise=args.noise,
        seed=args.seed,
        task_params=key_values(args.task_param, "--task-param"),
        controller_params=key_values(args.param, "--param"),
    )
    check_specs([spec])
    with episode_errors():
        if args.video:
            from dcmppi.bench.episodes.runner import Episode
            from dcmppi.render.recording import record_episode
            from dcmppi.render.video import check_path

            check_path(args.video)
            result = record_episode(
                Episode(spec), args.video, camera=args.camera, legend=not args.no_legend
            )
        else:
            result = run_episode(spec)
    if args.json:
        fields = {k: v for k, v in result.items() if k != "trace"}  # bytes: the database's
        keys = {"task": spec.task, "controller": spec.controller, "noise": spec.noise}
        print(json.dumps({**keys, "seed": spec.seed, **fields}))
    else:
        ttg = "-" if result["time_to_goal"] is None else f"{result['time_to_goal']:.1f} s"
        print(
            f"{spec.task} / {spec.controller} / noise {spec.noise} / seed {spec.seed}: "
            f"{result['outcome']}\n"
            f"  time to goal {ttg}, path {result['path_length']:.1f} m, "
            f"min clearance {result['min_clearance']:.2f} m, {result['steps']} steps\n"
            f"  controller {result['ctrl_ms_mean']:.2f} ms/step (p95 {result['ctrl_ms_p95']:.2f}), "
            f"env.step {result['env_ms_mean']:.2f} ms/step"
        )
    return 0
