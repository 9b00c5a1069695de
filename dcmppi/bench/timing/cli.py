"""The options of `dcmppi timing` and its table; `--against`, `--profile`, `--fingerprint`."""

import argparse
import json
import platform
import sys

from threadpoolctl import threadpool_limits

from dcmppi.control import defaults
from dcmppi.control._malloc import tune_malloc

from . import cases
from .fingerprint import fingerprint, print_fingerprint
from .loop import BLOCK, ClosedLoop, time_cases
from .profile import print_profile, profile


def main(argv=None):
    """Run the timing benchmark; print a table or JSON. Returns 0 (2: --against without its
    packages)."""
    parser = argparse.ArgumentParser(
        prog="dcmppi timing",
        description="median controller time per control step on fixed problems",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--steps", type=int, default=100, help="control steps per case")
    parser.add_argument(
        "--block", type=int, default=BLOCK, help="consecutive steps of a case (1: cold caches)"
    )
    parser.add_argument(
        "--against",
        choices=["pytorch_mppi"],
        help="time pytorch_mppi beside our mppi on the same problem (needs the extra `peer`)",
    )
    parser.add_argument(
        "--profile", action="store_true", help="where one step's time goes, in microseconds"
    )
    parser.add_argument(
        "--fingerprint",
        action="store_true",
        help="hash every closed loop's actions (identical before and after a speed change)",
    )
    args = parser.parse_args(argv)
    if args.steps < 5:
        parser.error("--steps must be >= 5")
    if args.block < 1:
        parser.error("--block must be >= 1")
    tune_malloc()  # process-wide: only entry points set it
    if args.against:
        return against(args)
    if args.profile:
        results = profile(cases.PROFILE_CASES, args.steps)
        if args.json:
            print(json.dumps(results, indent=2))
        else:
            print_profile(results, args.steps)
        return 0
    if args.fingerprint:
        rows = fingerprint(cases.FINGERPRINT_CASES, args.steps)
        if args.json:
            print(json.dumps({"steps": args.steps, "results": rows}, indent=2))
        else:
            print_fingerprint(rows, args.steps)
        return 0
    rows = table(cases.CASES, args.steps, args.block)
    info = {"K": defaults.K, "N": defaults.N, "P": defaults.P, "steps": args.steps}
    info["block"] = args.block
    info["machine"] = (
        f"{platform.processor() or platform.machine()}, python {platform.python_version()}"
    )
    if args.json:
        print(json.dumps({"settings": info, "results": rows}, indent=2))
        return 0
    print(
        f"dcmppi timing: K={info['K']} N={info['N']} P={info['P']}, one thread, {args.steps} steps "
        f"in blocks of {args.block}"
    )
    header = f"{'case':<21} {'problem':<11} {'median ms':>9} {'p95 ms':>7} {'ratio':>6}"
    print(f"{header}  target")
    for r in rows:
        print(
            f"{r['case']:<21} {r['problem']:<11} {r['median_ms']:9.3f} {r['p95_ms']:7.3f} "
            f"{r['ratio']:6.2f}  {r['target']}"
        )
    return 0


def table(selected, steps, block):
    """Rows {case, controller, problem, params, median_ms, p95_ms, ratio, reference, target} of
    the selected cases (cases.Case), timed interleaved on one thread; ratio: the median over its
    reference row's (same problem family)."""
    with threadpool_limits(1):
        times = time_cases(selected, steps, block)
    rows = [
        {"case": c.label, "controller": c.controller, "problem": c.problem, "params": c.params,
         "median_ms": median, "p95_ms": p95}
        for c, (median, p95) in zip(selected, times, strict=True)
    ]  # fmt: skip
    median = {(r["case"], r["problem"].split("+")[0]): r["median_ms"] for r in rows}
    for c, r in zip(selected, rows, strict=True):
        r["ratio"] = r["median_ms"] / median[(c.reference, c.problem.split("+")[0])]
        r["reference"] = c.reference
        r["target"] = (
            f"<= {c.target_ms} ms" if c.target_ms
            else f"<= {c.target_ratio} x {c.reference}" if c.target_ratio else ""
        )  # fmt: skip
    return rows


def against(args):
    """`--against pytorch_mppi`: our mppi (time-varying) and pytorch_mppi on the forest."""
    from dcmppi.bench import peer

    try:
        peer.require()
    except ImportError as e:
        print(f"dcmppi timing: {e}", file=sys.stderr)
        return 2
    ours = ClosedLoop("mppi", "forest", args.steps, perturbation="time_varying")
    with threadpool_limits(1):
        result = peer.compare(ours, args.steps, args.block)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    v, s = result["versions"], result["settings"]
    print(
        f"dcmppi timing --against pytorch_mppi {v['pytorch_mppi']} (torch {v['torch']}): forest, "
        f"K={s['K']} N={s['N']}, {s['perturbation']} noise, one thread, {args.steps} steps "
        f"interleaved in blocks of {args.block}"
    )
    print(f"{'controller':<20} {'median ms':>9} {'p95 ms':>7}")
    for name, key in (("mppi (dcmppi)", "ours"), ("pytorch_mppi", "theirs")):
        print(f"{name:<20} {result[key]['median_ms']:9.3f} {result[key]['p95_ms']:7.3f}")
    print(
        f"pytorch_mppi / ours = {result['theirs_over_ours']:.1f} (target >= 20), "
        f"ours / pytorch_mppi = {result['ours_over_theirs']:.3f}"
    )
    print(f"same problem: {result['same_problem']}")
    return 0
