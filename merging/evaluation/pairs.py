"""Test pairs with a known answer: the protocol of section 4.1 of the paper.

Two windows of the same size are cut from one whole map so that they overlap:
the first along the map's axes, the second from the map turned by a uniformly
random angle about the second window's centre (nearest neighbour, as a
robot's map of the same place would be rasterised anew). Where the second
window lies is the random shift. The true map transformation matrix (map 2
cells -> map 1 cells) follows from the cut, and the overlap is measured
through it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from merging.grid import occupied_mask, validate_cells
from merging.transforms import rigid_matrix, translation_matrix
from merging.validators import as_generator, whole_number
from merging.warp import warp_cells

OVERLAP_RANGE = (0.15, 0.9)
"""Accepted average overlap ratio of a pair, the range of the paper's Figure 7."""
MIN_KNOWN_FRACTION = 0.2
"""A window must be at least this much observed, or it shows too little to merge."""
MIN_OCCUPIED = 200
"""Occupied cells a window must hold: about 10 m of wall at 0.05 m."""
MIN_SHARED_WALL = 50
"""Occupied cells (about 2.5 m of wall) that must lie in the overlap of both
windows: where the overlap shows no wall, no matching method can merge."""
MAX_TRIES = 20000
"""Rejection-sampling attempts before giving up on a map."""


@dataclass(frozen=True, slots=True)
class WindowPair:
    """Two overlapping maps cut from one, and the truth that relates them.

    Attributes
    ----------
    map1, map2 : int8 ndarray
        The two grids, of the same shape; map 2 rotated and shifted.
    truth : (3, 3) float ndarray
        Map transformation matrix taking map 2's cells to map 1's.
    overlap : float
        Mean over both windows of the fraction of their observed cells that
        the other window observes too.
    angle : float
        Angle by which the map was turned before window 2 was cut, radians.
    """

    map1: NDArray[np.int8]
    map2: NDArray[np.int8]
    truth: NDArray[np.float64]
    overlap: float
    angle: float


def overlap_ratio(known1: NDArray[np.bool_], map2: NDArray[np.int8], truth: NDArray[np.float64]):
    """Mean over both windows of the fraction of their observed cells the other observes."""
    known2_in_1 = warp_cells(map2, truth, known1.shape) >= 0
    shared = np.count_nonzero(known1 & known2_in_1)
    n1, n2 = np.count_nonzero(known1), np.count_nonzero(map2 >= 0)
    if n1 == 0 or n2 == 0:
        return 0.0
    return 0.5 * (shared / n1 + shared / n2)


def cut_window_pairs(
    whole: NDArray[np.int8],
    *,
    count: int,
    window: tuple[int, int] | None = None,
    size_fraction: tuple[float, float] = (0.35, 0.55),
    overlap_range: tuple[float, float] = OVERLAP_RANGE,
    min_known_fraction: float = MIN_KNOWN_FRACTION,
    rng: np.random.Generator | int | None = None,
) -> list[WindowPair]:
    """Cut ``count`` window pairs from a whole map (section 4.1 of the paper).

    Parameters
    ----------
    whole : (rows, cols) int8 array
        The whole map in the ROS coding.
    count : int
        Pairs to produce.
    window : (rows, cols), optional
        Fixed window size in cells, placed anywhere on the map. By default
        each pair draws its side lengths uniformly from ``size_fraction`` of
        the extent of the map's observed part, and stays within that part.
    overlap_range : (float, float)
        Accepted average overlap ratio.
    min_known_fraction : float
        Observed fraction each window must have.
    rng : Generator, int or None
        Randomness for windows and angles.

    Raises
    ------
    ValueError
        If ``count`` is not a whole number >= 0, a range is not within
        ``[0, 1]``, or the map is too small or too empty to give such pairs.
    """
    cells = validate_cells(whole, name="whole")
    whole_number(count, "count", minimum=0, unit="pairs")
    for name, (low, high) in (("size_fraction", size_fraction), ("overlap_range", overlap_range)):
        if not 0.0 <= low <= high <= 1.0:
            raise ValueError(f"{name} must be (low, high) with 0 <= low <= high <= 1, got "
                             f"{(low, high)}")  # fmt: skip
    if window is not None and min(window) < 1:
        raise ValueError(f"window must be (rows, cols) of at least one cell, got {window}")
    generator = as_generator(rng)
    known = cells >= 0
    occupied = occupied_mask(cells)
    rows_k, cols_k = np.nonzero(known)
    if len(rows_k) == 0:
        raise ValueError("whole map has no observed cells to cut windows from")
    if window is None:
        y_min, y_max = int(rows_k.min()), int(rows_k.max()) + 1
        x_min, x_max = int(cols_k.min()), int(cols_k.max()) + 1
    else:
        y_min, y_max, x_min, x_max = 0, cells.shape[0], 0, cells.shape[1]
    pairs: list[WindowPair] = []
    for _ in range(MAX_TRIES):
        if len(pairs) == count:
            break
        if window is None:
            h = int(generator.uniform(*size_fraction) * (y_max - y_min))
            w = int(generator.uniform(*size_fraction) * (x_max - x_min))
        else:
            h, w = window
        if h > y_max - y_min or w > x_max - x_min or min(h, w) < 16:
            raise ValueError(
                f"window {h}x{w} does not fit the map's {y_max - y_min}x{x_max - x_min} cells"
            )
        x1 = int(generator.integers(x_min, x_max - w + 1))
        y1 = int(generator.integers(y_min, y_max - h + 1))
        window1 = cells[y1 : y1 + h, x1 : x1 + w]
        if not _rich_enough(window1, occupied[y1 : y1 + h, x1 : x1 + w], min_known_fraction):
            continue
        # Window 2: centred within one window size of window 1's centre (farther
        # ones cannot overlap), cut from the map turned by angle.
        centre = np.array([x1 + (w - 1) / 2, y1 + (h - 1) / 2])
        centre += generator.uniform(-1.0, 1.0, size=2) * np.array([w, h])
        angle = float(generator.uniform(-np.pi, np.pi))
        half = np.array([(w - 1) / 2, (h - 1) / 2])
        whole_to_2 = translation_matrix(half) @ rigid_matrix(0.0, 0.0, angle)
        whole_to_2 = whole_to_2 @ translation_matrix(-centre)
        map2 = warp_cells(cells, whole_to_2, (h, w))
        if not _rich_enough(map2, occupied_mask(map2), min_known_fraction):
            continue
        truth = rigid_matrix(-x1, -y1, 0.0) @ np.linalg.inv(whole_to_2)
        ratio = overlap_ratio(window1 >= 0, map2, truth)
        if overlap_range[0] <= ratio <= overlap_range[1] and _shared_wall(window1, map2, truth):
            pairs.append(WindowPair(window1.copy(), map2, truth, ratio, angle))
    if len(pairs) < count:
        raise ValueError(
            f"found only {len(pairs)} of {count} window pairs with overlap in {overlap_range}; "
            "use smaller windows or a wider overlap range"
        )
    return pairs


def _shared_wall(map1: NDArray[np.int8], map2: NDArray[np.int8], truth: NDArray[np.float64]):
    """Whether both windows show at least :data:`MIN_SHARED_WALL` wall cells of their overlap."""
    map2_in_1 = warp_cells(map2, truth, map1.shape)
    overlap = (map1 >= 0) & (map2_in_1 >= 0)
    walls1 = np.count_nonzero(occupied_mask(map1) & overlap)
    walls2 = np.count_nonzero(occupied_mask(map2_in_1) & overlap)
    return min(walls1, walls2) >= MIN_SHARED_WALL


def _rich_enough(window: NDArray[np.int8], occupied: NDArray[np.bool_], known: float) -> bool:
    """Whether a window shows enough of the map to be worth merging."""
    return bool(
        np.count_nonzero(occupied) >= MIN_OCCUPIED
        and np.count_nonzero(window >= 0) >= known * window.size
    )
