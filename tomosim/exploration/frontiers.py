"""Frontier detection and clustering on an occupancy grid.

A *frontier cell* is a known-free cell with an unknown cell among its four
neighbours: driving there shows the robot something new. Frontier cells are
grouped into 8-connected clusters; clusters smaller than a threshold are
sensor speckle rather than openings and are dropped.

Grids here are the planning grid's three-valued cell state (see
:func:`coarsen`), indexed ``[row, col]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from merging.grid import FREE_THRESHOLD, OCCUPIED_THRESHOLD
from tomosim.kernels.planning import FREE_CELL, OCCUPIED_CELL, UNKNOWN_CELL

FOUR_CONNECTED = ndimage.generate_binary_structure(2, 1)
EIGHT_CONNECTED = ndimage.generate_binary_structure(2, 2)


def coarsen(
    cells: NDArray[np.int8],
    factor: int,
    *,
    free_below: int = FREE_THRESHOLD + 1,
    occupied_from: int = OCCUPIED_THRESHOLD,
) -> NDArray[np.uint8]:
    """Reduce a ROS-coded grid to planning states, ``factor`` x ``factor`` cells per cell.

    A coarse cell is *occupied* if any of its cells is ``>= occupied_from``,
    else *free* if any is known and ``< free_below``, else *unknown*. Edges
    are padded with unknown cells. The defaults are ``map_server``'s
    thresholds (occupied >= 65, free <= 19). The planner runs the compiled
    :func:`tomosim.kernels.planning.block_states`, which the tests compare
    with this.

    Returns
    -------
    (ceil(rows / factor), ceil(cols / factor)) uint8 ndarray
        :data:`UNKNOWN_CELL`, :data:`FREE_CELL` or :data:`OCCUPIED_CELL`.
    """
    if factor < 1:
        raise ValueError(f"factor must be a positive integer, got {factor}")
    rows, cols = cells.shape
    pad_rows, pad_cols = -rows % factor, -cols % factor
    padded = np.pad(cells, ((0, pad_rows), (0, pad_cols)), constant_values=-1)
    blocks = padded.reshape(padded.shape[0] // factor, factor, padded.shape[1] // factor, factor)
    occupied = (blocks >= occupied_from).any(axis=(1, 3))
    free = ((blocks >= 0) & (blocks < free_below)).any(axis=(1, 3))
    state = np.full(occupied.shape, UNKNOWN_CELL, dtype=np.uint8)
    state[free] = FREE_CELL
    state[occupied] = OCCUPIED_CELL
    return state


def frontier_mask(state: NDArray[np.uint8]) -> NDArray[np.bool_]:
    """Free cells with a 4-neighbour that is unknown (cells off the grid count as unknown)."""
    unknown = np.pad(state == UNKNOWN_CELL, 1, constant_values=True)
    near_unknown = ndimage.binary_dilation(unknown, structure=FOUR_CONNECTED)[1:-1, 1:-1]
    return (state == FREE_CELL) & near_unknown


@dataclass(frozen=True, slots=True)
class Frontier:
    """One cluster of frontier cells.

    Attributes
    ----------
    cells : (K, 2) int ndarray
        ``(x, y) = (col, row)`` of its cells in the planning grid.
    size : int
        ``K``.
    """

    cells: NDArray[np.intp]
    size: int


def frontier_clusters(state: NDArray[np.uint8], *, min_size: int = 1) -> list[Frontier]:
    """8-connected clusters of frontier cells with at least ``min_size`` cells.

    Clusters are returned in a fixed order (by their first cell in row-major
    order), so planning on the same grid always sees them alike. The policy
    runs the compiled :func:`tomosim.kernels.planning.frontier_groups`, which
    the tests compare with this.
    """
    if min_size < 1:
        raise ValueError(f"min_size must be at least 1, got {min_size}")
    labels, count = ndimage.label(frontier_mask(state), structure=EIGHT_CONNECTED)
    if count == 0:
        return []
    rows, cols = np.nonzero(labels)
    ids = labels[rows, cols]
    order = np.argsort(ids, kind="stable")
    rows, cols, ids = rows[order], cols[order], ids[order]
    splits = np.flatnonzero(np.diff(ids)) + 1
    clusters = []
    for r, c in zip(np.split(rows, splits), np.split(cols, splits), strict=True):
        if len(r) >= min_size:
            clusters.append(Frontier(np.column_stack([c, r]), len(r)))
    return clusters
