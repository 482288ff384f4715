"""Study: what merging is worth to a team exploring, against no merging and known poses.

Sweeps (:mod:`tomosim.sweep`, a process pool or Ray) of the built-in
exploration over worlds (generated floors and real buildings), team sizes,
exploration policies, merge methods (``none``: merging off, the lower bound;
``tomographic``: the default merger; ``oracle``: merging with the true
relative start poses, the upper bound any merger can reach) and seeds. Every
finished episode appends a row to ``<out>/episodes_<world>.csv`` at once; rerunning
the same command skips the episodes already there, so the study can be
stopped and resumed at will, and ``--report-only`` redraws the outputs from
what has run.

Episodes run in stages, the most telling first (stages are ordered, each
runs what it lacks, and anything else the grid asks for comes last):

1. generated floors, 4 robots, the default policy, every method;
2. generated floors, every team size, the default policy;
3. ``aces3``, 4 robots, the default policy;
4. generated floors, 4 robots, the default policy, with each communication
   range of ``--comm-ranges`` (merging methods only: merging off does not
   talk);
5. the other real maps (``fr079``), 4 robots, the default policy;
6. real maps, every team size, the default policy;
7. generated floors, the other policies;
8. the rest of the grid (real maps' other policies).

Outputs in ``--out``: the CSVs, ``study_exploration.md`` (tables, the
acceptance checks, and the tomographic merger against the oracle: time
ratio, share of the oracle's saving and first linking step, per episode
and with intervals over the episodes) and two PNGs (time to 90 % against team size; speed-up of
merging and the share of the oracle's speed-up the tomographic merger reaches).

Usage::

    python scripts/study_exploration.py                          # the whole study
    python scripts/study_exploration.py --worlds 0 1 2 --robots 4 --seeds 0 1 2 3
    python scripts/study_exploration.py --report-only            # tables and plots only
    python scripts/study_exploration.py --worlds 0 --robots 4 --team confirmations=3 --out c3

``--team NAME=VALUE`` (repeatable) sets a team setting by its dotted name for
every episode (:mod:`tomosim.team.overrides`); a setting only one method uses
acts on that method's episodes: the default merger's ``merger.*``, the
oracle's ``oracle_*`` (``--team oracle_min_shared_m2=10``: an oracle that
waits until a pair's maps share 10 m²). The folder records them in
``team_settings.json`` and refuses to resume with others.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from exploration_study.plots import gains_figure, times_figure
from exploration_study.report import (
    checks,
    checks_markdown,
    comm_table,
    criterion_table,
    first_links_table,
    policies_table,
    policies_verdict,
    times_table,
)
from exploration_study.runs import Grid, progress, read_rows, run_world
from exploration_study.summary import ORACLE, TOMOGRAPHIC, cells
from exploration_study.worlds import DEFAULT_WORLDS, StudyWorld, resolve

from merging.settings import parse_assignments
from merging.validators import one_of
from tomosim.commands import UsageError
from tomosim.commands.script_args import non_negative_int, positive_float, positive_int, run_script
from tomosim.commands.team_options import check_methods_option, check_methods_use
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.sweep import EXECUTORS, NO_MERGE
from tomosim.team import TeamConfig, team_methods
from tomosim.team.overrides import changed_settings, with_settings

OUTPUT = Path(__file__).resolve().parents[1] / "docs" / "figures" / "study_exploration"
"""Default folder of the outputs."""
ROBOTS = (1, 2, 4, 6)
METHODS = (NO_MERGE, TOMOGRAPHIC, ORACLE)
SEEDS = (0, 1, 2, 3)
COMM_RANGES = (10.0, 5.0)
"""Communication ranges (metres) of the fourth stage: a room or two, and a few metres."""
CORE_TEAM = 4
"""The team size of the first, third and fourth stages."""


def stages(
    worlds: list[StudyWorld], grid: Grid, policy: str, comm_ranges: tuple[float, ...]
) -> list[tuple[StudyWorld, Grid]]:
    """The study's runs in order of importance (module docstring)."""
    floors = [w for w in worlds if w.generated]
    real = [w for w in worlds if not w.generated]
    core = tuple(n for n in grid.robots if n == CORE_TEAM)
    others = tuple(p for p in grid.policies if p != policy)
    mine = (policy,) if policy in grid.policies else ()
    aces3 = [w for w in real if w.label == "aces3"]

    def part(robots: tuple[int, ...], policies: tuple[str, ...], comm: float | None = None) -> Grid:
        return Grid(robots, policies, grid.methods, grid.seeds, grid.alone, comm, grid.team)

    out: list[tuple[StudyWorld, Grid]] = []
    if mine:
        out += [(w, part(core, mine)) for w in floors]
        out += [(w, part(grid.robots, mine)) for w in floors]
        out += [(w, part(core, mine)) for w in aces3]
        out += [(w, part(core, mine, r)) for r in comm_ranges for w in floors]
        out += [(w, part(core, mine)) for w in real if w not in aces3]
        out += [(w, part(grid.robots, mine)) for w in real]
    if others:
        out += [(w, part(grid.robots, others)) for w in floors]
    out += [(w, grid) for w in worlds]
    return [(w, g) for w, g in out if g.robots]


def report(
    worlds: list[StudyWorld], grid: Grid, policy: str, comm_ranges: tuple[float, ...], out: Path
) -> str:
    """Write the Markdown and the figures from the rows so far; returns the Markdown."""
    rows = read_rows(out, worlds)
    tables = {label: cells(r) for label, r in rows.items() if r}
    limited = {}
    for metres in comm_ranges:
        found = read_rows(out, worlds, metres)
        limited[metres] = {label: cells(r) for label, r in found.items() if r}
    changed = changed_settings(grid.team)
    named = ", ".join(f"`{name}={value}`" for name, value in changed.items())
    text = [
        f"# Exploration study: time to 90 % coverage, policy `{policy}`",
        "",
        *([f"Team settings changed (`--team`): {named}.", ""] if changed else []),
        "Median over seeds (min-max in brackets) of the simulated seconds until the team "
        "knows 90 % of the free space; `> cap`: half the episodes or fewer got there.",
        "",
        times_table(worlds, tables, policy, grid.robots),
        "",
        "## Policies (generated floors pooled, tomographic merging)",
        "",
        policies_table(worlds, tables, grid.policies, grid.robots, TOMOGRAPHIC),
        "",
        "Time to 90 % against the first policy's, same world, team and seed (teams of 2 and more):",
        "",
        policies_verdict(worlds, tables, grid.policies, grid.robots, TOMOGRAPHIC),
        "",
        "## Policies (generated floors pooled, no merging)",
        "",
        policies_table(worlds, tables, grid.policies, grid.robots, NO_MERGE),
        "",
        f"## Communication range (generated floors pooled, {CORE_TEAM} robots)",
        "",
        comm_table(worlds, tables, limited, policy, CORE_TEAM),
        "",
        "## Acceptance checks",
        "",
        checks_markdown(checks(worlds, tables, policy, grid.robots)),
        "",
        f"## Against the oracle (generated floors, {CORE_TEAM} robots)",
        "",
        "Intervals: the middle 90 % over the episodes resampled with replacement "
        "(each with its three methods). The first link is the step of the first merge "
        "round that linked two maps, all linked that of the first that linked every "
        "robot's map into one, median (range) over the episodes (never: the target was "
        "reached first; -: not in the results files).",
        "",
        criterion_table(worlds, tables, policy, CORE_TEAM),
        "",
        "Per episode:",
        "",
        first_links_table(worlds, tables, policy, CORE_TEAM),
        "",
        "## Progress: episodes in the results files, of those the study plans",
        "",
        progress_table(worlds, grid, policy, comm_ranges, out),
        "",
    ]
    markdown = "\n".join(text)
    (out / "study_exploration.md").write_text(markdown)
    times_figure(worlds, tables, policy, grid.robots, out / "time_to_90.png")
    gains_figure(worlds, tables, policy, grid.robots, out / "merging_gains.png")
    return markdown


def progress_table(
    worlds: list[StudyWorld], grid: Grid, policy: str, comm_ranges: tuple[float, ...], out: Path
) -> str:
    """Per world, the episodes run so far of those the study's stages plan."""
    lines = ["| world | done | planned |", "|---|---:|---:|"]
    for world in worlds:
        parts = [g for w, g in stages(worlds, grid, policy, comm_ranges) if w == world]
        done, planned = progress(world, parts, out)
        lines.append(f"| {world.label} | {done} | {planned} |")
    return "\n".join(lines)


TEAM_FILE = "team_settings.json"
"""The file in ``--out`` naming the team settings its episodes ran with (none: the defaults)."""


def study_team(
    pairs: list[str], out: Path, methods: list[str], robots: tuple[int, ...] = ROBOTS
) -> TeamConfig:
    """The team ``--team`` asks for; :class:`UsageError` for a bad setting, one that none of
    ``methods`` uses (``oracle_min_shared_m2`` without the oracle) or that no episode of
    team sizes ``robots`` would use (a robot alone runs with merging off), or a folder
    whose episodes ran with other settings (resuming would mix two teams' rows). A
    setting of one method acts on that method's episodes only."""
    try:
        settings = parse_assignments(pairs, option="--team", example="confirmations=3")
    except ValueError as error:
        raise UsageError(str(error)) from None
    if "comms.range" in settings:
        raise UsageError("--team comms.range: the study's ranges are --comm-ranges")
    try:
        team = with_settings(TeamConfig(), settings)
    except ValueError as error:
        raise UsageError(f"--team: {error}") from None
    try:
        for method in methods:
            one_of(method, (*team_methods(), NO_MERGE), what="merging method")
    except ValueError as error:
        raise UsageError(f"--methods: {error}") from None
    check_methods_option(team, methods)
    if all(size == 1 for size in robots):
        sizes = " ".join(str(size) for size in robots)
        check_methods_use(
            team,
            [],
            chosen=f"--robots {sizes} (a robot alone explores with merging off)",
            fix="add a team size above 1 to --robots",
        )
    recorded = out / TEAM_FILE
    before = json.loads(recorded.read_text()) if recorded.is_file() else {}
    now = json.loads(json.dumps(changed_settings(team)))
    has_rows = any(out.glob("episodes_*.csv"))
    if has_rows and before != now:
        raise UsageError(
            f"{out} holds episodes run with team settings {before or 'the defaults'}, not "
            f"{now or 'the defaults'}; give another --out for these settings"
        )
    return team


def record_team(team: TeamConfig, out: Path) -> None:
    """Write the team settings the study changed to ``out`` (``{}``: the defaults), so that
    the next run into ``out`` can tell whether it runs the same team."""
    (out / TEAM_FILE).write_text(json.dumps(changed_settings(team), indent=2) + "\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--worlds", nargs="+", default=list(DEFAULT_WORLDS),
        help="generated floor seeds, names of shared maps or YAML files",
    )  # fmt: skip
    parser.add_argument("--robots", nargs="+", type=positive_int, default=list(ROBOTS))
    parser.add_argument("--policies", nargs="+", default=list(chooser_names()))
    parser.add_argument(
        "--policy", default=DEFAULT_POLICY,
        help=f"the policy the tables and checks are about (default {DEFAULT_POLICY})",
    )  # fmt: skip
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--seeds", nargs="+", type=non_negative_int, default=list(SEEDS))
    parser.add_argument("--steps", type=int, help="step cap of every world (default: per world)")
    parser.add_argument(
        "--comm-ranges", nargs="*", type=positive_float, default=list(COMM_RANGES),
        metavar="METRES",
        help="communication ranges of the fourth stage (default: 10 5; none: skip it)",
    )  # fmt: skip
    parser.add_argument("--executor", choices=EXECUTORS, default="process")
    parser.add_argument("--workers", type=positive_int, help="local processes (default: all cores)")
    parser.add_argument(
        "--team", action="append", default=[], metavar="NAME=VALUE",
        help="a team setting by its dotted name for every episode, e.g. "
        "merger.confidence.accept=0.7 (repeatable; a folder holds one team's episodes)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, default=OUTPUT, help="folder of the outputs")
    parser.add_argument("--report-only", action="store_true", help="run nothing, only report")
    args = parser.parse_args(argv)
    team = study_team(args.team, args.out, args.methods, tuple(args.robots))
    if args.steps is not None and args.steps < 1:
        parser.error(f"--steps must be at least 1, got {args.steps}")
    unknown = [p for p in (*args.policies, args.policy) if p not in chooser_names()]
    if unknown:
        parser.error(f"unknown policy {unknown[0]!r}; choose from {', '.join(chooser_names())}")
    worlds = [resolve(token, args.steps) for token in args.worlds]
    grid = Grid(
        tuple(args.robots),
        tuple(args.policies),
        tuple(args.methods),
        tuple(args.seeds),
        args.policy,
        team=team,
    )
    args.out.mkdir(parents=True, exist_ok=True)
    record_team(team, args.out)
    if not args.report_only:
        try:
            for world, part in stages(worlds, grid, args.policy, tuple(args.comm_ranges)):
                run_world(world, part, args.out, executor=args.executor, workers=args.workers)
        except KeyboardInterrupt:
            print("interrupted: rerun the same command to resume", file=sys.stderr)
    print(report(worlds, grid, args.policy, tuple(args.comm_ranges), args.out))
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
