"""``tomosim explore``: robots explore a world with periodic map merging, recorded for review.

Runs one episode of frontier exploration (:func:`tomosim.episode.run_episode`):
three robots on the default generated floor plan, coordinated by the default
policy, merging with the tomographic method every 50 steps (every 10 while
some robot's map is linked to nobody's), until the team knows 90 % of the free
space. It shows progress (a bar on a terminal, a line every few seconds elsewhere), records
the episode to an ``.rrd`` file, and ends with a summary: coverage, steps, and
per pair the merges accepted and their errors against the simulator's truth
(or JSON with ``--json``).

The run can be watched live as rerun's own examples offer it: ``--spawn`` a
viewer window, ``--connect`` to a running viewer, or ``--serve-web`` a web
viewer for a browser elsewhere (the way on a machine without a display);
``--no-record`` writes no file. Ctrl-C or SIGTERM stop the run cleanly: the
recording keeps what was logged and says that the run was interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from pathlib import Path

from PIL import Image

from merging.validators import real_number, whole_number
from tomosim.commands import (
    CommandError,
    UsageError,
    check_world,
    check_writable,
    one_line,
    world_spec,
)
from tomosim.commands.explore_report import render_summary
from tomosim.commands.progress import Progress
from tomosim.commands.stopping import Stopped, raise_if_stopped, stop_behind
from tomosim.commands.team_options import DEFAULT_TEAM, add_team_arguments, team_config
from tomosim.episode import DEFAULT_WORLD_SEED, EpisodeConfig, run_episode
from tomosim.exploration import chooser_names
from tomosim.kernels.jit import interrupts_unwrapped
from tomosim.recording import LiveViewer, Recorder, RecordingError
from tomosim.recording.sinks import DEFAULT_GRPC_PORT, DEFAULT_VIEWER_URL, DEFAULT_WEB_PORT
from tomosim.team import ORACLE, check_team_method, team_methods
from tomosim.worlds.world import NoRoomError

NAME = "explore"
"""The subcommand's name."""
HELP = "robots explore a world, merging their maps; records an .rrd and prints a summary"
"""One line for ``tomosim --help``."""
DEFAULTS = EpisodeConfig()
"""The episode run without options."""
DEFAULT_RECORD = Path("explore.rrd")
"""Recording written unless ``--record`` names another file."""
MAX_ROBOTS = 16
"""Most robots a run may have: every merge round estimates all N (N - 1) / 2 pairs
of maps, so its time grows with the square of the team. Measured on floor 0 on a
loaded 2-core machine (``tomosim explore --robots N --merge-interval 100
--coverage-target 1.0 --no-record --json``): 120 pairs and 3.2-3.7 s a round at
16 robots, 496 pairs and 14 s at 32; 200 robots would take some ten minutes a
round."""
SERVE_POLL_S = 0.5
"""Seconds between two checks for Ctrl-C while the web viewer serves a finished run."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    parser.add_argument(
        "--world",
        default=str(DEFAULT_WORLD_SEED),
        help="a generated floor plan's seed, a map's name ('tomosim maps' lists them) or a "
        f"map_server YAML file (default: floor plan {DEFAULT_WORLD_SEED}, 30 m x 20 m)",
    )
    parser.add_argument(
        "--robots",
        type=int,
        default=DEFAULTS.robots,
        help=f"number of robots, 1 to {MAX_ROBOTS} (default {DEFAULTS.robots})",
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
        "--method",
        default=DEFAULT_TEAM.method,
        help=f"merging method: {', '.join(team_methods())}; {ORACLE} merges with the true "
        f"start poses, the upper bound (default {DEFAULT_TEAM.method})",
    )
    parser.add_argument(
        "--no-merge", action="store_true", help="explore without merging (the lower bound)"
    )
    add_team_arguments(parser)
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
        help=f".rrd file to record to; its folder must exist (default {DEFAULT_RECORD})",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_live_arguments(parser)


def add_live_arguments(parser: argparse.ArgumentParser) -> None:
    """The options to watch a run live (module docstring)."""
    live = parser.add_mutually_exclusive_group()
    live.add_argument(
        "--spawn", action="store_true", help="watch live in a new rerun viewer window"
    )
    live.add_argument(
        "--connect",
        nargs="?",
        const=DEFAULT_VIEWER_URL,
        default=None,
        metavar="URL",
        help=f"watch live in a running rerun viewer (default URL {DEFAULT_VIEWER_URL})",
    )
    live.add_argument(
        "--serve-web",
        action="store_true",
        help="serve a web viewer (on --web-port) and keep serving after the run "
        "until Ctrl-C (watch from a browser; for machines without a display)",
    )
    parser.add_argument(
        "--web-port",
        type=int,
        default=DEFAULT_WEB_PORT,
        metavar="PORT",
        help=f"--serve-web: the web viewer's port (default {DEFAULT_WEB_PORT})",
    )
    parser.add_argument(
        "--grpc-port",
        type=int,
        default=DEFAULT_GRPC_PORT,
        metavar="PORT",
        help=f"--serve-web and --spawn: the port the run is streamed from "
        f"(default {DEFAULT_GRPC_PORT})",
    )
    parser.add_argument(
        "--no-record", action="store_true", help="write no .rrd file (watch live only, or not)"
    )


def check_episode_options(args: argparse.Namespace) -> None:
    """The episode options ``explore`` and ``sweep`` share: :class:`UsageError` naming a bad
    one (the team's are :func:`~tomosim.commands.team_options.team_config`'s)."""
    try:
        whole_number(args.steps, "--steps", minimum=1)
        real_number(args.coverage_target, "--coverage-target", low=0.0, high=1.0, low_open=True)
    except ValueError as error:
        raise UsageError(str(error)) from None


def build_config(args: argparse.Namespace) -> EpisodeConfig:
    """The episode the command line asks for; :class:`UsageError` when it cannot be."""
    if not 1 <= args.robots <= MAX_ROBOTS:
        raise UsageError(
            f"--robots must be from 1 to {MAX_ROBOTS}, got {args.robots} (a merge round "
            f"estimates every pair of maps: {MAX_ROBOTS * (MAX_ROBOTS - 1) // 2} pairs at "
            f"{MAX_ROBOTS} robots)"
        )
    check_episode_options(args)
    for option, port in (("--web-port", args.web_port), ("--grpc-port", args.grpc_port)):
        if not 1 <= port <= 65535:
            raise UsageError(f"{option} must be from 1 to 65535, got {port}")
    if args.serve_web and args.web_port == args.grpc_port:
        raise UsageError(f"--web-port and --grpc-port must differ, got {args.web_port} for both")
    if args.no_record and args.record != DEFAULT_RECORD:
        raise UsageError("give either --record or --no-record, not both")
    if args.no_merge and args.method != DEFAULT_TEAM.method:
        raise UsageError(f"--no-merge explores without merging; drop --method {args.method}")
    if args.seed < 0:
        raise UsageError(f"--seed must be a non-negative integer, got {args.seed}")
    try:
        check_team_method(args.method)
    except ValueError as error:
        raise UsageError(str(error)) from None
    if args.policy not in chooser_names():
        choices = ", ".join(chooser_names())
        raise UsageError(f"unknown policy {args.policy!r}; choose one of: {choices}")
    if args.record.suffix != ".rrd":
        raise UsageError(f"--record must name an .rrd file, got {args.record}")
    world = world_spec(args.world, option="--world")
    return EpisodeConfig(
        world=world,
        robots=args.robots,
        policy=args.policy,
        steps=args.steps,
        coverage_target=args.coverage_target,
        seed=args.seed,
        record=None if args.no_record else args.record,
        team=team_config(args, merge=not args.no_merge, method=args.method),
    )


def live_viewer(args: argparse.Namespace) -> LiveViewer | None:
    """The :class:`~tomosim.recording.LiveViewer` the options ask for, or None."""
    ports = {"grpc_port": args.grpc_port, "web_port": args.web_port}
    if args.spawn:
        return LiveViewer("spawn", **ports)
    if args.connect is not None:
        return LiveViewer("connect", url=args.connect)
    if args.serve_web:
        return LiveViewer("serve-web", **ports)
    return None


def run(args: argparse.Namespace) -> int:
    """Run the episode and print its summary; returns the exit status."""
    config = build_config(args)
    check_world(config.world, option="--world")
    live = live_viewer(args)
    if config.record is not None:
        check_writable(config.record, option="--record")
    recorder = None
    if config.record is not None or live is not None:
        try:
            recorder = Recorder.open(record=config.record, live=live)
        except RecordingError as exc:
            raise CommandError(one_line(exc)) from exc
        if recorder.watch is not None:
            print(f"tomosim: watch the run: {recorder.watch}", file=sys.stderr)
    progress = Progress(config.steps, "step", label=NAME)

    def report(step: int, coverage: float) -> None:
        progress.update(step, f"team coverage {coverage:.3f}")
        raise_if_stopped()

    try:
        with interrupts_unwrapped():
            metrics = run_episode(config, recorder=recorder, progress=report)
    except BaseException as exc:
        progress.close()
        interrupt = stop_behind(exc)
        if interrupt is not None:
            # The recording's own last step: the signal may land after a step was logged
            # and before the progress line heard of it.
            step = recorder.last_step if recorder is not None else progress.done
            started = recorder is None or recorder.started
            stopped = Stopped.of(interrupt, kept(config.record, step, started=started))
            if recorder is not None:
                if started:
                    recorder.log_interrupted(stopped.why)
                _close_quietly(recorder)
            raise stopped from None
        if recorder is not None:
            _close_quietly(recorder)
        if isinstance(exc, MemoryError):
            raise CommandError(
                f"out of memory ({one_line(exc)}): use a smaller world or fewer robots"
            ) from exc
        if isinstance(exc, ValueError | OSError | Image.DecompressionBombError):
            raise failure(exc, args.world) from exc
        raise
    progress.close(f"team coverage {metrics.coverage:.3f} after {metrics.steps} steps")
    print(json.dumps(metrics.as_dict(), indent=2) if args.json else render_summary(metrics))
    if recorder is not None:
        if live is not None and args.serve_web:
            serve_until_stopped(recorder.watch)
        close(recorder)
    return 0


def kept(record: Path | None, step: int, *, started: bool = True) -> str:
    """What an interrupted run leaves behind, and how to look at it.

    ``started``: whether the recording had begun (it is written from the run's
    first step on; before that an existing file of its name is left alone).
    """
    if record is None:
        return f"stopped at step {step}; nothing was recorded (--no-record)"
    if not started:
        existing = f" ({record} is an earlier run's, left as it was)" if record.exists() else ""
        return f"stopped before the run began; nothing was recorded{existing}"
    return (
        f"{record} keeps the run up to step {step} and says it was interrupted; "
        f"see it with: tomosim review {record}"
    )


def _close_quietly(recorder: Recorder) -> None:
    """Close ``recorder`` while another error is being reported: that one matters."""
    with contextlib.suppress(RecordingError):
        recorder.close()


def close(recorder: Recorder) -> None:
    """Close ``recorder``; a recording that could not be written is a :class:`CommandError`."""
    try:
        recorder.close()
    except RecordingError as exc:
        raise CommandError(one_line(exc)) from exc
    error = recorder.viewer_error
    if error:
        print(f"tomosim: warning: the live viewer stopped receiving: {error}", file=sys.stderr)


def serve_until_stopped(watch: str | None) -> None:
    """Keep this process (and so the web viewer) alive until Ctrl-C or SIGTERM."""
    print(
        f"tomosim: the run is over; the web viewer shows it at {watch} until you press Ctrl-C",
        file=sys.stderr,
    )
    try:
        while True:
            time.sleep(SERVE_POLL_S)
    except KeyboardInterrupt:
        return


def failure(exc: Exception, world: str) -> CommandError:
    """The one-line :class:`CommandError` for a run that failed with ``exc``."""
    if isinstance(exc, NoRoomError):
        return CommandError(
            f"cannot explore {world}: it has room for only {exc.placed} robots at their "
            f"start separation; use --robots {max(exc.placed, 1)} or fewer, or a larger world"
        )
    if isinstance(exc, RecordingError | FileNotFoundError):
        return CommandError(one_line(exc))
    return CommandError(f"cannot explore {world}: {one_line(exc)}")
