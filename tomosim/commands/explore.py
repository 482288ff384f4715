"""``tomosim explore``: robots explore a world with periodic map merging, recorded for review.

Runs one episode of frontier exploration (:func:`tomosim.episode.run_episode`):
three robots on the default generated floor plan, coordinated by the default
policy, merging every 50 steps with the tomographic method, until the team
knows 90 % of the free space. It shows a
progress bar, records the episode to an ``.rrd`` file, and ends with a summary:
coverage, steps, and per pair the merges accepted and their errors against the
simulator's truth (or JSON with ``--json``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
from pathlib import Path

from PIL import Image
from tqdm import tqdm

from merging.api import DEFAULT_METHOD
from tomosim.commands import CommandError, UsageError, one_line
from tomosim.commands.explore_report import render_summary
from tomosim.episode import DEFAULT_WORLD_SEED, EpisodeConfig, run_episode
from tomosim.exploration import chooser_names
from tomosim.team import ORACLE, team_methods

NAME = "explore"
"""The subcommand's name."""
HELP = "robots explore a world, merging their maps; records an .rrd and prints a summary"
"""One line for ``tomosim --help``."""
DEFAULTS = EpisodeConfig()
"""The episode run without options."""
DEFAULT_RECORD = Path("explore.rrd")
"""Recording written unless ``--record`` names another file."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    parser.add_argument(
        "--world",
        default=str(DEFAULT_WORLD_SEED),
        help="a generated floor plan's seed, or a map_server YAML file "
        f"(default: floor plan {DEFAULT_WORLD_SEED})",
    )
    parser.add_argument(
        "--robots", type=int, default=DEFAULTS.robots, help=f"default {DEFAULTS.robots}"
    )
    parser.add_argument(
        "--policy",
        default=DEFAULTS.policy,
        help=f"how robots choose frontiers: {', '.join(chooser_names())} "
        f"(default {DEFAULTS.policy})",
    )
    parser.add_argument(
        "--steps",
        type=int,
        default=DEFAULTS.steps,
        help=f"most steps of 0.1 s to run (default {DEFAULTS.steps})",
    )
    parser.add_argument(
        "--merge-interval",
        type=int,
        default=DEFAULTS.merge_interval,
        help=f"steps between merge rounds (default {DEFAULTS.merge_interval})",
    )
    parser.add_argument(
        "--method",
        default=DEFAULT_METHOD,
        help=f"merging method: {', '.join(team_methods())}; {ORACLE} merges with the true "
        f"start poses, the upper bound (default {DEFAULT_METHOD})",
    )
    parser.add_argument(
        "--no-merge", action="store_true", help="explore without merging (the lower bound)"
    )
    parser.add_argument(
        "--comm-range",
        type=float,
        default=None,
        metavar="METRES",
        help="robots exchange maps, poses and targets, and merge, only within this range, "
        "directly or through teammates in range (default unlimited)",
    )
    parser.add_argument(
        "--line-of-sight", action="store_true", help="walls block communication (with --comm-range)"
    )
    parser.add_argument(
        "--coverage-target",
        type=float,
        default=DEFAULTS.coverage_target,
        help=f"stop when the team knows this fraction of the free space "
        f"(default {DEFAULTS.coverage_target})",
    )
    parser.add_argument(
        "--seed", type=int, default=DEFAULTS.seed, help=f"episode seed (default {DEFAULTS.seed})"
    )
    parser.add_argument(
        "--record",
        type=Path,
        default=DEFAULT_RECORD,
        metavar="PATH",
        help=f".rrd file to record to (default {DEFAULT_RECORD})",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


def build_config(args: argparse.Namespace) -> EpisodeConfig:
    """The episode the command line asks for; :class:`UsageError` when it cannot be."""
    if args.robots < 1:
        raise UsageError(f"--robots must be at least 1, got {args.robots}")
    if args.steps < 1:
        raise UsageError(f"--steps must be at least 1, got {args.steps}")
    if args.merge_interval < 1:
        raise UsageError(f"--merge-interval must be at least 1 step, got {args.merge_interval}")
    if args.seed < 0:
        raise UsageError(f"--seed must be a non-negative integer, got {args.seed}")
    if not 0.0 < args.coverage_target <= 1.0:
        raise UsageError(f"--coverage-target must be in (0, 1], got {args.coverage_target}")
    if args.method not in team_methods():
        choices = ", ".join(team_methods())
        raise UsageError(f"unknown method {args.method!r}; choose one of: {choices}")
    if args.comm_range is not None and not (math.isfinite(args.comm_range) and args.comm_range > 0):
        raise UsageError(f"--comm-range must be a positive number of metres, got {args.comm_range}")
    if args.line_of_sight and args.comm_range is None:
        raise UsageError("--line-of-sight needs --comm-range")
    if args.policy not in chooser_names():
        choices = ", ".join(chooser_names())
        raise UsageError(f"unknown policy {args.policy!r}; choose one of: {choices}")
    if args.record.suffix != ".rrd":
        raise UsageError(f"--record must name an .rrd file, got {args.record}")
    world: int | Path = int(args.world) if args.world.strip().isdigit() else Path(args.world)
    if isinstance(world, Path) and world.suffix not in (".yaml", ".yml"):
        raise UsageError(f"--world must be a seed or a map_server .yaml file, got {args.world!r}")
    return EpisodeConfig(
        world=world,
        robots=args.robots,
        policy=args.policy,
        steps=args.steps,
        merge=not args.no_merge,
        merge_interval=args.merge_interval,
        method=args.method,
        coverage_target=args.coverage_target,
        comm_range=args.comm_range,
        line_of_sight=args.line_of_sight,
        seed=args.seed,
        record=args.record,
    )


def check_writable(output: Path) -> None:
    """Raise :class:`CommandError` unless ``output`` can be created in its folder."""
    folder = output.absolute().parent
    if output.is_dir():
        raise CommandError(f"cannot write {output}: it is a directory")
    if not folder.is_dir():
        raise CommandError(f"cannot write {output}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise CommandError(f"cannot write {output}: folder {folder} is not writable")


def run(args: argparse.Namespace) -> int:
    """Run the episode and print its summary; returns the exit status."""
    config = build_config(args)
    assert config.record is not None  # the command always records
    check_writable(config.record)
    bar = tqdm(total=config.steps, unit="step", disable=None, leave=False)

    def progress(step: int, coverage: float) -> None:
        bar.update(step - bar.n)
        bar.set_postfix(coverage=f"{coverage:.3f}", refresh=False)

    try:
        metrics = run_episode(config, progress=progress)
    except FileNotFoundError as exc:
        raise CommandError(one_line(exc)) from exc
    except (ValueError, OSError, Image.DecompressionBombError) as exc:
        raise CommandError(f"cannot explore {args.world}: {one_line(exc)}") from exc
    finally:
        bar.close()
    print(json.dumps(metrics.as_dict(), indent=2) if args.json else render_summary(metrics))
    return 0
