"""Benchmark the mergers on the paper's section 4.1 protocol, on real maps.

For each map, window pairs are cut with :func:`merging.evaluation.pairs.cut_window_pairs`
(the second window rotated by a uniform random angle and shifted, average
overlap 0.15-0.9). Every method runs on the same pairs, one after the other,
so that machine load affects them alike. Reported per method:

* ``within2``: fraction of pairs whose RMS error on map 2's occupied cells is
  at most 2 cells;
* ``accepted`` and ``acc_wrong``: fractions accepted, and accepted yet wrong
  (more than 2 cells RMS);
* ``Ψ``: mean and standard deviation of the matching index of eq. (31);
* time: median and 90th percentile, in milliseconds;

and how time grows with the side of square maps (200 to 4000 cells; windows
larger than ``aces3`` are cut from it drawn at a finer resolution, each cell
split into 2 x 2 or 3 x 3, so the building and its walls are the same and only
the cell count grows), for the methods of ``--scaling-methods`` (by default
also the ROS ``multirobot_map_merge`` pipeline, when OpenCV is installed).

Each pair's result is appended to a CSV file as soon as it is known, so an
interrupted run keeps what it measured.

Usage::

    python scripts/bench_merge.py                       # 30 pairs a map, and the scaling
    python scripts/bench_merge.py --pairs-per-map 5 --sizes 200 400   # a quick look
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import merging
from merging.evaluation.metrics import matching_index, transform_error
from merging.evaluation.pairs import cut_window_pairs
from tomosim.commands.script_args import (
    missing_maps,
    non_negative_int,
    positive_int,
    run_script,
    shared_maps,
)
from tomosim.data import maps_dir, maps_missing

DEFAULT_MAPS = ("aces3", "intel", "fr079", "brsu_c069")
DEFAULT_METHODS = ("tomographic", "paper")
SUCCESS_CELLS = 2.0
"""A merge is right when map 2's occupied cells land within this RMS distance."""
SCALING_MAP = "aces3"
"""The largest map, from which the square windows of the scaling runs are cut."""
SCALING_METHODS = ("tomographic", "paper", "ros_akaze")
"""Methods timed against map size by default (OpenCV ones only when installed)."""
SLOW = 10.0
"""Seconds per pair past which a method is not timed at larger sizes (AKAZE takes over
a minute per pair at 3200 cells a side)."""
PADDED_SIZES = (2000, 3000, 4000)
"""Canvas sides (cells) into which the whole building is laid, unknown around it."""


@dataclass(frozen=True, slots=True)
class Row:
    """One method on one pair."""

    map: str
    pair: int
    method: str
    overlap: float
    rms_cells: float
    rotation_error_deg: float
    accepted: bool
    confidence: float
    matching_index: float
    truth_matching_index: float
    seconds: float


OPENCV_METHODS = ("ros_akaze", "ros_orb")
"""Methods that need the optional OpenCV."""


def has_opencv() -> bool:
    """Whether OpenCV is installed (the ROS pipeline baselines need it)."""
    return importlib.util.find_spec("cv2") is not None


def run_pairs(names, methods, pairs_per_map, seed, writer, handle) -> list[Row]:
    rows: list[Row] = []
    folder = shared_maps()
    for name in names:
        grid = merging.load_map(folder / f"{name}.yaml")
        pairs = cut_window_pairs(grid.data, count=pairs_per_map, rng=seed)
        for index, pair in enumerate(pairs):
            truth_index = matching_index(pair.map1, pair.map2, pair.truth)
            for method in methods:
                result = merging.estimate_transform(pair.map1, pair.map2, method=method, rng=seed)
                rms, rotation = transform_error(result.matrix, pair.truth, pair.map2)
                row = Row(
                    name,
                    index,
                    method,
                    round(pair.overlap, 4),
                    round(rms, 3),
                    round(rotation, 3),
                    result.accepted,
                    round(result.confidence, 4),
                    round(matching_index(pair.map1, pair.map2, result.matrix), 4),
                    round(truth_index, 4),
                    round(result.timings["total"], 5),
                )
                rows.append(row)
                writer.writerow(asdict(row))
                handle.flush()
            print(f"  {name} pair {index + 1}/{len(pairs)}", end="\r", file=sys.stderr)
    print(file=sys.stderr)
    return rows


def summarise(rows: list[Row]) -> dict[str, float]:
    right = np.array([r.rms_cells <= SUCCESS_CELLS for r in rows])
    accepted = np.array([r.accepted for r in rows])
    psi = np.array([r.matching_index for r in rows])
    ms = np.array([r.seconds for r in rows]) * 1000
    return {
        "pairs": len(rows),
        "within2": float(right.mean()),
        "accepted": float(accepted.mean()),
        "acc_wrong": float((accepted & ~right).mean()),
        "psi_mean": float(psi.mean()),
        "psi_std": float(psi.std()),
        "median_ms": float(np.median(ms)),
        "p90_ms": float(np.percentile(ms, 90)),
    }


def scaling(methods, sizes, repeats, seed) -> dict[str, dict[int, list[float]]]:
    grid = merging.load_map(shared_maps() / f"{SCALING_MAP}.yaml")
    times: dict[str, dict[int, list[float]]] = {m: {} for m in methods}
    for size in sizes:
        slow = [m for m in methods if times[m] and np.median(times[m][max(times[m])]) > SLOW]
        # Split cells until the map holds the window; large windows of one building are
        # mostly unobserved: only timing matters here.
        split = max(1, int(np.ceil(size / min(grid.shape))))
        cells = np.repeat(np.repeat(grid.data, split, axis=0), split, axis=1)
        pairs = cut_window_pairs(
            cells, count=repeats, window=(size, size), min_known_fraction=0.05, rng=seed
        )
        for pair in pairs:
            for method in methods:
                if method in slow:
                    continue
                start = time.perf_counter()
                merging.estimate_transform(pair.map1, pair.map2, method=method, rng=seed)
                times[method].setdefault(size, []).append(time.perf_counter() - start)
        print(f"  scaling {size}x{size} done", file=sys.stderr)
    return times


def padded_scaling(sizes, repeats, seed) -> dict[int, tuple[float, float]]:
    """The default method on the whole building in canvases of growing side.

    Map 2 is map 1 shifted by (23, 37) cells; the building (its wall cells)
    stays the same and only the unknown area around it grows. Returns per
    side the median seconds and the largest error in cells RMS.
    """
    whole = merging.load_map(shared_maps() / f"{SCALING_MAP}.yaml").data
    rows, cols = whole.shape
    out: dict[int, tuple[float, float]] = {}
    for size in sizes:
        first = np.full((size, size), -1, dtype=np.int8)
        second = first.copy()
        first[:rows, :cols] = whole
        second[37 : 37 + rows, 23 : 23 + cols] = whole
        truth = np.array([[1.0, 0.0, -23.0], [0.0, 1.0, -37.0], [0.0, 0.0, 1.0]])
        seconds, errors = [], []
        for _ in range(repeats):
            start = time.perf_counter()
            result = merging.estimate_transform(first, second, rng=seed)
            seconds.append(time.perf_counter() - start)
            errors.append(transform_error(result.matrix, truth, second)[0])
        out[size] = (float(np.median(seconds)), float(max(errors)))
        print(f"  padded {size}x{size} done", file=sys.stderr)
    return out


def markdown(summary: dict, per_map: dict, times: dict, truth_psi: float) -> str:
    lines = [
        "| method | pairs | within 2 cells | accepted | accepted but wrong | Ψ mean ± sd "
        "| median ms | p90 ms |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for method, s in summary.items():
        lines.append(
            f"| {method} | {s['pairs']} | {s['within2']:.1%} | {s['accepted']:.1%} | "
            f"{s['acc_wrong']:.1%} | {s['psi_mean']:.3f} ± {s['psi_std']:.3f} | "
            f"{s['median_ms']:.0f} | {s['p90_ms']:.0f} |"
        )
    lines += ["", f"Ψ of the true transform (rasterisation limit): {truth_psi:.3f}", ""]
    lines += [
        "| map | method | within 2 cells | accepted but wrong | median ms |",
        "|---|---|---|---|---|",
    ]
    for (name, method), s in per_map.items():
        lines.append(
            f"| {name} | {method} | {s['within2']:.1%} | {s['acc_wrong']:.1%} "
            f"| {s['median_ms']:.0f} |"
        )
    if times:
        methods = list(times)
        sizes = sorted({size for timed in times.values() for size in timed})
        lines += [
            "",
            "| side (cells) | " + " | ".join(f"{m} median ms (IQR)" for m in methods) + " |",
            "|---|" + "---|" * len(methods),
        ]
        for size in sizes:
            cells = []
            for m in methods:
                if size not in times[m]:
                    cells.append(f"not timed (over {SLOW:.0f} s at a smaller size)")
                    continue
                t = np.array(times[m][size]) * 1000
                q1, q3 = np.percentile(t, [25, 75])
                cells.append(f"{np.median(t):.0f} ({q1:.0f}-{q3:.0f})")
            lines.append(f"| {size} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def padded_markdown(padded: dict[int, tuple[float, float]], building: tuple[int, int]) -> str:
    """The padded-canvas timings as a Markdown table."""
    lines = [
        "",
        f"The whole building ({building[0]} x {building[1]} cells) in a larger unknown canvas, "
        "map 2 shifted by (23, 37) cells: same wall cells, growing area.",
        "",
        "| canvas side (cells) | tomographic median ms | largest error (cells RMS) |",
        "|---|---|---|",
    ]
    for size, (seconds, error) in padded.items():
        lines.append(f"| {size} | {seconds * 1000:.0f} | {error:.2f} |")
    return "\n".join(lines)


def plot_scaling(times: dict[str, dict[int, list[float]]], path: Path) -> None:
    """Median time against map side, log-log, one line per method (needs matplotlib)."""
    try:
        import matplotlib
        import matplotlib.ticker

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print('no plot: plotting needs matplotlib: pip install "tomosim[plot]"', file=sys.stderr)
        return
    fig, axis = plt.subplots(figsize=(5, 3.6))
    for method, per_size in times.items():
        sizes = sorted(per_size)
        medians = [np.median(per_size[n]) * 1000 for n in sizes]
        low = [np.percentile(per_size[n], 25) * 1000 for n in sizes]
        high = [np.percentile(per_size[n], 75) * 1000 for n in sizes]
        axis.plot(sizes, medians, marker="o", label=method)
        axis.fill_between(sizes, low, high, alpha=0.2)
    axis.set_xscale("log")
    axis.set_yscale("log")
    axis.set_xlabel("map side (cells)")
    axis.set_ylabel("time per pair (ms)")
    axis.axhline(50, color="grey", linestyle=":", linewidth=1)
    sizes = sorted({n for per_size in times.values() for n in per_size})
    axis.set_xticks(sizes, [str(n) for n in sizes], rotation=45)
    axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axis.legend()
    axis.set_title("merge time against map size")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", nargs="+", default=list(DEFAULT_MAPS))
    parser.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    parser.add_argument("--pairs-per-map", type=positive_int, default=30)
    parser.add_argument(
        "--sizes", nargs="*", type=positive_int, default=[200, 400, 800, 1600, 2400, 3200, 4000]
    )
    parser.add_argument("--scaling-methods", nargs="*", default=list(SCALING_METHODS))
    parser.add_argument("--size-repeats", type=positive_int, default=5)
    parser.add_argument("--seed", type=non_negative_int, default=2020)
    parser.add_argument("--out", type=Path, default=Path("results/bench_merge"))
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    args = parser.parse_args(argv)
    if maps_dir() is None:
        print(f"error: {maps_missing()}", file=sys.stderr)
        return 1
    problem = missing_maps(args.maps, "--maps")
    if problem is not None:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    unknown = sorted(set(args.methods + args.scaling_methods) - set(merging.available_methods()))
    if unknown:
        print(
            f"error: unknown method(s) {unknown}; choose from {merging.available_methods()}",
            file=sys.stderr,
        )
        return 2
    args.out.parent.mkdir(parents=True, exist_ok=True)
    csv_path = args.out.with_suffix(".csv")
    with csv_path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(Row.__dataclass_fields__))
        writer.writeheader()
        rows = run_pairs(args.maps, args.methods, args.pairs_per_map, args.seed, writer, handle)
    summary = {m: summarise([r for r in rows if r.method == m]) for m in args.methods}
    per_map = {
        (name, m): summarise([r for r in rows if r.method == m and r.map == name])
        for name in args.maps
        for m in args.methods
    }
    truth_psi = float(np.mean([r.truth_matching_index for r in rows]))
    # Write the accuracy report first, so that it survives a failure in the timing runs.
    args.out.with_suffix(".md").write_text(markdown(summary, per_map, {}, truth_psi) + "\n")
    timed = [m for m in args.scaling_methods if m not in OPENCV_METHODS or has_opencv()]
    if len(timed) < len(args.scaling_methods):
        print('no OpenCV: timing without ros_*; pip install "tomosim[opencv]"', file=sys.stderr)
    times = scaling(timed, args.sizes, args.size_repeats, args.seed) if args.sizes else {}
    report = markdown(summary, per_map, times, truth_psi)
    # The padded canvases up to the largest size asked for: a quick look at small sizes
    # does not time 4000-cell canvases.
    padded_sizes = [size for size in PADDED_SIZES if args.sizes and size <= max(args.sizes)]
    if padded_sizes:
        padded = padded_scaling(padded_sizes, args.size_repeats, args.seed)
        shape = merging.load_map(shared_maps() / f"{SCALING_MAP}.yaml").shape
        report += "\n" + padded_markdown(padded, shape)
    args.out.with_suffix(".md").write_text(report + "\n")
    if times:
        plot_scaling(times, args.out.with_suffix(".png"))
    if args.json:
        print(
            json.dumps(
                {
                    "summary": summary,
                    "truth_psi": truth_psi,
                    "scaling_ms": {
                        m: {s: float(np.median(v) * 1000) for s, v in t.items()}
                        for m, t in times.items()
                    },
                },
                indent=2,
            )
        )
    else:
        print(report)
        print(f"\nrows: {csv_path}  report: {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
