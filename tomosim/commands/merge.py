"""``tomosim merge``: merge ``map_server`` maps into one, or a generated demo pair.

``tomosim merge a.yaml b.yaml [c.yaml ...] -o merged.yaml`` estimates the
transform between every pair of maps, links them by a spanning tree of
confident merges (:func:`merging.merge_all`), writes the fused map in
``map_server`` format, and prints each map's transform into the fused map and
the pairwise confidences (or JSON with ``--json``).

``tomosim merge --demo [SEED] -o merged.yaml`` first writes two overlapping
windows of a generated floor plan beside the output, the second rotated and
shifted, merges them, and prints the true transform beside the estimate.

A map that cannot be linked to the others is an error (exit status 1, nothing
written) unless ``--partial`` asks for the merge of the maps that could be
linked. The output's folder must exist; the image and the YAML are written as
a pair, whole or not at all (:func:`merging.save_map`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from merging import OccupancyGrid, available_methods, check_method, load_map, merge_all, save_map
from merging.api import DEFAULT_METHOD
from merging.catalog import MAP_SUFFIXES, find_map, is_yaml_name
from merging.mapio import map_image
from merging.resample import common_resolution
from tomosim.commands import CommandError, UsageError, check_writable, one_line
from tomosim.commands.demo_maps import DEMO_SEED, demo_pair
from tomosim.commands.merge_report import render_table, summarise
from tomosim.commands.merger_options import add_merger_argument, changed, merger_params

NAME = "merge"
"""The subcommand's name."""
HELP = "merge map_server maps (YAML + image) into one map"
"""One line for ``tomosim --help``."""
DEFAULT_SEED = 0
"""Seed of the merging methods' randomness unless ``--seed`` is given, so runs repeat."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    parser.add_argument(
        "maps",
        nargs="*",
        help="two or more maps: map_server YAML files, or names of maps ('tomosim maps')",
    )
    parser.add_argument(
        "-o",
        "--output",
        required=True,
        type=Path,
        help="YAML file to write the merged map to; the image goes beside it (.pgm) and "
        "the folder must exist",
    )
    parser.add_argument(
        "--method",
        default=DEFAULT_METHOD,
        help=f"merging method: {', '.join(available_methods())} (default {DEFAULT_METHOD})",
    )
    parser.add_argument(
        "--partial",
        action="store_true",
        help="write the merge of the maps that could be linked even if some could not "
        "(default: such a merge is an error and nothing is written)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=DEFAULT_SEED,
        help=f"seed for the methods' randomness (default {DEFAULT_SEED})",
    )
    add_merger_argument(parser)
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument(
        "--demo",
        nargs="?",
        type=int,
        const=DEMO_SEED,
        default=None,
        metavar="SEED",
        help=f"merge a generated demo pair (floor plan seed, default {DEMO_SEED}) instead of files",
    )


def run(args: argparse.Namespace) -> int:
    """Merge the maps named by ``args`` and print the report; returns the exit status."""
    paths = [map_path(source) for source in args.maps]
    output: Path = args.output
    check_arguments(args, paths, output)
    params = merger_params(args.merger, args.method)
    check_writable(output, option="-o")
    truth = None
    if args.demo is not None:
        paths, truth = write_demo(args.demo, output)
    # Maps of different resolutions are brought to the coarsest (each keeps its frame).
    maps = [read_map(path) for path in paths]
    try:
        grids = common_resolution(maps)
    except ValueError as exc:
        raise CommandError(f"cannot bring the maps to one resolution: {one_line(exc)}") from exc
    image = output.with_suffix(".pgm").resolve()  # save_map writes the image beside the YAML
    for path in paths:
        if map_image(path).resolve() == image:
            raise UsageError(
                f"output {output} would write its image over {image.name}, the image of input "
                f"{path}; choose another output file"
            )
    try:
        options: dict[str, Any] = {} if params is None else {"params": params}
        result = merge_all(grids, method=args.method, rng=args.seed, **options)
    except ValueError as exc:
        raise CommandError(f"cannot merge: {one_line(exc)}") from exc
    fused = result.fused.grid
    if fused is None:  # load_map returns OccupancyGrids, so the fused map is one too
        raise CommandError("the fused map lost its georeference")
    left_out = ", ".join(str(paths[k]) for k in result.unlinked)
    unlinked = f"could not link {left_out} to the other maps"
    partial = "pass --partial to write the merge of the rest"
    if len(result.unlinked) == len(paths) - 1:  # no pair linked: no one map is to blame
        unlinked = f"could not link any two of the {len(paths)} maps"
        kept = next(k for k in range(len(paths)) if k not in result.unlinked)
        partial = f"pass --partial to write map {kept} ({paths[kept]}) alone"
    written = not result.unlinked or args.partial
    if written:
        try:
            save_map(fused, output)
        except OSError as exc:
            raise CommandError(f"cannot write {output}: {one_line(exc.strerror or exc)}") from exc
    summary = summarise(result, grids, paths, output, truth=truth)
    summary["written"] = written
    if params is not None:
        summary["merger_settings"] = changed(params)
    print(json.dumps(summary, indent=2) if args.json else render_table(summary))
    if not written:
        raise CommandError(
            f"{unlinked} (no confident merge; see the pairs above); {output} was not "
            f"written; {partial}"
        )
    if result.unlinked:
        print(f"tomosim: warning: not merged (no confident link): {left_out}", file=sys.stderr)
    return 0


def check_arguments(args: argparse.Namespace, paths: list[Path], output: Path) -> None:
    """Raise :class:`UsageError` for a command line that cannot work."""
    if args.demo is not None and paths:
        raise UsageError("give either map files or --demo, not both")
    if args.demo is None and len(paths) < 2:
        raise UsageError(f"give at least two maps to merge (got {len(paths)}), or use --demo")
    if args.demo is not None and args.demo < 0:
        raise UsageError(f"--demo seed must be a non-negative integer, got {args.demo}")
    if args.seed < 0:
        raise UsageError(f"--seed must be a non-negative integer, got {args.seed}")
    try:
        check_method(args.method)
    except ValueError as error:
        raise UsageError(str(error)) from None
    if not is_yaml_name(output):  # the image goes beside it with its own suffix
        named = output.name not in ("", ".", "..")  # a folder has no name to give a suffix
        if output.name.lower() in MAP_SUFFIXES:  # ".yaml" alone: a suffix without a name
            example = output.parent / "merged.yaml"
        else:
            example = output.with_suffix(".yaml") if named else output / "merged.yaml"
        raise UsageError(
            f"output must be a .yaml file (the image is written beside it), got {output}; "
            f"give e.g. {example}"
        )
    target = output.resolve()
    if any(path.resolve() == target for path in paths):
        raise UsageError(f"output {output} is also an input; choose another output file")


def map_path(source: str) -> Path:
    """The YAML file of an input map given by path or by name (:func:`merging.catalog.find_map`)."""
    try:
        return find_map(source)
    except FileNotFoundError as exc:
        raise CommandError(one_line(exc)) from exc


def read_map(path: Path) -> OccupancyGrid:
    """Load one map, turning every way a file can be bad into a :class:`CommandError`."""
    try:
        return load_map(path)
    except FileNotFoundError as exc:
        raise CommandError(one_line(exc)) from exc
    except (OSError, ValueError, Image.DecompressionBombError) as exc:
        raise CommandError(f"cannot read map {path}: {one_line(exc)}") from exc


def write_demo(seed: int, output: Path) -> tuple[list[Path], np.ndarray]:
    """Write the demo pair beside ``output``; returns their paths and the true transform."""
    map1, map2, truth = demo_pair(seed)
    stem = output.with_suffix("")
    paths = [stem.with_name(f"{stem.name}_demo{k}.yaml") for k in (1, 2)]
    try:
        for grid, path in zip((map1, map2), paths, strict=True):
            save_map(grid, path)
    except OSError as exc:
        raise CommandError(f"cannot write the demo maps: {one_line(exc)}") from exc
    return paths, truth
