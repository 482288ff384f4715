"""The ``tomosim`` command line: ``tomosim <command> [options]``.

Each command lives in its own module under :mod:`tomosim.commands`; this module
only wires them as subcommands and turns their errors into a one-line message
on stderr and an exit status: 0 success, 1 the command failed (unreadable
input, unwritable output), 2 the command line is wrong.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from types import ModuleType

from tomosim.commands import CommandError, Parser, UsageError, one_line
from tomosim.commands import explore as explore_command
from tomosim.commands import merge as merge_command
from tomosim.commands import review as review_command
from tomosim.commands import sweep as sweep_command

COMMANDS: tuple[ModuleType, ...] = (
    explore_command,
    review_command,
    merge_command,
    sweep_command,
)
"""Command modules, in the order ``tomosim --help`` lists them."""
PROG = "tomosim"
"""The program name in messages."""
EXIT_FAILURE, EXIT_USAGE = 1, 2
"""Exit statuses for a failed command and for a wrong command line."""
EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C: 128 + SIGINT, the shells' convention."""


def build_parser() -> Parser:
    """The argument parser with one subparser per command module."""
    parser = Parser(
        prog=PROG,
        description="Multi-robot exploration testbed with tomographic occupancy-grid merging.",
    )
    commands = parser.add_subparsers(title="commands", dest="command", metavar="COMMAND")
    commands.required = True
    for module in COMMANDS:
        sub = commands.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(sub)
        sub.set_defaults(run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (``sys.argv[1:]`` when None) and return the exit status."""
    parser = build_parser()
    arguments = list(sys.argv[1:] if argv is None else argv)
    try:
        args = parser.parse_args(arguments)
        return int(args.run(args))
    except UsageError as exc:
        print(f"{PROG}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except CommandError as exc:
        print(f"{PROG}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_FAILURE
    except SystemExit as exc:  # --help prints and exits 0
        return exc.code if isinstance(exc.code, int) else EXIT_FAILURE
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
