"""What the scripts in ``scripts/`` share with the command line: checked numbers, one-line errors.

``type=positive_int`` (a whole number >= 1), ``type=non_negative_int`` (>= 0:
seeds) and ``type=positive_float`` (a finite number > 0) make ``argparse`` refuse a bad value at
once, naming the option, where a negative pair count would otherwise run a
benchmark for minutes or print a negative rate. :func:`run_script` runs a
script's ``main`` so that a bad input the script meets later (a map that is
not there, an output it cannot write) ends in one line naming it, as in
``tomosim``'s commands, not in a traceback; ``TOMOSIM_TRACEBACK=1`` shows the
traceback too.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NoReturn

from tomosim.commands import CommandError, UsageError, one_line

TRACEBACK_VARIABLE = "TOMOSIM_TRACEBACK"
"""Set to 1 to see the traceback behind a script's one-line error."""


def _parse_int(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None


def positive_int(text: str) -> int:
    """An ``argparse`` type: a whole number of at least 1."""
    value = _parse_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {value}")
    return value


def non_negative_int(text: str) -> int:
    """An ``argparse`` type: a whole number of at least 0 (a seed, or a count that may be 0)."""
    value = _parse_int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 0, got {value}")
    return value


def positive_float(text: str) -> float:
    """An ``argparse`` type: a finite number above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def run_script(main: Callable[[], int | None], script: str) -> NoReturn:
    """Exit with ``main()``'s status; a ValueError, OSError, ImportError or a command's
    error becomes one line on stderr (status 1), and Ctrl-C a line saying so (130)."""
    name = Path(script).name
    try:
        status = main()
    except KeyboardInterrupt:
        print(f"{name}: interrupted", file=sys.stderr)
        sys.exit(130)
    except (ValueError, OSError, ImportError, CommandError, UsageError) as error:
        if os.environ.get(TRACEBACK_VARIABLE) == "1":
            raise
        print(f"{name}: error: {one_line(error)}", file=sys.stderr)
        sys.exit(1)
    sys.exit(status or 0)


def shared_maps() -> Path:
    """The folder of shared real maps; :class:`CommandError` naming where it was looked
    for when it is absent (:func:`tomosim.data.maps_missing`)."""
    from tomosim.data import maps_dir, maps_missing

    folder = maps_dir()
    if folder is None:
        raise CommandError(maps_missing())
    return folder


def missing_maps(names: Sequence[str], option: str) -> str | None:
    """Why ``names`` (given with ``option``) are not all maps of :func:`shared_maps`'s
    folder, in one line; None when they are. Scripts ask before their long runs, which
    would otherwise stop at the first missing map after the others' work."""
    folder = shared_maps()
    missing = [name for name in names if not (folder / f"{name}.yaml").is_file()]
    if not missing:
        return None
    return (
        f"{option}: no map {', '.join(repr(name) for name in missing)} in {folder}; "
        "`tomosim maps` lists the names"
    )
