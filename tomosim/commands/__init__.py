"""Subcommands of the ``tomosim`` command line, one module each.

A command module provides ``NAME`` and ``HELP`` (str), ``add_arguments(parser)``
and ``run(args) -> int``; :mod:`tomosim.cli` lists the modules and wires them
as subcommands. Commands report bad input by raising :class:`UsageError` (exit
status 2) or :class:`CommandError` (exit status 1) with a one-line message that
names the file or value and what to do.

Importing this package quiets rerun's own log lines about failed writes and
lost viewers (unless ``RUST_LOG`` is set): the commands report those failures
themselves, in one line.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import NoReturn

RERUN_LOG_FILTER = "warn,re_log_encoding=off,re_sdk::recording_stream=off,re_grpc_client=off"
"""``RUST_LOG`` for rerun's Rust side (read when rerun is first imported): warnings,
but not those the commands turn into their own messages."""
os.environ.setdefault("RUST_LOG", RERUN_LOG_FILTER)


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


def check_writable(output: Path, *, option: str) -> None:
    """Raise :class:`CommandError` unless ``output`` can be created in a folder that exists.

    Missing folders are not created: a typo in a path should not leave new
    folders behind (``option`` names the option in the message).
    """
    folder = output.absolute().parent
    if output.is_dir():
        raise CommandError(f"cannot write {output}: it is a directory; give a file to {option}")
    if not folder.exists():
        raise CommandError(
            f"cannot write {output}: folder {folder} does not exist; create it or give "
            f"{option} another path"
        )
    if not folder.is_dir():
        raise CommandError(f"cannot write {output}: {folder} is not a directory")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise CommandError(
            f"cannot write {output}: folder {folder} is not writable; give {option} a path "
            "in a folder you can write to"
        )


def world_spec(text: str, *, option: str) -> int | str | Path:
    """What a world option names: a floor plan's seed, a map's name, or a map's YAML file.

    Raises :class:`UsageError` for a file that cannot be a map's YAML (an image,
    say); whether a name or a file exists is :func:`check_world`'s question.
    """
    stripped = text.strip()
    if stripped.isdigit():
        return int(stripped)
    from merging.catalog import is_yaml_name  # imported when asked, as in check_world

    if is_yaml_name(stripped):
        return Path(stripped)
    if Path(stripped).suffix or not stripped:
        raise UsageError(
            f"{option} must be a seed (a whole number >= 0), a map's name ('tomosim maps' "
            f"lists them) or a map_server .yaml file, got {text!r}"
        )
    return stripped


def check_world(world: int | str | Path, *, option: str) -> None:
    """Raise :class:`CommandError` when the map ``world`` names is not there.

    A name is looked up in the maps path (:func:`merging.catalog.find_map`;
    the message lists the folders searched); a file must exist.
    """
    from merging.catalog import find_map

    if isinstance(world, int):
        return
    try:
        path = find_map(world)
    except FileNotFoundError as exc:
        raise CommandError(f"{option} {world}: {exc}") from None
    if not path.is_file():
        raise CommandError(
            f"{option} {world}: no such map file; give a map_server .yaml file, a map's "
            "name or a floor-plan seed"
        )
