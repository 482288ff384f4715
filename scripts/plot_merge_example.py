"""Draw one merge for the README: two windows of a map, and what the merger made of them.

By default the map is the project's own generated floor plan (seed 3); ``--map
NAME`` takes a real map by name instead (``tomosim maps`` lists them), for a look
that is not committed.

Usage::

    python scripts/plot_merge_example.py [--floor 3 | --map intel] [--seed 7] [--out FILE.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import merging
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from tomosim.commands.script_args import non_negative_int, run_script
from tomosim.worlds import generate_floorplan

GREY = {-1: 0.75, 0: 1.0, 100: 0.0}
"""Grey level per cell class for the pictures: unknown, free, occupied."""


def shade(cells: np.ndarray) -> np.ndarray:
    """Grey image of a grid: walls black, free white, unknown grey."""
    image = np.full(cells.shape, GREY[-1])
    image[(cells >= 0) & (cells <= merging.FREE_THRESHOLD)] = GREY[0]
    image[cells >= merging.OCCUPIED_THRESHOLD] = GREY[100]
    return image


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--floor", type=non_negative_int, default=3, help="generated floor-plan seed"
    )
    parser.add_argument("--map", help="a real map of the shared folder, instead of a floor")
    parser.add_argument("--seed", type=non_negative_int, default=7)
    parser.add_argument("--out", type=Path, default=Path("docs/figures/merge_example.png"))
    args = parser.parse_args(argv)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print('error: plotting needs matplotlib: pip install "tomosim[plot]"', file=sys.stderr)
        return 1
    if args.map is None:
        whole = generate_floorplan(args.floor).truth
    else:
        try:
            whole = merging.load_map(args.map)
        except FileNotFoundError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
    pair = cut_window_pairs(whole.data, count=1, rng=args.seed)[0]
    result = merging.estimate_transform(pair.map1, pair.map2)
    rms, rotation = transform_error(result.matrix, pair.truth, pair.map2)
    fused = merging.merge(pair.map1, pair.map2, result.matrix)

    fig, axes = plt.subplots(1, 3, figsize=(12, 4.4))
    axes[0].imshow(shade(pair.map1), origin="lower", cmap="gray", vmin=0, vmax=1)
    axes[0].set_title("map 1")
    axes[1].imshow(shade(pair.map2), origin="lower", cmap="gray", vmin=0, vmax=1)
    axes[1].set_title(f"map 2 (turned {np.degrees(pair.angle):.0f}°, shifted)")
    # Fused map in grey, with map 2's walls as the merger placed them in red.
    axes[2].imshow(shade(fused.cells), origin="lower", cmap="gray", vmin=0, vmax=1)
    walls2 = np.column_stack(np.nonzero(pair.map2 >= merging.OCCUPIED_THRESHOLD)[::-1])
    to_fused = fused.to_fused[1]
    assert to_fused is not None  # merge() places map 2 by the matrix it is given
    placed = merging.transforms.apply_transform(to_fused, walls2.astype(float))
    axes[2].scatter(placed[:, 0], placed[:, 1], s=0.2, c="tab:red", linewidths=0)
    axes[2].set_title(
        f"fused: error {rms:.2f} cells RMS, {rotation:.2f}°\n"
        f"confidence {result.confidence:.2f}, {result.timings['total'] * 1000:.0f} ms"
    )
    for axis in axes:
        axis.set_xticks([])
        axis.set_yticks([])
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    print(f"{args.out}: overlap {pair.overlap:.2f}, error {rms:.2f} cells, {rotation:.2f} deg")
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
