"""The planner's grid, compiled: cell states and the distance to the nearest wall.

:func:`block_states` computes :func:`tomosim.exploration.frontiers.coarsen`:
each block of ``factor`` x ``factor`` cells becomes occupied if any of its
cells is occupied, else free if any is known free, else unknown. The numpy
function spells this out with reductions over a padded copy of the grid;
the loop reads each cell once. :func:`distances_to_walls` computes
``scipy.ndimage.distance_transform_edt`` of the free cells, without the
feature transform scipy builds on the way. The planner runs both once per
plan (:func:`tomosim.exploration.planning.planning_grid`); the tests compare
each with its oracle.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel

UNKNOWN_CELL, FREE_CELL, OCCUPIED_CELL = 0, 1, 2
"""Cell states of a planning grid (:mod:`tomosim.exploration.frontiers` uses them too)."""


@kernel
def block_states(
    cells: NDArray[np.int8], factor: int, free_below: int, occupied_from: int
) -> NDArray[np.uint8]:
    """The state of each ``factor`` x ``factor`` block of ``cells`` (ROS coding).

    Occupied (:data:`OCCUPIED_CELL`) where a cell is ``>= occupied_from``,
    else free (:data:`FREE_CELL`) where a cell is known and ``< free_below``,
    else unknown (:data:`UNKNOWN_CELL`); blocks past the last row or column
    hold only the cells there are. Returns ``(ceil(rows / factor),
    ceil(cols / factor))`` uint8.
    """
    rows, cols = cells.shape
    out = np.zeros((-(-rows // factor), -(-cols // factor)), dtype=np.uint8)
    for r in range(rows):
        states = out[r // factor]
        line = cells[r]
        for c in range(cols):
            value = line[c]
            if value >= occupied_from:
                states[c // factor] = OCCUPIED_CELL
            elif value >= 0 and value < free_below and states[c // factor] == UNKNOWN_CELL:
                states[c // factor] = FREE_CELL
    return out


@kernel
def distances_to_walls(occupied: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Euclidean distance, in cells, from each cell's centre to the nearest occupied one.

    ``scipy.ndimage.distance_transform_edt(~occupied)`` to the bit, by the
    exact two-pass algorithm of Meijster, Roerdink and Hesselink (2000): the
    distance to the nearest occupied cell of each column, then, row by row,
    the lower envelope of the parabolas ``(x - i)**2 + g(i)**2`` in whole
    numbers, so the squared distances are exact integers, as those of
    scipy's feature transform. ``occupied`` must hold an occupied cell.
    """
    rows, cols = occupied.shape
    far = rows + cols  # beyond any distance on the grid: a column with no occupied cell
    column = np.empty((rows, cols), dtype=np.int64)
    for c in range(cols):
        column[0, c] = 0 if occupied[0, c] else far
        for r in range(1, rows):
            column[r, c] = 0 if occupied[r, c] else min(column[r - 1, c] + 1, far)
        for r in range(rows - 2, -1, -1):
            if column[r + 1, c] < column[r, c]:
                column[r, c] = column[r + 1, c] + 1
    out = np.empty((rows, cols), dtype=np.float64)
    starts = np.empty(cols, dtype=np.int64)  # where each parabola of the envelope begins
    sites = np.empty(cols, dtype=np.int64)  # the column each one stands for
    for r in range(rows):
        heights = column[r]
        top = 0
        sites[0], starts[0] = 0, 0
        for u in range(1, cols):
            while top >= 0:
                site = sites[top]
                x = starts[top]
                own = (x - site) ** 2 + heights[site] ** 2
                if own <= (x - u) ** 2 + heights[u] ** 2:
                    break
                top -= 1
            if top < 0:
                top = 0
                sites[0], starts[0] = u, 0
            else:
                site = sites[top]
                # The first column from which u's parabola lies below site's.
                meet = 1 + (u * u - site * site + heights[u] ** 2 - heights[site] ** 2) // (
                    2 * (u - site)
                )
                if meet < cols:
                    top += 1
                    sites[top], starts[top] = u, meet
        for x in range(cols - 1, -1, -1):
            site = sites[top]
            out[r, x] = np.sqrt(float((x - site) ** 2 + heights[site] ** 2))
            if x == starts[top]:
                top -= 1
    return out
