"""``tomosim sweep``: many seeded episodes over a grid of worlds, team sizes and methods.

Every combination of ``--worlds``, ``--robots``, ``--policies``, ``--methods``
and ``--seeds`` is one episode of the built-in exploration (as ``tomosim
explore`` runs it).
Episodes run on a local process pool (``--executor process``, the default) or
on Ray (``--executor ray``, ``pip install "tomosim[ray]"``; ``--ray-address``
joins a running cluster, otherwise a local Ray is started). Each finished
episode appends a row to the CSV file ``--out`` at once, so a killed sweep
loses nothing; ``--resume`` runs only the episodes not yet in the file. A
sweep locks its file: a second sweep on the same ``--out`` refuses.

Progress shows episodes done and, inside running episodes, their step and
coverage (a bar on a terminal, a line every few seconds elsewhere).
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path
from typing import Any

from tomosim.commands import (
    CommandError,
    UsageError,
    check_world,
    check_writable,
    one_line,
    world_spec,
)
from tomosim.commands.explore import MAX_ROBOTS, check_episode_options
from tomosim.commands.progress import Progress
from tomosim.commands.stopping import Stopped, raise_if_stopped, stop_behind
from tomosim.commands.team_options import add_team_arguments, check_methods_option, team_config
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.kernels.jit import interrupts_unwrapped
from tomosim.sweep import EXECUTORS, NO_MERGE, ResultsFile, SweepPlan, WorkerDied, run_sweep
from tomosim.team import team_methods

NAME = "sweep"
"""The subcommand's name."""
HELP = "run many seeded episodes (worlds x robots x policies x methods x seeds), locally or on Ray"
"""One line for ``tomosim --help``."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    plan = SweepPlan()
    methods = ", ".join([*team_methods(), NO_MERGE])
    parser.add_argument(
        "--worlds", nargs="+", default=list(plan.worlds), metavar="WORLD",
        help="generated floor-plan seeds, map names ('tomosim maps') and/or map_server YAML files "
        f"(default: {' '.join(plan.worlds)})",
    )  # fmt: skip
    parser.add_argument(
        "--robots", nargs="+", type=int, default=list(plan.robots), metavar="N",
        help=f"team sizes, 1 to {MAX_ROBOTS} (default: {' '.join(map(str, plan.robots))})",
    )  # fmt: skip
    parser.add_argument(
        "--policies", nargs="+", default=list(plan.policies), metavar="POLICY",
        help=f"exploration policies: {', '.join(chooser_names())} (default: {DEFAULT_POLICY})",
    )  # fmt: skip
    parser.add_argument(
        "--methods", nargs="+", default=list(plan.methods), metavar="METHOD",
        help=f"merging methods: {methods} ('{NO_MERGE}': merging off, 'oracle': the true "
        "start poses; "
        f"default: {' '.join(plan.methods)})",
    )  # fmt: skip
    parser.add_argument(
        "--seeds", nargs="+", type=int, default=list(plan.seeds), metavar="SEED",
        help=f"episode seeds (default: {' '.join(map(str, plan.seeds))})",
    )  # fmt: skip
    parser.add_argument(
        "--steps", type=int, default=plan.steps,
        help=f"most steps of 0.1 s per episode (default {plan.steps})",
    )  # fmt: skip
    parser.add_argument(
        "--coverage-target", type=float, default=plan.coverage_target,
        help="an episode ends when the team knows this fraction of the free space "
        f"(default {plan.coverage_target})",
    )  # fmt: skip
    parser.add_argument(
        "--world-size", nargs=2, type=float, metavar=("WIDTH", "HEIGHT"),
        help="size in metres of generated floor plans (default 30 20)",
    )  # fmt: skip
    add_team_arguments(parser)
    parser.add_argument(
        "--out", type=Path, required=True,
        help="CSV file the rows go to, one per finished episode; its folder must exist",
    )  # fmt: skip
    parser.add_argument(
        "--resume", action="store_true",
        help="keep the rows already in --out and run only the missing episodes",
    )  # fmt: skip
    parser.add_argument(
        "--executor", choices=EXECUTORS, default="process",
        help="a local process pool, or Ray (default process)",
    )  # fmt: skip
    parser.add_argument(
        "--workers", type=int,
        help="local processes, or CPUs of a local Ray (default: all cores)",
    )  # fmt: skip
    parser.add_argument(
        "--ray-address", help="address of a running Ray cluster, e.g. auto (default: start one)"
    )
    parser.add_argument(
        "--record-dir", type=Path, metavar="DIR",
        help="write one .rrd per episode into this folder (created if its parent exists)",
    )  # fmt: skip


def build_plan(args: argparse.Namespace) -> SweepPlan:
    """The sweep the command line asks for; :class:`UsageError` when it cannot be."""
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    if args.ray_address is not None and args.executor != "ray":
        raise UsageError("--ray-address needs --executor ray")
    too_many = [n for n in args.robots if not 1 <= n <= MAX_ROBOTS]
    if too_many:
        raise UsageError(
            f"--robots must be from 1 to {MAX_ROBOTS}, got {too_many[0]} (a merge round "
            f"estimates every pair of maps: {MAX_ROBOTS * (MAX_ROBOTS - 1) // 2} pairs at "
            f"{MAX_ROBOTS} robots)"
        )
    for world in args.worlds:
        world_spec(world, option="--worlds")
    negative = [seed for seed in args.seeds if seed < 0]
    if negative:
        raise UsageError(f"--seeds must be non-negative integers, got {negative[0]}")
    if args.world_size is not None and not all(
        math.isfinite(side) and side > 0 for side in args.world_size
    ):
        sides = " ".join(map(str, args.world_size))
        raise UsageError(f"--world-size must be two positive numbers of metres, got {sides}")
    check_episode_options(args)
    team = team_config(args)
    if args.record_dir is not None and args.record_dir.exists() and not args.record_dir.is_dir():
        raise UsageError(f"--record-dir {args.record_dir} is a file; give a folder")
    try:
        plan = SweepPlan(
            worlds=tuple(args.worlds),
            robots=tuple(args.robots),
            policies=tuple(args.policies),
            methods=tuple(args.methods),
            seeds=tuple(args.seeds),
            steps=args.steps,
            coverage_target=args.coverage_target,
            world_size=None if args.world_size is None else tuple(args.world_size),
            team=team,
            record_dir=args.record_dir,
        )
    except ValueError as exc:
        raise UsageError(one_line(exc)) from exc
    # After the plan has checked the method names, so that a misspelt one is named as such.
    check_methods_option(team, plan.methods)
    return plan


def run(args: argparse.Namespace) -> int:
    """Run the sweep; returns the exit status."""
    plan = build_plan(args)
    try:
        episodes = plan.episodes()
    except ValueError as exc:
        raise UsageError(one_line(exc)) from exc
    for world in plan.worlds:
        check_world(world_spec(world, option="--worlds"), option="--worlds")
    check_writable(args.out, option="--out")
    if args.record_dir is not None and not args.record_dir.absolute().parent.is_dir():
        raise CommandError(
            f"cannot write into {args.record_dir}: folder {args.record_dir.absolute().parent} "
            "does not exist; create it or give --record-dir another path"
        )
    if args.record_dir is not None:  # it or, when it is still to be made, its parent
        folder = args.record_dir if args.record_dir.is_dir() else args.record_dir.absolute().parent
        if not os.access(folder, os.W_OK | os.X_OK):
            raise CommandError(
                f"cannot write into {args.record_dir}: folder {folder} is not writable; give "
                "--record-dir a folder you can write to"
            )
    progress = Progress(len(episodes), "episode", label=NAME)
    running: dict[str, tuple[int, float]] = {}

    def detail() -> str:
        if not running:
            return ""
        shown = "; ".join(f"{k} step {s} coverage {c:.2f}" for k, (s, c) in running.items())
        return f"running {shown}"

    def start(planned: int, skipped: int) -> None:
        progress.update(skipped, detail())

    def step(key: str, at: int, coverage: float) -> None:
        running[key] = (at, coverage)
        progress.update(progress.done, detail())
        raise_if_stopped()

    def finished(row: dict[str, Any]) -> None:
        running.pop(row["key"], None)
        progress.update(progress.done + 1, detail())
        raise_if_stopped()

    try:
        with interrupts_unwrapped():
            outcome = run_sweep(
                plan, args.out, executor=args.executor, workers=args.workers,
                resume=args.resume, ray_address=args.ray_address, progress=finished,
                on_start=start, on_step=step,
            )  # fmt: skip
    except BaseException as exc:
        progress.close()
        interrupt = stop_behind(exc)
        if interrupt is not None:
            try:
                rows = len(ResultsFile(args.out).rows())
            except (OSError, ValueError):
                rows = 0
            raise Stopped.of(
                interrupt,
                f"{rows} of {len(episodes)} episodes are in {args.out}; run the same command "
                "with --resume to run the rest",
            ) from None
        if isinstance(exc, MemoryError):
            raise CommandError(
                f"out of memory ({one_line(exc)}): use smaller worlds or fewer --workers; "
                "the rows written so far are kept (--resume goes on)"
            ) from exc
        if isinstance(exc, ValueError | ImportError | OSError | WorkerDied):
            raise CommandError(one_line(exc)) from exc
        raise
    progress.close(f"{outcome.ran} run, {outcome.skipped} already done")
    print(
        f"{outcome.ran} episodes run, {outcome.skipped} already done, "
        f"{outcome.planned} planned; rows in {outcome.results}"
    )
    return 0
