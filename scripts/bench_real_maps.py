"""Benchmark the mergers on the maps users bring: whole buildings, separate sessions, low overlap.

Four suites, each running every method on the same pairs in one run (so that
machine load affects them alike), appending a CSV row per method and pair as
soon as it is known, and writing a Markdown report:

``sessions``
    The 109 pairs of mapping sessions of the Halmstad E5 floor with a known
    transform (``halmstad/truth_E5.json``; right when within
    ``max(1.5 * rms, rms + 10)`` cells, the rule of the maps' README), split
    into the even-numbered pairs (on which the robust acceptance was set) and
    the odd-numbered ones; and the real pairs of one building without a known
    transform (``ucm_longrun6/7``, ``ucm_longcorridor1/2``, ``intel`` vs
    ``intel_raster``), reported as accepted or not and by how far each
    method's answer lies from the default's.
``whole``
    Large turned windows (80-100 % of the map's extent, overlap 0.5-1) of
    ``aces3``, ``fr079`` and ``intel_raster``, right within 2 cells RMS; and
    a 1600 x 1600 crop of ``aces3`` against the same crop shifted by (23, 37)
    cells, and a 3200 x 3200 one of ``aces3`` drawn at twice the resolution
    (each cell split in four).
``moderate-overlap``
    Window pairs of the same four maps sharing 15-20 % (50 per map): the band
    just above, where mergers used to succeed, to see that none is lost.
``low-overlap``
    Window pairs of four maps sharing 3-15 % of their area (the section 4.1
    protocol otherwise), right within 2 cells; what matters is that nothing
    wrong is accepted. Also side-by-side windows around the round hall of
    ``aces3``, which is symmetric under a half turn and across its corridors'
    axes: there the true overlap holds almost no wall, and the windows turned
    by half a turn fit each other exactly (reported apart: a merger must
    refuse them, as what the windows share looks the same in a mirror).

Methods by default: ``tomographic`` (the default merger), ``orb`` and ``sift``
(scikit-image features + RANSAC), and ``ros_akaze`` and ``ros_orb`` (the ROS
``multirobot_map_merge`` pipeline with OpenCV), which are skipped, with the
install command, when OpenCV is absent.

``--from-truth`` adds a row per pair with a known transform, method
``from_truth``: the default's refinement and verdict started at the true
transform (:func:`merging.tomographic.search.refine_from`), with no search. It
tells a miss of the search from a pair whose overlap cannot vouch for any
placement: what the verdict accepts there bounds what a better search could
add. It accepts a little more than a perfect search would, as it skips the two
checks that need a search (the best different placement, map 2's mirror image).
With it comes a row ``truth_in_search``: the same refinement judged in the place
of the search's winner, against the search's pool and map 2's mirror image by the
full verdict (``refine_from(..., held_against_search=True)``), what a search that
always found the truth would accept under today's verdict.

Usage::

    python scripts/bench_real_maps.py sessions
    python scripts/bench_real_maps.py whole --pairs-per-map 10
    python scripts/bench_real_maps.py low-overlap --pairs-per-map 75
    python scripts/bench_real_maps.py moderate-overlap --seed 41
    python scripts/bench_real_maps.py sessions --methods tomographic --every 3   # a quick look
    python scripts/bench_real_maps.py low-overlap --methods tomographic --from-truth
    python scripts/bench_real_maps.py sessions --methods tomographic --merger robust.margin=0.2

``--merger NAME=VALUE`` (repeatable) changes a setting of the default method
by its dotted name (:mod:`merging.settings`), for its rows and ``from_truth``'s;
the report names the settings changed.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import sys
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import merging
from merging.api import DEFAULT_METHOD
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from merging.grid import OccupancyGrid
from merging.params import TomographicParams
from merging.tomographic.search import refine_from
from merging.transforms import rigid_matrix
from tomosim.commands.merger_options import add_merger_argument, changed, merger_params
from tomosim.commands.script_args import non_negative_int, run_script
from tomosim.data import maps_dir, maps_missing

DEFAULT_METHODS = ("tomographic", "orb", "sift", "ros_akaze", "ros_orb")
OPENCV_METHODS = ("ros_akaze", "ros_orb")
OPENCV_INSTALL = 'pip install "tomosim[opencv]"'
FROM_TRUTH = "from_truth"
"""The row of ``--from-truth``: the default's verdict on its refinement of the true transform."""
TRUTH_IN_SEARCH = "truth_in_search"
"""The other row of ``--from-truth``: that refinement judged against the search's pool and
map 2's mirror image, in the place of the search's winner."""
TRUTH_ROWS = (FROM_TRUTH, TRUTH_IN_SEARCH)
WINDOW_RIGHT_CELLS = 2.0
"""A window merge is right within this RMS error, as in ``bench_merge.py``."""
CROP_RIGHT_CELLS = 1.0
"""The shifted crops are asked to be right within one cell."""
SAME_BUILDING = (
    ("ucm_longrun6", "ucm_longrun7"),
    ("ucm_longcorridor1", "ucm_longcorridor2"),
    ("intel", "intel_raster"),
)
"""Real pairs of maps of one building, without a known transform."""
WHOLE_MAPS = ("aces3", "fr079", "intel_raster")
LOW_OVERLAP_MAPS = ("aces3", "intel", "fr079", "brsu_c069")
LOW_OVERLAP = (0.03, 0.15)
"""Shares of their area the low-overlap windows hold in common."""
MODERATE_OVERLAP = (0.15, 0.20)
"""Shares of the moderate-overlap windows: the band just above the low-overlap suite."""
ROUND_HALL = (672, 291, 247, range(600, 1020, 40), (13, 30))
"""aces3's round hall: window row, height, width, first window's columns, and the
overlaps in columns of the second window to its left or right."""


@dataclass(frozen=True, slots=True)
class Case:
    """One pair of maps and what is known about it."""

    suite: str
    group: str
    name: str
    map1: OccupancyGrid | NDArray[Any]
    map2: OccupancyGrid | NDArray[Any]
    truth: NDArray[np.float64] | None
    tolerance: float


@dataclass(frozen=True, slots=True)
class Row:
    """One method on one pair."""

    suite: str
    group: str
    pair: str
    method: str
    rms_cells: float
    tolerance: float
    right: str
    accepted: bool
    confidence: float
    seconds: float
    cpu_seconds: float
    from_default_cells: float
    reason: str
    stages: str = ""
    """The default method's milliseconds per step of its search (``MergeResult.timings``
    but the total), ``name=ms`` joined by ``;``; empty for the other methods."""


def available(methods: list[str]) -> list[str]:
    """The methods that can run here; OpenCV ones are dropped, with a note, when it is absent."""
    if importlib.util.find_spec("cv2") is None:
        skipped = [m for m in methods if m in OPENCV_METHODS]
        if skipped:
            print(f"skipping {skipped}: they need OpenCV: {OPENCV_INSTALL}", file=sys.stderr)
        return [m for m in methods if m not in OPENCV_METHODS]
    return methods


def session_cases(every: int) -> Iterator[Case]:
    folder = maps_dir()
    assert folder is not None
    halmstad = folder / "halmstad"
    truth = json.loads((halmstad / "truth_E5.json").read_text())["pairs"]
    grids: dict[str, merging.OccupancyGrid] = {}
    for index, key in enumerate(sorted(truth)):
        if index % every:
            continue
        first, second = key.split("|")
        for name in (first, second):
            if name not in grids:
                grids[name] = merging.load_map(halmstad / f"{name}.yaml")
        entry = truth[key]
        tolerance = max(1.5 * entry["rms_cells"], entry["rms_cells"] + 10.0)
        group = "E5 even" if index % 2 == 0 else "E5 odd"
        yield Case("sessions", group, key, grids[first], grids[second],
                   np.array(entry["matrix_cells"]), tolerance)  # fmt: skip
    for first, second in SAME_BUILDING:
        yield Case("sessions", "same building", f"{first}|{second}",
                   merging.load_map(folder / f"{first}.yaml"),
                   merging.load_map(folder / f"{second}.yaml"), None, 0.0)  # fmt: skip


def whole_cases(pairs_per_map: int, seed: int) -> Iterator[Case]:
    folder = maps_dir()
    assert folder is not None
    for name in WHOLE_MAPS:
        whole = merging.load_map(folder / f"{name}.yaml").data
        pairs = cut_window_pairs(whole, count=pairs_per_map, size_fraction=(0.8, 1.0),
                                 overlap_range=(0.5, 1.0), rng=seed)  # fmt: skip
        for index, pair in enumerate(pairs):
            yield Case("whole", f"turned windows {name}", f"{name}#{index}", pair.map1,
                       pair.map2, pair.truth, WINDOW_RIGHT_CELLS)  # fmt: skip
    aces = merging.load_map(folder / "aces3.yaml").data
    shift = (23, 37)
    for scale, side in ((1, 1600), (2, 3200)):
        big = np.repeat(np.repeat(aces, scale, axis=0), scale, axis=1)
        top = 100 * scale
        first = big[top : top + side, 0:side]
        second = big[top + shift[1] : top + shift[1] + side, shift[0] : shift[0] + side]
        yield Case("whole", "shifted crops", f"aces3 x{scale} {side}x{side}", first, second,
                   rigid_matrix(*shift, 0.0), CROP_RIGHT_CELLS)  # fmt: skip


def window_cases(suite: str, overlap: tuple[float, float], pairs_per_map: int,
                 seed: int) -> Iterator[Case]:  # fmt: skip
    """Window pairs of the four low-overlap maps sharing ``overlap`` of their area."""
    folder = maps_dir()
    assert folder is not None
    group = f"windows sharing {round(overlap[0] * 100)}-{round(overlap[1] * 100)} %"
    for name in LOW_OVERLAP_MAPS:
        whole = merging.load_map(folder / f"{name}.yaml").data
        pairs = cut_window_pairs(whole, count=pairs_per_map, overlap_range=overlap, rng=seed)
        for index, pair in enumerate(pairs):
            yield Case(suite, group, f"{name}#{index}", pair.map1, pair.map2, pair.truth,
                       WINDOW_RIGHT_CELLS)  # fmt: skip


def low_overlap_cases(pairs_per_map: int, seed: int) -> Iterator[Case]:
    yield from window_cases("low-overlap", LOW_OVERLAP, pairs_per_map, seed)
    folder = maps_dir()
    assert folder is not None
    aces = merging.load_map(folder / "aces3.yaml").data
    row, height, width, columns, overlaps = ROUND_HALL
    for column in columns:
        for overlap in overlaps:
            for side in (-1, 1):
                other = column + side * (width - overlap)
                if other < 0 or other + width > aces.shape[1]:
                    continue
                first = aces[row : row + height, column : column + width]
                second = aces[row - 24 : row - 24 + height, other : other + width]
                yield Case("low-overlap", "round hall of aces3", f"{column}/{other}", first,
                           second, rigid_matrix(other - column, -24.0, 0.0),
                           WINDOW_RIGHT_CELLS)  # fmt: skip


def run(cases: Iterator[Case], methods: list[str], seed: int, writer, handle,
        params: TomographicParams | None = None) -> list[Row]:  # fmt: skip
    """Run ``methods`` on ``cases``, writing each row as it is known; ``params`` (None: the
    defaults) are the default method's settings, for its rows and those of ``from_truth``."""
    settings = {} if params is None else {"params": params}
    rows: list[Row] = []
    for count, case in enumerate(cases, start=1):
        default_matrix = None
        for method in methods:
            if method in TRUTH_ROWS and case.truth is None:
                continue
            start, cpu_start = time.perf_counter(), time.process_time()
            if method in TRUTH_ROWS:
                assert case.truth is not None  # cases without a truth were skipped above
                result = refine_from(case.map1, case.map2, case.truth,
                                     held_against_search=method == TRUTH_IN_SEARCH,
                                     **settings)  # fmt: skip
            else:
                options = settings if method == DEFAULT_METHOD else {}
                result = merging.estimate_transform(case.map1, case.map2, method=method,
                                                    rng=seed, **options)  # fmt: skip
            seconds = time.perf_counter() - start
            cpu_seconds = time.process_time() - cpu_start
            cells2 = getattr(case.map2, "data", case.map2)
            if method == methods[0]:
                default_matrix = result.matrix
            from_default = (
                transform_error(result.matrix, default_matrix, cells2)[0]
                if default_matrix is not None
                else float("nan")
            )
            if case.truth is None:
                rms, right = float("nan"), "unknown"
            else:
                rms = transform_error(result.matrix, case.truth, cells2)[0]
                right = "yes" if rms <= case.tolerance else "no"
            row = Row(case.suite, case.group, case.name, method, round(rms, 3),
                      round(case.tolerance, 2), right, result.accepted,
                      round(result.confidence, 4), round(seconds, 4), round(cpu_seconds, 4),
                      round(from_default, 3), result.reason,
                      stage_text(result.timings) if method == DEFAULT_METHOD else "")  # fmt: skip
            rows.append(row)
            writer.writerow(asdict(row))
            handle.flush()
        print(f"  {case.suite}: {count} pairs ({case.name})", end="\r", file=sys.stderr)
    print(file=sys.stderr)
    return rows


def stage_text(timings: dict[str, float]) -> str:
    """``timings`` (seconds by step) as a row's ``stages``: ``name=ms;...``, the total left out."""
    return ";".join(f"{name}={1000 * value:.2f}" for name, value in timings.items()
                    if name != "total")  # fmt: skip


def stages_table(rows: list[Row]) -> list[str]:
    """Where the default method's time goes: per step of its search, the pairs it ran on,
    its median milliseconds on those and its mean over every pair (what it adds to a
    pair's time); empty without the default's rows."""
    steps: dict[str, list[float]] = {}
    pairs = 0
    for row in rows:
        if row.method != DEFAULT_METHOD or not row.stages:
            continue
        pairs += 1
        for item in row.stages.split(";"):
            name, value = item.split("=")
            steps.setdefault(name, []).append(float(value))
    if not pairs:
        return []
    lines = [
        "",
        f"Where the default's time goes ({pairs} pairs; milliseconds):",
        "",
        "| step | pairs it ran on | median where it ran | mean per pair |",
        "|---|---|---|---|",
    ]
    for name, values in steps.items():
        lines.append(f"| {name} | {len(values)} | {np.median(values):.1f} | "
                     f"{sum(values) / pairs:.1f} |")  # fmt: skip
    return lines


ALL_PAIRS = "all pairs"
"""The group name of a summary row that pools every group of a suite."""


def summary_table(rows: list[Row], methods: list[str]) -> list[str]:
    """Per group and method: right, accepted and right, accepted but wrong, errors, time.

    A suite of several groups ends with a row per method over all its pairs.

    Times are wall clock; ``median CPU s`` is the process's CPU time, which
    exceeds the wall clock for a method that runs on several cores (OpenCV's
    AKAZE does when cores are free).
    """
    lines = [
        "| pairs | method | n | right | accepted and right | accepted but wrong "
        "| median error (cells) | median s | p90 s | time / default's | median CPU s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    known = [r for r in rows if r.right != "unknown"]
    groups = list(dict.fromkeys(r.group for r in known))
    # With several groups, a last row per method pools them: the suite as a whole.
    pooled = [*groups, ALL_PAIRS] if len(groups) > 1 else groups
    for group in pooled:
        members = known if group == ALL_PAIRS else [r for r in known if r.group == group]
        base = [r.seconds for r in members if r.method == methods[0]]
        for method in methods:
            mine = [r for r in members if r.method == method]
            if not mine:
                continue
            right = np.array([r.right == "yes" for r in mine])
            accepted = np.array([r.accepted for r in mine])
            seconds = np.array([r.seconds for r in mine])
            ratio = float(np.median(seconds) / np.median(base)) if base else float("nan")
            lines.append(
                f"| {group} | {method} | {len(mine)} | {right.mean():.1%} | "
                f"{(right & accepted).mean():.1%} | {int((~right & accepted).sum())} | "
                f"{np.median([r.rms_cells for r in mine]):.2f} | {np.median(seconds):.3f} | "
                f"{np.percentile(seconds, 90):.3f} | {ratio:.2f} | "
                f"{np.median([r.cpu_seconds for r in mine]):.3f} |"
            )
    return lines


def by_map_table(rows: list[Row], methods: list[str]) -> list[str]:
    """Window pairs per map and method: accepted and right, and the median times.

    A suite of windows cut from several maps pools maps whose sizes differ
    tenfold, and a method's time grows with the map differently from
    another's: the pooled median of one method may fall between the maps'
    clusters of times. Only pairs named ``map#index`` (windows) are counted.
    """
    windows = [r for r in rows if r.right != "unknown" and "#" in r.pair]
    names = list(dict.fromkeys(r.pair.split("#")[0] for r in windows))
    if len(names) < 2:
        return []
    lines = [
        "",
        "Window pairs per map (medians of each map's pairs):",
        "",
        "| map | method | n | accepted and right | accepted but wrong | median s "
        "| time / default's |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in names:
        members = [r for r in windows if r.pair.split("#")[0] == name]
        base = [r.seconds for r in members if r.method == methods[0]]
        for method in methods:
            mine = [r for r in members if r.method == method]
            if not mine:
                continue
            right = np.array([r.right == "yes" for r in mine])
            accepted = np.array([r.accepted for r in mine])
            seconds = float(np.median([r.seconds for r in mine]))
            ratio = seconds / float(np.median(base)) if base else float("nan")
            lines.append(
                f"| {name} | {method} | {len(mine)} | {(right & accepted).mean():.1%} | "
                f"{int((~right & accepted).sum())} | {seconds:.4f} | {ratio:.2f} |"
            )
    return lines


def settings_line(params: TomographicParams | None) -> list[str]:
    """The report's line naming the default merger's settings a run changed (none: no line)."""
    settings = changed(params)
    if not settings:
        return []
    listed = ", ".join(f"`{name}={value}`" for name, value in settings.items())
    return [f"Default merger's settings changed (`--merger`): {listed}.", ""]


def unknown_table(rows: list[Row]) -> list[str]:
    """The pairs without a known transform: accepted, confidence, distance from the default's."""
    mine = [r for r in rows if r.right == "unknown"]
    if not mine:
        return []
    lines = [
        "",
        "Pairs of one building without a known transform: whether each method accepts its "
        "answer, and how far (cells RMS over map 2's walls) it lies from the default's.",
        "",
        "| pair | method | accepted | confidence | from the default's (cells) | s | reason |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in mine:
        lines.append(
            f"| {r.pair} | {r.method} | {'yes' if r.accepted else 'no'} | {r.confidence:.2f} "
            f"| {r.from_default_cells:.1f} | {r.seconds:.2f} | {r.reason[:90]} |"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("suite", choices=("sessions", "whole", "low-overlap", "moderate-overlap"))
    parser.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    parser.add_argument("--pairs-per-map", type=int, default=None,
                        help="window pairs per map (whole: 10, low-overlap: 75, "
                             "moderate-overlap: 50)")  # fmt: skip
    parser.add_argument(
        "--every",
        type=int,
        default=1,
        help="sessions: every n-th E5 pair (an odd n keeps both the even and the odd half)",
    )
    parser.add_argument("--seed", type=non_negative_int, default=2026)
    parser.add_argument(
        "--from-truth",
        action="store_true",
        help=f"add rows '{FROM_TRUTH}' and '{TRUTH_IN_SEARCH}' per pair with a known "
        "transform: the default's verdict on its refinement started at the truth, without "
        "the checks that need a search, and with them, against the search's own pool "
        "(bounds on what a better search could add)",
    )
    add_merger_argument(parser)
    parser.add_argument("--out", type=Path, default=Path("results/bench_real_maps"))
    args = parser.parse_args(argv)
    params = merger_params(args.merger)
    if maps_dir() is None:
        print(f"error: {maps_missing()}", file=sys.stderr)
        return 1
    unknown = sorted(set(args.methods) - set(merging.available_methods()))
    if unknown:
        print(f"error: unknown method(s) {unknown}; choose from {merging.available_methods()}",
              file=sys.stderr)  # fmt: skip
        return 2
    if args.every < 1 or (args.pairs_per_map is not None and args.pairs_per_map < 1):
        print("error: --every and --pairs-per-map must be positive integers", file=sys.stderr)
        return 2
    methods = available(list(args.methods))
    if DEFAULT_METHOD in methods:
        # The "default's" columns compare with the first method run: the default's.
        methods.remove(DEFAULT_METHOD)
        methods.insert(0, DEFAULT_METHOD)
    if args.from_truth:
        methods += TRUTH_ROWS
    if args.suite == "sessions":
        cases = session_cases(args.every)
    elif args.suite == "whole":
        cases = whole_cases(args.pairs_per_map or 10, args.seed)
    elif args.suite == "moderate-overlap":
        cases = window_cases(args.suite, MODERATE_OVERLAP, args.pairs_per_map or 50, args.seed)
    else:
        cases = low_overlap_cases(args.pairs_per_map or 75, args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    csv_path = args.out / f"{args.suite}.csv"
    with csv_path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(Row.__dataclass_fields__))
        writer.writeheader()
        rows = run(cases, methods, args.seed, writer, handle, params)
    report = [f"# {args.suite}", "", *settings_line(params), *summary_table(rows, methods),
              *by_map_table(rows, methods), *stages_table(rows),
              *unknown_table(rows)]  # fmt: skip
    md_path = args.out / f"{args.suite}.md"
    md_path.write_text("\n".join(report) + "\n")
    print("\n".join(report))
    print(f"\nrows: {csv_path}  report: {md_path}")
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
