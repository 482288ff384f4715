"""The planner's grid, compiled: cell states, the distance to the nearest wall, frontiers.

:func:`block_states` computes :func:`tomosim.exploration.frontiers.coarsen`:
each block of ``factor`` x ``factor`` cells becomes occupied if any of its
cells is occupied, else free if any is known free, else unknown. The numpy
function spells this out with reductions over a padded copy of the grid;
the loop reads each cell once. :func:`distances_to_walls` computes
``scipy.ndimage.distance_transform_edt`` of the free cells, without the
feature transform scipy builds on the way. The planner runs both once per
plan (:func:`tomosim.exploration.planning.planning_grid`).
:func:`frontier_groups` finds the clusters of
:func:`tomosim.exploration.frontiers.frontier_clusters` (``scipy.ndimage.label``
of the frontier mask) in one pass. The tests compare each kernel with its
oracle.
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


@kernel
def frontier_groups(state: NDArray[np.uint8]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The 8-connected groups of frontier cells of a planning grid, in one pass.

    A frontier cell is a free cell with an unknown 4-neighbour (cells off the
    grid count as unknown). Returns ``(cells, starts)``: ``cells[starts[k] :
    starts[k + 1]]`` are the ``(x, y)`` of group ``k``, in row-major order, and
    the groups come in the row-major order of their first cells, as
    :func:`tomosim.exploration.frontiers.frontier_clusters` orders what
    ``scipy.ndimage.label`` finds (the tests compare the two). Groups are joined
    with a union-find over the cells, scanned row by row.
    """
    rows, cols = state.shape
    parent = np.full(rows * cols, -1, dtype=np.intp)  # -1: not a frontier cell
    for r in range(rows):
        for c in range(cols):
            if state[r, c] != FREE_CELL:
                continue
            if not (
                r == 0
                or r == rows - 1
                or c == 0
                or c == cols - 1
                or state[r - 1, c] == UNKNOWN_CELL
                or state[r + 1, c] == UNKNOWN_CELL
                or state[r, c - 1] == UNKNOWN_CELL
                or state[r, c + 1] == UNKNOWN_CELL
            ):
                continue
            here = r * cols + c
            parent[here] = here
            # The neighbours already scanned: west, north-west, north, north-east.
            for dr, dc in ((0, -1), (-1, -1), (-1, 0), (-1, 1)):
                nr, nc = r + dr, c + dc
                if nr < 0 or nc < 0 or nc >= cols or parent[nr * cols + nc] < 0:
                    continue
                a, b = _root(parent, here), _root(parent, nr * cols + nc)
                if a != b:
                    # The root is always a group's first cell in row-major order.
                    parent[max(a, b)] = min(a, b)
    group = np.full(rows * cols, -1, dtype=np.intp)
    sizes = np.zeros(rows * cols + 1, dtype=np.intp)
    count = 0
    for cell in range(rows * cols):
        if parent[cell] < 0:
            continue
        root = _root(parent, cell)
        if root == cell:
            group[cell] = count
            count += 1
        else:
            group[cell] = group[root]
        sizes[group[cell] + 1] += 1
    starts = np.cumsum(sizes[: count + 1])
    filled = starts[:count].copy()
    cells = np.empty((starts[count], 2), dtype=np.intp)
    for cell in range(rows * cols):
        k = group[cell]
        if k >= 0:
            cells[filled[k], 0] = cell % cols
            cells[filled[k], 1] = cell // cols
            filled[k] += 1
    return cells, starts


@kernel
def _root(parent: NDArray[np.intp], cell: int) -> int:
    """The root of ``cell``'s set, halving the path on the way."""
    while parent[cell] != cell:
        parent[cell] = parent[parent[cell]]
        cell = parent[cell]
    return cell
