"""``tomosim sweep``: many seeded episodes over a grid of worlds, team sizes and methods.

Every combination of ``--worlds``, ``--robots``, ``--policies``, ``--methods``
and ``--seeds`` is one episode of the built-in exploration (as ``tomosim
explore`` runs it).
Episodes run on a local process pool (``--executor process``, the default) or
on Ray (``--executor ray``, ``pip install "tomosim[ray]"``; ``--ray-address``
joins a running cluster, otherwise a local Ray is started). Each finished
episode appends a row to the CSV file ``--out`` at once, so a killed sweep
loses nothing; ``--resume`` runs only the episodes not yet in the file.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from tomosim.commands import CommandError, UsageError, one_line
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.sweep import EXECUTORS, NO_MERGE, SweepPlan, run_sweep
from tomosim.team import team_methods

NAME = "sweep"
"""The subcommand's name."""
HELP = "run many seeded episodes (worlds x robots x policies x methods x seeds), locally or on Ray"
"""One line for ``tomosim --help``."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    plan = SweepPlan()
    parser.add_argument(
        "--worlds", nargs="+", default=list(plan.worlds),
        help="generated floor-plan seeds and/or map_server YAML files (default: 0)",
    )  # fmt: skip
    parser.add_argument("--robots", nargs="+", type=int, default=list(plan.robots))
    parser.add_argument(
        "--policies", nargs="+", default=list(plan.policies), metavar="POLICY",
        help=f"exploration policies: {', '.join(chooser_names())} (default: {DEFAULT_POLICY})",
    )  # fmt: skip
    parser.add_argument(
        "--methods", nargs="+", default=list(plan.methods),
        help=f"merging methods ({', '.join(team_methods())}), '{NO_MERGE}' for merging off "
        "(default: tomographic)",
    )  # fmt: skip
    parser.add_argument("--seeds", nargs="+", type=int, default=list(plan.seeds))
    parser.add_argument("--steps", type=int, default=plan.steps, help="most steps per episode")
    parser.add_argument("--merge-interval", type=int, default=plan.merge_interval)
    parser.add_argument("--coverage-target", type=float, default=plan.coverage_target)
    parser.add_argument(
        "--world-size", nargs=2, type=float, metavar=("WIDTH", "HEIGHT"),
        help="size in metres of generated floor plans (default 30 20)",
    )  # fmt: skip
    parser.add_argument(
        "--comm-range", type=float, metavar="METRES",
        help="robots talk only within this range, or through teammates in range "
        "(default unlimited)",
    )  # fmt: skip
    parser.add_argument(
        "--line-of-sight", action="store_true", help="walls block communication"
    )  # fmt: skip
    parser.add_argument("--out", type=Path, required=True, help="CSV file the rows go to")
    parser.add_argument("--resume", action="store_true", help="skip episodes already in --out")
    parser.add_argument("--executor", choices=EXECUTORS, default="process")
    parser.add_argument("--workers", type=int, help="local processes or CPUs (default: all)")
    parser.add_argument("--ray-address", help="address of a running Ray cluster, e.g. auto")
    parser.add_argument("--record-dir", type=Path, help="write one .rrd per episode here")


def run(args: argparse.Namespace) -> int:
    """Run the sweep; returns the exit status."""
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    if args.ray_address is not None and args.executor != "ray":
        raise UsageError("--ray-address needs --executor ray")
    try:
        plan = SweepPlan(
            worlds=tuple(args.worlds),
            robots=tuple(args.robots),
            policies=tuple(args.policies),
            methods=tuple(args.methods),
            seeds=tuple(args.seeds),
            steps=args.steps,
            merge_interval=args.merge_interval,
            coverage_target=args.coverage_target,
            world_size=None if args.world_size is None else tuple(args.world_size),
            comm_range=args.comm_range,
            line_of_sight=args.line_of_sight,
            record_dir=args.record_dir,
        )
        episodes = plan.episodes()
    except ValueError as exc:
        raise UsageError(one_line(exc)) from exc
    bar = tqdm(total=len(episodes), unit="episode", file=sys.stderr, disable=None)

    def start(planned: int, skipped: int) -> None:
        bar.update(skipped)

    def progress(row: dict[str, Any]) -> None:
        bar.update(1)
        bar.set_postfix_str(f"{row['key']} coverage {float(row['coverage']):.2f}")

    try:
        outcome = run_sweep(
            plan, args.out, executor=args.executor, workers=args.workers, resume=args.resume,
            ray_address=args.ray_address, progress=progress, on_start=start,
        )  # fmt: skip
    except (ValueError, ImportError, FileNotFoundError, OSError) as exc:
        raise CommandError(one_line(exc)) from exc
    finally:
        bar.close()
    print(
        f"{outcome.ran} episodes run, {outcome.skipped} already done, "
        f"{outcome.planned} planned; rows in {outcome.results}"
    )
    return 0
