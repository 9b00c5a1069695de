"""`dcmppi outcomes`: do two codes give the same outcomes within chance on the same episodes?

The rule for a change that alters the random draws or the last bits (docs/performance.md, "The
outcome rule"): over the environments both databases finished, per row and noise profile,
the collisions of the old and the new code are paired by environment (the same seed) and
- McNemar's exact test on the discordant environments gives p > 0.05, and
- each collision rate lies inside the other's 95 % Wilson interval.
Failures of any kind (collision, time limit, leaving the map) are shown beside, the same way.
Beside the rule, `joint` tests all rows at once (Holm's step-down over the McNemar p-values,
5 % family-wise): one change of draws fails some row's own test by chance far more often than
5 % when there are many rows (docs/performance.md, "The outcome rule": a pure re-draw fails
1.45 of 15 rows on average).
"""

from __future__ import annotations

from dataclasses import dataclass

from dcmppi.bench.reports.report import load
from dcmppi.bench.results.stats import mcnemar_exact, noise_order, wilson

ALPHA = 0.05


@dataclass(frozen=True)
class Comparison:
    """One row and noise profile, old code against new, on `pairs` paired environments."""

    noise: str
    label: str
    pairs: int
    old: int  # collisions
    new: int
    only_old: int  # environments where only the old code collided
    only_new: int
    p: float  # McNemar's exact p-value on the discordant environments
    old_failures: int
    new_failures: int

    @property
    def inside(self) -> bool:
        """Each collision rate inside the other's 95 % Wilson interval."""
        lo_old, hi_old = wilson(self.old, self.pairs)
        lo_new, hi_new = wilson(self.new, self.pairs)
        return (
            lo_old <= self.new / self.pairs <= hi_old and lo_new <= self.old / self.pairs <= hi_new
        )

    @property
    def holds(self) -> bool:
        return self.p > ALPHA and self.inside


def compare(old_paths, new_paths) -> list[Comparison]:
    """The comparisons of every (noise, label) the two sides share, in the experiment's order.

    old_paths, new_paths: a database path or a list of them (shards of one side). Raises
    ValueError (one line) when they hold different experiments, configurations (task, seeds,
    task and controller parameters, a compared row's controller and parameters), or share no
    episode.
    """
    old, new = load(old_paths), load(new_paths)
    _check_configurations(old.exp, new.exp)
    groups = _pairs(old.rows, new.rows)
    if not groups:
        raise ValueError("the old and the new databases share no finished episode")
    rows_old = {row.label: (row.controller, row.params) for row in old.exp.rows}
    rows_new = {row.label: (row.controller, row.params) for row in new.exp.rows}
    for label in sorted({label for _, label in groups}):
        if rows_old.get(label) != rows_new.get(label):
            raise ValueError(
                f"row {label!r} ran {rows_old.get(label)} in the old databases and "
                f"{rows_new.get(label)} in the new (controller, parameters): run both with the "
                "same rows"
            )
    rows = [row.label for row in old.exp.rows]
    order = sorted(
        groups,
        key=lambda k: (noise_order(k[0]), rows.index(k[1]) if k[1] in rows else len(rows), k[1]),
    )
    return [_comparison(noise, label, groups[noise, label]) for noise, label in order]


def _check_configurations(old, new) -> None:
    """Refuse two sides of different experiments or configurations (ValueError, one line)."""
    if old.name != new.name:
        raise ValueError(
            f"the old databases hold experiment {old.name!r} and the new {new.name!r}; "
            "compare runs of one experiment"
        )
    for field in (
        "task",
        "base_seed",
        "env_param",
        "env_offset",
        "task_params",
        "controller_params",
    ):
        a, b = getattr(old, field), getattr(new, field)
        if a != b:
            raise ValueError(
                f"the old databases ran {field} {a!r} and the new {b!r}: the rule pairs two codes "
                "on the same episodes; run both with the same configuration"
            )


def _pairs(old: list[dict], new: list[dict]) -> dict[tuple[str, str], list[tuple[dict, dict]]]:
    """{(noise, label): [(old row, new row)]} of the episodes both sides finished; a pair of
    different seeds raises ValueError."""
    done = {(r["noise"], r["label"], r["env_index"]): r for r in new if r["status"] == "ok"}
    groups = {}
    for a in old:
        key = (a["noise"], a["label"], a["env_index"])
        b = done.get(key)
        if a["status"] != "ok" or b is None:
            continue
        if a["seed"] != b["seed"]:
            raise ValueError(
                f"{'/'.join(map(str, key))} has seed {a['seed']} in the old databases and "
                f"{b['seed']} in the new; compare runs with the same base seed"
            )
        groups.setdefault(key[:2], []).append((a, b))
    return groups


def _comparison(noise: str, label: str, pairs: list[tuple[dict, dict]]) -> Comparison:
    only_old = sum(bool(a["collision"]) and not b["collision"] for a, b in pairs)
    only_new = sum(bool(b["collision"]) and not a["collision"] for a, b in pairs)
    return Comparison(
        noise=noise,
        label=label,
        pairs=len(pairs),
        old=sum(bool(a["collision"]) for a, _ in pairs),
        new=sum(bool(b["collision"]) for _, b in pairs),
        only_old=only_old,
        only_new=only_new,
        p=mcnemar_exact(only_old, only_new),
        old_failures=sum(bool(a["failure"]) for a, _ in pairs),
        new_failures=sum(bool(b["failure"]) for _, b in pairs),
    )


def table(comparisons: list[Comparison]) -> str:
    """The comparisons as a Markdown table."""
    lines = [
        "| noise | row | envs | collisions old | new | only old / only new | McNemar p | "
        "inside each other's 95 % CI | failures old | new | rule |",
        "|---|---|---:|---:|---:|---:|---:|---|---:|---:|---|",
    ]
    for c in comparisons:
        lines.append(
            f"| {c.noise} | {c.label} | {c.pairs} | {c.old} | {c.new} | {c.only_old} / "
            f"{c.only_new} | {c.p:.2f} | {'yes' if c.inside else 'no'} | {c.old_failures} | "
            f"{c.new_failures} | {'holds' if c.holds else 'FAILS'} |"
        )
    return "\n".join(lines)


def joint(comparisons: list[Comparison]) -> str:
    """One line: do all rows hold together under Holm's step-down over their McNemar p-values
    (family-wise error ALPHA)? The rows that Holm rejects are named."""
    m = len(comparisons)
    ranked = sorted(comparisons, key=lambda c: c.p)
    rejected = []
    for i, c in enumerate(ranked):
        if c.p > ALPHA / (m - i):
            break
        rejected.append(f"{c.label} ({c.noise}, p = {c.p:.3g})")
    head = f"joint test over {m} rows (Holm, McNemar, {ALPHA:.0%} family-wise): "
    if rejected:
        return head + "differ: " + ", ".join(rejected)
    return (
        head + f"the same within chance (smallest p = {ranked[0].p:.3g}, threshold {ALPHA / m:.3g})"
    )
