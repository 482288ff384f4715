"""Time the default merger's hand-written kernels against the library calls they replace.

A kernel is kept hand-written only while it is clearly faster than the
library call doing the same job (each is also tested to give the library's
result, in ``tests/merging/tomographic/test_kernels.py``). Today one such kernel:

* :func:`merging.evidence.verify.dilate` (chessboard dilation by separable shifted
  ORs) against ``scipy.ndimage.binary_dilation`` with a square element and
  ``scipy.ndimage.maximum_filter``.

Runs on the occupied cells of a whole real map (``aces3``, 1803 x 1647 by
default) and prints the median of repeated timings, in milliseconds.

Usage::

    python scripts/bench_kernels.py [--map aces3] [--repeats 20]
"""

from __future__ import annotations

import argparse
import sys
import timeit

import numpy as np
from scipy import ndimage

import merging
from merging.evidence.verify import dilate
from merging.grid import occupied_mask
from tomosim.commands.script_args import positive_int, run_script
from tomosim.data import maps_dir, maps_missing


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--map", default="aces3")
    parser.add_argument("--repeats", type=positive_int, default=20)
    args = parser.parse_args(argv)
    folder = maps_dir()
    if folder is None:
        print(f"error: {maps_missing()}", file=sys.stderr)
        return 1
    mask = occupied_mask(merging.load_map(folder / f"{args.map}.yaml").data)
    print(f"{args.map}: {mask.shape[0]} x {mask.shape[1]} cells, {int(mask.sum())} occupied")
    print("radius  dilate ms  binary_dilation ms  maximum_filter ms")
    for radius in (1, 3):
        square = np.ones((2 * radius + 1, 2 * radius + 1), dtype=bool)
        candidates = {
            "dilate": lambda: dilate(mask, radius),  # noqa: B023  (timed within the loop)
            "binary_dilation": lambda: ndimage.binary_dilation(mask, structure=square),  # noqa: B023
            "maximum_filter": lambda: ndimage.maximum_filter(mask, size=2 * radius + 1),  # noqa: B023
        }
        reference = candidates["binary_dilation"]()
        for name, run in candidates.items():
            if not np.array_equal(run(), reference):
                print(f"error: {name} differs from binary_dilation", file=sys.stderr)
                return 1
        medians = {
            name: 1000 * float(np.median(timeit.repeat(run, number=1, repeat=args.repeats)))
            for name, run in candidates.items()
        }
        print(
            f"{radius:6d}  {medians['dilate']:9.2f}  {medians['binary_dilation']:18.2f}  "
            f"{medians['maximum_filter']:17.2f}"
        )
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
