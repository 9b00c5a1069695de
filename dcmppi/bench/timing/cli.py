"""What `dcmppi timing` runs and prints in each of its modes: the table, `--profile`,
`--fingerprint`, `--against`, `--profile EXPERIMENT`, `--scaling` (its options and their checks:
dcmppi.cli.timing). Each takes the parsed options and returns the exit status."""

import json
import platform
import sys

from threadpoolctl import threadpool_limits

from dcmppi.bench.results.provenance import kernels
from dcmppi.bench.timing import cases, episodes, scaling
from dcmppi.bench.timing.cores import machine_gains
from dcmppi.bench.timing.fingerprint import fingerprint, print_fingerprint
from dcmppi.bench.timing.loop import ClosedLoop, time_cases
from dcmppi.bench.timing.profile import print_profile, profile
from dcmppi.control import defaults

# pytorch_mppi / ours wanted at a size (K, N), and ours on one thread / on two
AGAINST_TARGETS = {(defaults.K, defaults.N): 14, (2048, 100): 12}
THREADS_TARGETS = {(2048, 100): 1.7}


def timings(args):
    """The table (or its JSON): every case's median and p95 ms per step, ratio and target."""
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
        f"in blocks of {min(args.block, args.steps)}"
    )
    header = f"{'case':<21} {'problem':<11} {'median ms':>9} {'p95 ms':>7} {'ratio':>6}"
    print(f"{header}  target")
    for r in rows:
        print(
            f"{r['case']:<21} {r['problem']:<11} {r['median_ms']:9.3f} {r['p95_ms']:7.3f} "
            f"{r['ratio']:6.2f}  {r['target']}"
        )
    return 0


def profile_steps(args):
    """`--profile`: where one step's time goes, per case, in microseconds."""
    results = profile(cases.PROFILE_CASES, args.steps)
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        print_profile(results, args.steps)
    return 0


def fingerprints(args):
    """`--fingerprint`: the hash of every closed loop's actions, with this machine's kernels."""
    rows = fingerprint(cases.FINGERPRINT_CASES, args.steps)
    machine = kernels()
    if args.json:
        print(json.dumps({"steps": args.steps, "kernels": machine, "results": rows}, indent=2))
    else:
        print_fingerprint(rows, args.steps, machine)
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
    from dcmppi.bench.timing import peer

    try:
        peer.require()
    except ImportError as e:
        print(f"dcmppi timing: {e}", file=sys.stderr)
        return 2
    size = dict(perturbation="time_varying", K=args.K, N=args.N)
    ours = ClosedLoop("mppi", "forest", args.steps, **size)
    threaded = None
    if args.threads > 1:
        threaded = ClosedLoop("mppi", "forest", args.steps, threads=args.threads, **size)
    with threadpool_limits(1):  # BLAS on one thread: the plans are the same for any `threads`
        result = peer.compare(ours, args.steps, args.block, threaded)
    if threaded:  # what the machine's cores give any split, beside what ours gained
        result["machine_gains"] = machine_gains(args.threads)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print_against(result, args.steps, args.block)
    return 0


def print_against(result: dict, steps: int, block: int) -> None:
    """The table of `--against` (peer.compare's result): ours, ours threaded, theirs, ratios."""
    v, s = result["versions"], result["settings"]
    print(
        f"dcmppi timing --against pytorch_mppi {v['pytorch_mppi']} (torch {v['torch']}): forest, "
        f"K={s['K']} N={s['N']}, {s['perturbation']} noise, torch and BLAS on one thread, "
        f"{steps} steps interleaved in blocks of {min(block, steps)}"
    )
    print(f"{'controller':<24} {'median ms':>9} {'p95 ms':>7}")
    rows = [("mppi (dcmppi)", result["ours"]), ("pytorch_mppi", result["theirs"])]
    t = result.get("threaded")
    if t:
        rows.insert(1, (f"mppi (dcmppi, threads={t['threads']})", t))
    for name, row in rows:
        print(f"{name:<24} {row['median_ms']:9.3f} {row['p95_ms']:7.3f}")
    target = AGAINST_TARGETS.get((s["K"], s["N"]))
    q = result["theirs_over_ours_blocks"]
    print(
        f"pytorch_mppi / ours = {result['theirs_over_ours']:.1f}"
        + (f" (target >= {target})" if target else "")
        + f", ours / pytorch_mppi = {result['ours_over_theirs']:.3f}; per block of {block} "
        f"steps {q[0]:.1f}-{q[2]:.1f} between the quartiles"
    )
    if t:
        _print_threads(t, result["machine_gains"], s)
    print(f"same problem: {result['same_problem']}")


def _print_threads(t: dict, g: dict, s: dict) -> None:
    """--threads T: ours on one thread over ours on T, and what T threads gain on this machine."""
    target = THREADS_TARGETS.get((s["K"], s["N"])) if t["threads"] == 2 else None
    q = t["speedup_blocks"]
    print(
        f"ours / ours with threads={t['threads']} = {t['speedup']:.2f}"
        + (f" (target >= {target})" if target else "")
        + f", per block {q[0]:.2f}-{q[2]:.2f}; the same path: "
        + ("yes" if t["same_path"] else "NO")
    )
    print(
        f"this machine, {g['threads']} threads at once (the bounds of a split): scalar "
        f"arithmetic {g['compute']:.2f} x, vector arithmetic in L1 {g['vector']:.2f} x, a "
        f"stream beyond L2 {g['stream']:.2f} x"
    )


def profile_experiment(args):
    """`--profile EXPERIMENT`: its bench episodes profiled end to end (episodes); a bad
    experiment, row or world is one line, as in `dcmppi bench`."""
    from dcmppi.bench.episodes.runner import check_specs
    from dcmppi.bench.experiments import load_experiment

    try:
        exp = load_experiment(args.profile)
        sample = exp.select(episodes=min(args.environments, exp.episodes))
        check_specs(spec for _, spec in sample.specs())
    except (ValueError, RuntimeError, OSError) as e:
        print(f"dcmppi timing: error: {e}", file=sys.stderr)
        return 2
    report = episodes.profile_experiment(exp, args.environments, args.workers)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        episodes.print_profile_experiment(report)
    return 0


def scale(args):
    """`--scaling`: print the curves (or the JSON); with --out also write its files."""
    machine = f"{platform.processor() or platform.machine()}, python {platform.python_version()}"
    report = scaling.run(args.steps, args.block, machine)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        scaling.print_scaling(report)
    if args.out:
        try:
            paths = scaling.write(report, args.out)
        except (OSError, RuntimeError) as e:  # RuntimeError: no matplotlib
            print(f"dcmppi timing: error: {e}", file=sys.stderr)
            return 2
        print("wrote " + " and ".join(paths), file=sys.stderr)
    return 0
