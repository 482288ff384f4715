"""The study's Markdown: the table of times, the policies compared, the acceptance checks."""

from __future__ import annotations

import itertools
import math
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from exploration_study.summary import (
    ORACLE,
    TOMOGRAPHIC,
    Cell,
    lookup,
    on_common_seeds,
    oracle_share,
    paired_ratios,
    pooled,
    speedup,
)
from exploration_study.worlds import StudyWorld
from tomosim.sweep import NO_MERGE

Table = dict[tuple[int, str, str], Cell]

SPEEDUP_TARGET = 1.5
"""Merging must bring 4 robots to 90 % at least this many times sooner than none."""
ORACLE_RATIO_TARGET = 1.05
"""... and take at most this many times the oracle's time (the project's exploration target)."""
ORACLE_SHARE_TARGET = 0.9
"""... and save at least this share of the time the oracle saves over no merging."""
BOOTSTRAP_RESAMPLES = 2000
"""Resamples of the episodes behind the interval of a criterion figure."""
BOOTSTRAP_SEED = 0
"""Seed of the resampling, so that a report redrawn from the same rows is the same."""
INTERVAL_PERCENTILES = (5.0, 95.0)
"""The interval reported: the middle 90 % of the resampled figures."""
ACCEPTANCE_TEAM = 4
"""The team size the speed-up and oracle targets are measured with."""
ACES3 = "aces3"
"""The real map on which 4 robots must reach 90 % within the cap."""


def seconds(value: float, cap: float) -> str:
    """A time, ``> cap`` when not reached, ``-`` when missing."""
    if math.isnan(value):
        return "-"
    return f"> {cap:.0f}" if math.isinf(value) else f"{value:.0f}"


def ratio(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.2f}"


def spread(cell: Cell, cap: float) -> str:
    """``min-max`` over seeds; ``> cap`` for the episodes that did not get there."""
    low, high = cell.spread
    if math.isinf(low):
        return "none reached"
    return (
        f"{seconds(low, cap)}-{seconds(high, cap)}"
        if math.isfinite(high)
        else (f"{seconds(low, cap)} to > {cap:.0f}")
    )


def times_table(
    worlds: Sequence[StudyWorld], tables: dict[str, Table], policy: str, robots: Sequence[int]
) -> str:
    """Per world and team size (generated floors pooled first): median time to the target
    per method, speed-ups, the oracle's share, false matches the merger accepted."""
    lines = [
        "| world | robots | no merging [s] | tomographic [s] | oracle [s] | speed-up, "
        "tomographic | speed-up, oracle | tomographic / oracle | share of the oracle's "
        "speed-up | reached (none / tomo / oracle) | false matches accepted |",
        "|---|---:|---|---|---|---:|---:|---:|---:|---|---:|",
    ]
    floors = [w for w in worlds if w.generated and w.label in tables]
    groups: list[tuple[str, list[Table], float]] = []
    if len(floors) > 1:
        cap = max(w.steps for w in floors) * 0.1
        groups.append(("generated floors", [tables[w.label] for w in floors], cap))
    groups += [(w.label, [tables.get(w.label, {})], w.steps * 0.1) for w in worlds]
    for label, chosen, cap in groups:
        for n in robots:
            found = [pooled(chosen, n, policy, m) for m in (NO_MERGE, TOMOGRAPHIC, ORACLE)]
            if all(c is None for c in found):
                continue
            none, tomo, oracle = (c.median if c is not None else math.nan for c in found)
            cells = [
                "-" if c is None else f"{seconds(c.median, cap)} ({spread(c, cap)})" for c in found
            ]
            reached = " / ".join("-" if c is None else f"{c.reached}/{len(c.times)}" for c in found)
            wrong = sum(c.gross_wrong for c in found if c is not None)
            name = f"**{label}**" if len(chosen) > 1 else label
            lines.append(
                f"| {name} | {n} | {' | '.join(cells)} | {ratio(speedup(none, tomo))} "
                f"| {ratio(speedup(none, oracle))} | {ratio(speedup(tomo, oracle))} "
                f"| {ratio(oracle_share(none, tomo, oracle))} | {reached} | {wrong} |"
            )
    return "\n".join(lines)


def policies_table(
    worlds: Sequence[StudyWorld],
    tables: dict[str, Table],
    policies: Sequence[str],
    robots: Sequence[int],
    method: str,
) -> str:
    """Generated floors pooled: median time per policy and team size, with one method, over
    the seeds every policy ran."""
    floors = [tables[w.label] for w in worlds if w.generated and w.label in tables]
    header = " | ".join(f"{p} [s]" for p in policies)
    lines = [
        f"| robots | {header} | overlap rate ({', '.join(policies)}) |",
        "|---:|" + "---|" * (len(policies) + 1),
    ]
    cap = max((w.steps for w in worlds if w.generated), default=1500) * 0.1
    for n in robots:
        found = on_common_seeds([pooled(floors, n, p, method) for p in policies])
        if all(c is None for c in found):
            continue
        times = " | ".join(
            "-" if c is None else f"{seconds(c.median, cap)} ({spread(c, cap)})" for c in found
        )
        overlap = ", ".join("-" if c is None else f"{c.overlap_rate:.2f}" for c in found)
        lines.append(f"| {n} | {times} | {overlap} |")
    return "\n".join(lines)


def comm_table(
    worlds: Sequence[StudyWorld],
    tables: dict[str, Table],
    limited: dict[float, dict[str, Table]],
    policy: str,
    robots: int,
) -> str:
    """Generated floors pooled: median time to the target per communication range."""
    floors = [w.label for w in worlds if w.generated]
    cap = max((w.steps for w in worlds if w.generated), default=1500) * 0.1
    lines = [
        "| communication range | tomographic [s] | oracle [s] | no merging [s] |",
        "|---|---|---|---|",
    ]
    rows = [("unlimited", tables)] + [(f"{metres:g} m", t) for metres, t in limited.items()]
    found = []  # per row, the cell of each method
    for _, t in rows:
        chosen = [t[f] for f in floors if f in t]
        found.append([pooled(chosen, robots, policy, m) for m in (TOMOGRAPHIC, ORACLE)])
    none = pooled([tables[f] for f in floors if f in tables], robots, policy, NO_MERGE)
    flat = on_common_seeds([c for row in found for c in row] + [none])  # the seeds all ran
    for k, (name, _) in enumerate(rows):
        cells = [flat[2 * k], flat[2 * k + 1], flat[-1]]
        if all(c is None for c in cells[:2]):
            continue
        text = ["-" if c is None else f"{seconds(c.median, cap)} ({spread(c, cap)})" for c in cells]
        lines.append(f"| {name} | {' | '.join(text)} |")
    return "\n".join(lines)


def policies_verdict(
    worlds: Sequence[StudyWorld],
    tables: dict[str, Table],
    policies: Sequence[str],
    robots: Sequence[int],
    method: str,
) -> str:
    """One line per policy: the geometric mean, over every team of two or more on the
    generated floors that both ran (same world, size and seed), of its time over the
    first policy's, and how many of those episodes it was faster in."""
    floors = [tables[w.label] for w in worlds if w.generated and w.label in tables]
    if not floors or len(policies) < 2:
        return ""
    base = policies[0]
    lines = []
    for policy in policies[1:]:
        logs = []
        for n in (n for n in robots if n > 1):
            first, second = pooled(floors, n, base, method), pooled(floors, n, policy, method)
            if first is not None and second is not None:
                logs += [math.log(r) for r in paired_ratios(second, first)]
        if logs:
            mean = math.exp(statistics.mean(logs))
            faster = sum(1 for v in logs if v < 0)
            lines.append(
                f"- `{policy}` / `{base}`: {mean:.3f} (geometric mean over {len(logs)} "
                f"episodes; faster in {faster})"
            )
    return "\n".join(lines)


@dataclass(frozen=True, slots=True)
class Check:
    """One acceptance check: what, the figure measured, whether it passes."""

    name: str
    figure: str
    passed: bool | None  # None: not measured yet


def checks(
    worlds: Sequence[StudyWorld], tables: dict[str, Table], policy: str, robots: Sequence[int]
) -> list[Check]:
    """The acceptance checks of the study on what has run so far."""
    floors = [tables[w.label] for w in worlds if w.generated and w.label in tables]
    out = []
    none, tomo, oracle = (
        pooled(floors, ACCEPTANCE_TEAM, policy, m) for m in (NO_MERGE, TOMOGRAPHIC, ORACLE)
    )
    if none is not None and tomo is not None:
        value = speedup(none.median, tomo.median)
        pairs = paired_ratios(none, tomo)
        per_seed = (
            f"; per episode median {statistics.median(pairs):.2f} "
            f"(range {min(pairs):.2f}-{max(pairs):.2f}, {len(pairs)} episodes)"
            if pairs
            else ""
        )
        out.append(
            Check(
                f"generated floors, {ACCEPTANCE_TEAM} robots, {policy}: none / tomographic "
                f">= {SPEEDUP_TARGET}",
                f"{none.median:.1f} s / {tomo.median:.1f} s = {ratio(value)} "
                f"({len(tomo.times)} episodes){per_seed}",
                bool(value >= SPEEDUP_TARGET),
            )
        )
    if tomo is not None and oracle is not None:
        value = speedup(tomo.median, oracle.median)
        pairs = paired_ratios(tomo, oracle)
        per_seed = (
            f"; per episode median {statistics.median(pairs):.2f} "
            f"(range {min(pairs):.2f}-{max(pairs):.2f})"
            if pairs
            else ""
        )
        out.append(
            Check(
                f"generated floors, {ACCEPTANCE_TEAM} robots, {policy}: tomographic / oracle "
                f"<= {ORACLE_RATIO_TARGET}",
                f"{tomo.median:.1f} s / {oracle.median:.1f} s = {ratio(value)}{per_seed}",
                bool(value <= ORACLE_RATIO_TARGET),
            )
        )
    if none is not None and tomo is not None and oracle is not None:
        value = oracle_share(none.median, tomo.median, oracle.median)
        out.append(
            Check(
                f"generated floors, {ACCEPTANCE_TEAM} robots, {policy}: share of the oracle's "
                f"saving over none >= {ORACLE_SHARE_TARGET}",
                f"({none.median:.1f} - {tomo.median:.1f}) / ({none.median:.1f} - "
                f"{oracle.median:.1f}) s = {ratio(value)}",
                bool(value >= ORACLE_SHARE_TARGET),
            )
        )
    medians = []
    for n in robots:
        cell = pooled(floors, n, policy, TOMOGRAPHIC)
        if cell is not None:
            medians.append((n, cell.median))
    if len(medians) >= 2:
        finite = all(math.isfinite(t) for _, t in medians)
        ordered = finite and all(b[1] <= a[1] for a, b in itertools.pairwise(medians))
        cap = max((w.steps for w in worlds if w.generated), default=1500) * 0.1
        figure = ", ".join(f"{n} robots {seconds(t, cap)} s" for n, t in medians)
        out.append(
            Check(
                f"generated floors, {policy}, tomographic: median time does not grow with "
                "team size",
                figure,
                ordered,
            )
        )
    aces = [w for w in worlds if w.label == ACES3 and w.label in tables]
    if aces:
        cell = lookup(tables[ACES3], ACCEPTANCE_TEAM, policy, TOMOGRAPHIC)
        if cell is not None:
            out.append(
                Check(
                    f"aces3, {ACCEPTANCE_TEAM} robots, {policy}, tomographic: 90 % within "
                    f"{aces[0].steps} steps",
                    f"{cell.reached}/{len(cell.times)} episodes; median "
                    f"{seconds(cell.median, aces[0].steps * 0.1)} s",
                    cell.reached == len(cell.times),
                )
            )
    gross = sum(c.gross_wrong for t in tables.values() for c in t.values())
    used = sum(c.gross_wrong_confirmed for t in tables.values() for c in t.values())
    strict = sum(c.wrong for t in tables.values() for c in t.values())
    accepted = sum(c.accepted for t in tables.values() for c in t.values())
    episodes = sum(len(c.times) for t in tables.values() for c in t.values())
    out.append(
        Check(
            "no accepted wrong merge in the study",
            f"{gross} false matches (> 5 deg or > 1 m; {used} of them confirmed and linking "
            f"maps) and {strict} beyond 2 deg / 0.2 m among {accepted} accepted estimates, "
            f"{episodes} episodes",
            gross == 0 if episodes else None,  # no episode: nothing was checked
        )
    )
    return out


Episode = tuple[float, float, float]
"""Times to the target of one start (world and seed): no merging, tomographic, oracle."""


def paired_episodes(none: Cell, tomo: Cell, oracle: Cell) -> list[Episode]:
    """The episodes all three methods ran from the same start, in seed order."""
    by_seed = [dict(zip(c.seeds, c.times, strict=True)) for c in (none, tomo, oracle)]
    shared = sorted(set(by_seed[0]).intersection(by_seed[1], by_seed[2]))
    return [(by_seed[0][s], by_seed[1][s], by_seed[2][s]) for s in shared]


def oracle_ratio_of(episodes: Sequence[Episode]) -> float:
    """Median time of the tomographic merger over the oracle's."""
    return speedup(statistics.median(e[1] for e in episodes),
                   statistics.median(e[2] for e in episodes))  # fmt: skip


def oracle_share_of(episodes: Sequence[Episode]) -> float:
    """Share of the oracle's saving over no merging that the merger reaches (of medians)."""
    none, tomo, oracle = (statistics.median(e[k] for e in episodes) for k in range(3))
    return oracle_share(none, tomo, oracle)


def interval(
    episodes: Sequence[Episode], figure: Callable[[Sequence[Episode]], float]
) -> tuple[float, float]:
    """The middle 90 % of ``figure`` over the episodes resampled with replacement (each
    episode keeps its three methods together)."""
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    picks = rng.integers(len(episodes), size=(BOOTSTRAP_RESAMPLES, len(episodes)))
    values = np.array([figure([episodes[k] for k in pick]) for pick in picks])
    values = values[np.isfinite(values)]
    if not len(values):
        return (math.nan, math.nan)
    low, high = np.percentile(values, INTERVAL_PERCENTILES)
    return float(low), float(high)


def _steps(values: Sequence[float]) -> str:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "-"
    missing = len(values) - len(finite)
    text = f"{statistics.median(finite):.0f} ({min(finite):.0f}-{max(finite):.0f})"
    return text + (f", {missing} never" if missing else "")


def criterion_table(
    worlds: Sequence[StudyWorld], tables: dict[str, Table], policy: str, robots: int
) -> str:
    """The exploration target on the generated floors (pooled, then each floor): the
    tomographic merger's median time over the oracle's and its share of the oracle's
    saving over no merging, each with the interval of :func:`interval`; the per-episode
    ratios; the first round that linked two maps, and the first that linked them all, of
    either method; false matches confirmed and linking maps."""
    lines = [
        "| world | episodes | tomographic / oracle (90 % interval) | share of the oracle's "
        "saving (90 % interval) | per episode tomographic / oracle, median (range) | first "
        "link, tomographic [step] | first link, oracle [step] | all linked, tomographic "
        "[step] | all linked, oracle [step] | false matches linking maps |",
        "|---|---:|---|---|---|---|---|---|---|---:|",
    ]
    floors = [w for w in worlds if w.generated and w.label in tables]
    groups = [("generated floors", floors)] if len(floors) > 1 else []
    groups += [(w.label, [w]) for w in floors]
    for label, chosen in groups:
        found = [pooled([tables[w.label] for w in chosen], robots, policy, m)
                 for m in (NO_MERGE, TOMOGRAPHIC, ORACLE)]  # fmt: skip
        none, tomo, oracle = found
        if none is None or tomo is None or oracle is None:
            continue
        episodes = paired_episodes(none, tomo, oracle)
        if not episodes:
            continue
        ratio_low, ratio_high = interval(episodes, oracle_ratio_of)
        share_low, share_high = interval(episodes, oracle_share_of)
        pairs = paired_ratios(tomo, oracle)
        each = (f"{statistics.median(pairs):.2f} ({min(pairs):.2f}-{max(pairs):.2f})"
                if pairs else "-")  # fmt: skip
        name = f"**{label}**" if len(chosen) > 1 else label
        lines.append(
            f"| {name} | {len(episodes)} | {ratio(oracle_ratio_of(episodes))} "
            f"({ratio(ratio_low)}-{ratio(ratio_high)}) | {ratio(oracle_share_of(episodes))} "
            f"({ratio(share_low)}-{ratio(share_high)}) | {each} | {_steps(tomo.first_links)} "
            f"| {_steps(oracle.first_links)} | {_steps(tomo.all_links)} "
            f"| {_steps(oracle.all_links)} | {tomo.gross_wrong_confirmed} |"
        )
    return "\n".join(lines)


def first_links_table(
    worlds: Sequence[StudyWorld], tables: dict[str, Table], policy: str, robots: int
) -> str:
    """Per episode on the generated floors: the step of the first round that linked two
    maps and of the first that linked them all (``-``: never, or not in the results
    file), tomographic merger beside oracle, and the times to the target."""
    lines = [
        "| world | seed | first link, tomographic [step] | first link, oracle [step] "
        "| all linked, tomographic [step] | all linked, oracle [step] "
        "| no merging [s] | tomographic [s] | oracle [s] | tomographic / oracle |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for world in (w for w in worlds if w.generated and w.label in tables):
        table = tables[world.label]
        none, tomo, oracle = (lookup(table, robots, policy, m)
                              for m in (NO_MERGE, TOMOGRAPHIC, ORACLE))  # fmt: skip
        if tomo is None or oracle is None:
            continue
        links = [dict(zip(c.seeds, c.first_links, strict=True)) for c in (tomo, oracle)]
        links += [dict(zip(c.seeds, c.all_links, strict=False)) for c in (tomo, oracle)]
        times = [dict(zip(c.seeds, c.times, strict=True)) if c is not None else {}
                 for c in (none, tomo, oracle)]  # fmt: skip
        cap = world.steps * 0.1
        for seed in sorted(set(tomo.seeds) & set(oracle.seeds)):
            steps = [links[k].get(seed, math.nan) for k in range(4)]
            shown = ["-" if math.isnan(v) else f"{v:.0f}" for v in steps]
            secs = [seconds(t.get(seed, math.nan), cap) for t in times]
            lines.append(
                f"| {world.label} | {seed} | {' | '.join(shown)} | {' | '.join(secs)} "
                f"| {ratio(speedup(times[1][seed], times[2][seed]))} |"
            )
    return "\n".join(lines)


def checks_markdown(found: Sequence[Check]) -> str:
    mark = {True: "pass", False: "FAIL", None: "not run"}
    lines = ["| check | measured | |", "|---|---|---|"]
    lines += [f"| {c.name} | {c.figure} | {mark[c.passed]} |" for c in found]
    return "\n".join(lines)
