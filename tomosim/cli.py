"""The ``tomosim`` command line: ``tomosim <command> [options]``.

Each command lives in its own module under :mod:`tomosim.commands`; this module
only wires them as subcommands and turns their errors into a one-line message
on stderr and an exit status: 0 success, 1 the command failed (unreadable
input, unwritable output), 2 the command line is wrong, 130 and 143 stopped by
Ctrl-C (SIGINT) and SIGTERM. SIGTERM, what job schedulers and ``kill`` send,
is handled as Ctrl-C is: a run stops cleanly and keeps what it wrote.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version
from types import ModuleType

from tomosim.commands import CommandError, Parser, UsageError, one_line
from tomosim.commands.stopping import Stopped, stop_signals_handled

COMMANDS = ("explore", "review", "merge", "sweep", "maps")
"""Command modules under :mod:`tomosim.commands`, in the order ``tomosim --help`` lists
them. They import the simulator, the merger and the viewer's SDK, seconds of work, so
they are imported inside :func:`main`, where a Ctrl-C meanwhile stops as at any other
instant, and only the command named is imported (:func:`build_parser`)."""
PROG = "tomosim"
"""The program name in messages."""
EXIT_FAILURE, EXIT_USAGE = 1, 2
"""Exit statuses for a failed command and for a wrong command line."""
SIGNAL_EXIT_BASE = 128
"""A process stopped by signal N exits with 128 + N, the shells' convention."""


def package_version() -> str:
    """The installed version of tomosim."""
    try:
        return version("tomosim")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown (not installed)"


def build_parser(arguments: Sequence[str] | None = None) -> Parser:
    """The argument parser with one subparser per command module.

    Given the command line's ``arguments``, only the module of the command
    they name is imported and its options added; the other commands are
    known by name alone (a misspelt one is still refused with the list).
    ``tomosim merge`` and ``tomosim maps`` then start without the simulator
    and the viewer's SDK, in 0.6 s instead of 1.4 s. With no command named
    (``tomosim --help``), or no ``arguments``, every module is imported.
    """
    parser = Parser(
        prog=PROG,
        description="Multi-robot exploration testbed with tomographic occupancy-grid merging.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {package_version()}")
    commands = parser.add_subparsers(title="commands", dest="command", metavar="COMMAND")
    commands.required = True
    named = _named_command(arguments)
    for name in COMMANDS:
        if named is not None and name != named:
            commands.add_parser(name)
            continue
        module: ModuleType = importlib.import_module(f"tomosim.commands.{name}")
        sub = commands.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(sub)
        sub.set_defaults(run=module.run)
    return parser


def _named_command(arguments: Sequence[str] | None) -> str | None:
    """The command ``arguments`` name (their first word not starting with ``-``: the
    program's own options take no value), or None when they name none of
    :data:`COMMANDS` or ask for the program's help before it (``tomosim -h explore``
    lists every command)."""
    for word in arguments or ():
        if word in ("-h", "--help"):
            return None
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def _silence_stdout() -> None:
    """Point standard output at the null device, so that exiting does not fail flushing it."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no real file descriptor (captured output)
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (``sys.argv[1:]`` when None) and return the exit status."""
    arguments = list(sys.argv[1:] if argv is None else argv)
    try:
        args = build_parser(arguments).parse_args(arguments)
        with stop_signals_handled():
            return int(args.run(args))
    except UsageError as exc:
        print(f"{PROG}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except CommandError as exc:
        print(f"{PROG}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_FAILURE
    except SystemExit as exc:  # --help and --version print and exit 0
        return exc.code if isinstance(exc.code, int) else EXIT_FAILURE
    except KeyboardInterrupt as exc:
        stopped = exc if isinstance(exc, Stopped) else Stopped(signal.SIGINT)
        print(f"{PROG}: {stopped.describe()}", file=sys.stderr)
        return SIGNAL_EXIT_BASE + stopped.signum
    except BrokenPipeError:  # the reader of our output went away (tomosim ... | head)
        _silence_stdout()
        return EXIT_FAILURE


if __name__ == "__main__":
    raise SystemExit(main())
