"""Subcommands of the ``tomosim`` command line, one module each.

A command module provides ``NAME`` and ``HELP`` (str), ``add_arguments(parser)``
and ``run(args) -> int``; :mod:`tomosim.cli` lists the modules and wires them
as subcommands. Commands report bad input by raising :class:`UsageError` (exit
status 2) or :class:`CommandError` (exit status 1) with a one-line message.
"""

from __future__ import annotations

import argparse
from typing import NoReturn


class UsageError(Exception):
    """The command line itself is wrong (exit status 2)."""


class CommandError(Exception):
    """The command could not do its job: unreadable input, unwritable output (exit status 1)."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` raising :class:`UsageError` instead of printing usage and exiting."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see '{self.prog} --help')")


def one_line(message: object) -> str:
    """``message`` as text with every run of whitespace, newlines included, made one space."""
    return " ".join(str(message).split())
