"""How good a merge is: the paper's matching index, the acceptance index, error to truth."""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import (
    FREE_THRESHOLD,
    OCCUPIED_THRESHOLD,
    OccupancyGrid,
    occupied_cells,
    validate_cells,
)
from merging.transforms import apply_transform, checked_transform, matrix_to_pose, wrap_angle

MapLike = ArrayLike | OccupancyGrid
"""A map as the functions here take it: an OccupancyGrid or its cells in the ROS coding."""


def matching_index(map1: MapLike, map2: MapLike, matrix: ArrayLike) -> float:
    """The matching index Ψ of eq. (31) of the paper.

    Map 2 is carried into map 1's grid with ``matrix``; the index is the
    number of cells occupied in both, divided by ``N_overlap``, the number of
    occupied cells in the overlapping area. The paper leaves open whose
    occupied cells ``N_overlap`` counts; we count the cells occupied in
    *either* map within the area both maps know (so a merge that lays walls
    beside walls is not rewarded), which makes Ψ = 1 exactly for a perfect
    overlap of identical maps and lower for every misalignment.

    Returns 0 when the maps do not overlap.
    """
    return _matching(*_counts(map1, map2, matrix)[:2])


@numba.njit(cache=True, nogil=True)
def _overlap_counts(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    inverse: NDArray[np.float64],
    rows: tuple[int, int],
    cols: tuple[int, int],
) -> tuple[int, int, int, int]:
    """Counts over map 1's cells in ``rows`` x ``cols`` (half-open ranges), map 2 carried
    into map 1's grid.

    Each of map 1's known cells is compared with the map 2 cell that
    :func:`merging.warp.warp_cells` would carry onto it (``inverse`` is the
    inverse of the matrix; the pre-image is computed and rounded exactly as
    there), so the counts are those of warping map 2 whole and comparing the
    two grids, without the warped grid. Returns, over the cells both know,
    ``(occupied in both, occupied in either, agreeing, disagreeing)``.
    """
    rows2, cols2 = cells2.shape
    row_shift, row_by_row, row_by_col = inverse[1, 2], inverse[1, 1], inverse[1, 0]
    col_shift, col_by_row, col_by_col = inverse[0, 2], inverse[0, 1], inverse[0, 0]
    both = either = agree = disagree = 0
    for r in range(rows[0], rows[1]):
        fr = float(r)
        for c in range(cols[0], cols[1]):
            value1 = cells1[r, c]
            if value1 < 0:
                continue  # map 1 does not know the cell: it counts for nothing
            fc = float(c)
            # merging.warp._warp_nearest's pre-image, operation for operation.
            source_row = np.floor(row_shift + fr * row_by_row + fc * row_by_col + 0.5)
            source_col = np.floor(col_shift + fr * col_by_row + fc * col_by_col + 0.5)
            if not (0.0 <= source_row < rows2 and 0.0 <= source_col < cols2):
                continue
            value2 = cells2[np.uint64(source_row), np.uint64(source_col)]
            if value2 < 0:
                continue
            occupied1, occupied2 = value1 >= OCCUPIED_THRESHOLD, value2 >= OCCUPIED_THRESHOLD
            free1, free2 = value1 <= FREE_THRESHOLD, value2 <= FREE_THRESHOLD
            both += occupied1 and occupied2
            either += occupied1 or occupied2
            agree += (occupied1 and occupied2) or (free1 and free2)
            disagree += (occupied1 and free2) or (free1 and occupied2)
    return both, either, agree, disagree


REACH_MARGIN = 1
"""Cells added on every side of the part of map 1 that map 2's known cells can reach:
the part is found from the box's corners in floating point, whose rounding must not
cut off a row."""


def _reach(
    cells2: NDArray[np.int8], matrix: NDArray[np.float64], shape1: tuple[int, int]
) -> tuple[tuple[int, int], tuple[int, int]]:
    """Rows and columns (half-open) of map 1 outside which no cell lands on a known cell
    of map 2: those cells count for nothing, so they need no look."""
    known = cells2 >= 0
    rows = np.flatnonzero(known.any(axis=1))
    if len(rows) == 0:
        return (0, 0), (0, 0)
    cols = np.flatnonzero(known.any(axis=0))
    # A map 1 cell lands on map 2 cell s when its pre-image lies within half a cell of s.
    x0, x1 = cols[0] - 0.5, cols[-1] + 0.5
    y0, y1 = rows[0] - 0.5, rows[-1] + 0.5
    corners = np.array([[x0, y0, 1.0], [x1, y0, 1.0], [x0, y1, 1.0], [x1, y1, 1.0]]) @ matrix.T
    low = np.floor(corners[:, :2].min(axis=0)).astype(int) - REACH_MARGIN
    high = np.ceil(corners[:, :2].max(axis=0)).astype(int) + REACH_MARGIN
    rows1, cols1 = shape1
    return (
        (min(max(int(low[1]), 0), rows1), min(max(int(high[1]) + 1, 0), rows1)),
        (min(max(int(low[0]), 0), cols1), min(max(int(high[0]) + 1, 0), cols1)),
    )


def _counts(map1: MapLike, map2: MapLike, matrix: ArrayLike) -> tuple[int, int, int, int]:
    """:func:`_overlap_counts` of two maps given as the public functions take them."""
    cells1 = np.ascontiguousarray(_cells(map1, name="map1"))
    cells2 = np.ascontiguousarray(_cells(map2, name="map2"))
    forward = checked_transform(matrix)  # counted through its inverse: not folding
    inverse = np.ascontiguousarray(np.linalg.inv(forward))  # as merging.warp.warp_cells
    rows, cols = _reach(cells2, forward, cells1.shape)
    counts = _overlap_counts(cells1, cells2, inverse, rows, cols)
    return (int(counts[0]), int(counts[1]), int(counts[2]), int(counts[3]))


def _cells(value: object, *, name: str) -> NDArray[np.int8]:
    """A map as the public functions here take it (an OccupancyGrid or array-like), checked."""
    return validate_cells(
        value if isinstance(value, OccupancyGrid) else np.asarray(value), name=name
    )


def _matching(both: int, either: int) -> float:
    return float(both) / either if either else 0.0


def acceptance_index(map1: MapLike, map2: MapLike, matrix: ArrayLike) -> float:
    """Birk and Carpin's acceptance index ω = agr / (agr + dis).

    Over the cells both maps know after carrying map 2 into map 1's grid,
    ``agr`` counts cells that are occupied in both or free in both, ``dis``
    cells occupied in one and free in the other. Returns 0 without overlap.

    References
    ----------
    A. Birk and S. Carpin, "Merging occupancy grid maps from multiple robots",
    Proc. IEEE 94(7), 2006.
    """
    return _acceptance(*_counts(map1, map2, matrix)[2:])


def _acceptance(agree: int, disagree: int) -> float:
    total = agree + disagree
    return float(agree) / total if total else 0.0


def match_indices(map1: MapLike, map2: MapLike, matrix: ArrayLike) -> tuple[float, float]:
    """``(matching_index, acceptance_index)`` of one transform, comparing the maps once.

    The same values as :func:`matching_index` and :func:`acceptance_index`, at
    half the cost when both are wanted (benchmarks score every method's
    answer with both).
    """
    both, either, agree, disagree = _counts(map1, map2, matrix)
    return _matching(both, either), _acceptance(agree, disagree)


def transform_error(estimate: ArrayLike, truth: ArrayLike, map2: MapLike) -> tuple[float, float]:
    """Error of an estimated transform against the truth, on map 2's occupied cells.

    Returns
    -------
    rms_cells : float
        Root-mean-square distance, in cells, between where ``estimate`` and
        ``truth`` put map 2's occupied cells (its bounding-box corners when it
        has none).
    rotation_deg : float
        Absolute rotation difference in degrees, in ``[0, 180]``.
    """
    cells2 = _cells(map2, name="map2")
    estimate = checked_transform(estimate, name="estimate", invertible=False)
    truth = checked_transform(truth, name="truth", invertible=False)
    points = occupied_cells(cells2)
    if len(points) == 0:
        rows, cols = cells2.shape
        points = np.array([[0, 0], [cols - 1, 0], [0, rows - 1], [cols - 1, rows - 1]], float)
    diff = apply_transform(estimate, points) - apply_transform(truth, points)
    rms = float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))
    rotation = abs(float(wrap_angle(matrix_to_pose(estimate)[2] - matrix_to_pose(truth)[2])))
    return rms, float(np.degrees(rotation))
