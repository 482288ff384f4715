"""``tomosim maps``: the maps a name can name, with their size and resolution.

A map of the maps path (:mod:`merging.catalog`: ``TOMOSIM_MAPS``, else the
shared folder's ``maps/`` beside the checkout) can be given by name wherever a
map is taken: ``tomosim explore --world aces3``, ``tomosim merge intel
halmstad/E5_01``, ``merging.load_map("intel")``.
"""

from __future__ import annotations

import argparse
import json

from merging.catalog import MapEntry, describe_folders, list_maps, map_folders
from tomosim.commands import CommandError

NAME = "maps"
HELP = "list the maps that can be given by name, with their size and resolution"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    parser.add_argument("--json", action="store_true", help="print the list as JSON")


def as_dict(entry: MapEntry) -> dict[str, object]:
    """One map as plain values."""
    width, height = entry.size_m
    return {
        "name": entry.name,
        "path": str(entry.path),
        "rows": entry.rows,
        "cols": entry.cols,
        "resolution_m": entry.resolution,
        "width_m": round(width, 3),
        "height_m": round(height, 3),
    }


def render(entries: list[MapEntry]) -> str:
    """The table ``tomosim maps`` prints."""
    folders = ", ".join(str(folder) for folder in map_folders())
    lines = [f"{len(entries)} maps in {folders}", ""]
    width = max(len("name"), *(len(entry.name) for entry in entries))
    lines.append(f"{'name':<{width}}  {'cells (rows x cols)':>19}  {'resolution':>10}  size")
    for entry in entries:
        metres = "{:.1f} m x {:.1f} m".format(*entry.size_m)
        cells = f"{entry.rows} x {entry.cols}"
        lines.append(f"{entry.name:<{width}}  {cells:>19}  {entry.resolution:>8.3f} m  {metres}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """List the maps; returns the exit status."""
    entries = list_maps()
    if not entries:
        raise CommandError(
            f"no maps found in {describe_folders()}; a map is a map_server .yaml file beside "
            "its image"
        )
    if args.json:
        print(json.dumps([as_dict(entry) for entry in entries], indent=2))
    else:
        print(render(entries))
    return 0
