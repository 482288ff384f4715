"""A pooled window of a robot's best map, compiled.

It computes :meth:`tomosim.team.sharing.SharedMaps.crop`: cut the window out
of the robot's own grid (unknown off the grid), fill its unknown cells from
the teammate layer, and keep the maximum of each ``pool x pool`` block (in
the ROS coding: known beats unknown, occupied beats free). The tests compare
it with exactly that, written with numpy slices.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel


@kernel
def fill_window(
    window: NDArray[np.int8],
    cells: NDArray[np.int8],
    first_row: int,
    first_col: int,
    unknown_only: bool,
) -> None:
    """Copy into ``window`` the cells of ``cells`` it covers; its cell ``(0, 0)`` is
    ``cells[first_row, first_col]`` (which may lie off ``cells``). With
    ``unknown_only``, only window cells still unknown (negative) are written."""
    window_rows, window_cols = window.shape
    rows, cols = cells.shape
    r0, r1 = max(first_row, 0), min(first_row + window_rows, rows)
    c0, c1 = max(first_col, 0), min(first_col + window_cols, cols)
    if r0 >= r1 or c0 >= c1:
        return
    for r in range(r0, r1):
        source = cells[r, c0:c1]
        target = window[r - first_row, c0 - first_col : c1 - first_col]
        if unknown_only:
            for k in range(source.shape[0]):
                value = target[k]
                target[k] = value if value >= 0 else source[k]
        else:
            target[:] = source


@kernel
def covers(cells: NDArray[np.int8], first_row: int, first_col: int, fine: int) -> bool:
    """Whether ``cells`` hold the whole ``fine x fine`` window whose cell ``(0, 0)`` is
    ``cells[first_row, first_col]``."""
    rows, cols = cells.shape
    inside_rows = first_row >= 0 and first_row + fine <= rows
    return inside_rows and first_col >= 0 and first_col + fine <= cols


@kernel
def pool_pairs(
    own: NDArray[np.int8],
    own_row: int,
    own_col: int,
    layer: NDArray[np.int8],
    layer_row: int,
    layer_col: int,
    size: int,
) -> NDArray[np.int8]:
    """:func:`crop_max_pool` with ``pool = 2`` of a window that ``own`` covers, its cell
    ``(0, 0)`` at ``own[own_row, own_col]`` and at ``layer[layer_row, layer_col]`` (which
    may lie off the layer): each pair of fine rows is pooled from the grids' rows, an
    own row copied only where the layer holds unknown own cells' values."""
    width = 2 * size
    layer_rows, layer_cols = layer.shape
    first, last = max(0, -layer_col), min(width, layer_cols - layer_col)  # layer columns
    filled = np.empty((2, width), dtype=np.int8)
    out = np.empty((size, size), dtype=np.int8)
    for i in range(size):
        upper = own[own_row + 2 * i, own_col : own_col + width]
        lower = own[own_row + 2 * i + 1, own_col : own_col + width]
        for half in range(2):
            mates_row = layer_row + 2 * i + half
            if first >= last or mates_row < 0 or mates_row >= layer_rows:
                continue
            row = filled[half]  # unknown own cells take the layer's value
            row[:] = upper if half == 0 else lower
            mates = layer[mates_row]
            for k in range(first, last):
                value = row[k]
                row[k] = value if value >= 0 else mates[layer_col + k]
            if half == 0:
                upper = filled[0]
            else:
                lower = filled[1]
        target = out[i]
        for j in range(size):
            target[j] = max(
                max(upper[2 * j], upper[2 * j + 1]), max(lower[2 * j], lower[2 * j + 1])
            )
    return out


@kernel
def crop_max_pool(
    own: NDArray[np.int8],
    own_a: int,
    own_b: int,
    layer: NDArray[np.int8],
    layer_a: int,
    layer_b: int,
    start_a: int,
    start_b: int,
    size: int,
    pool: int,
) -> NDArray[np.int8]:
    """The ``(size, size)`` pooled window whose first fine cell is lattice ``(start_a, start_b)``.

    Parameters
    ----------
    own : (rows, cols) int8 ndarray
        The robot's grid (ROS coding); its cell ``(0, 0)`` is lattice ``(own_a, own_b)``.
    layer : (rows2, cols2) int8 ndarray
        The teammate layer (ROS coding), anchored at ``(layer_a, layer_b)``; an
        empty ``(0, 0)`` array when there is none.
    start_a, start_b : int
        Lattice cell of the window's first fine cell (its lowest ``a`` and ``b``).
    size, pool : int
        Output cells per side, and fine cells per output cell per side.

    Returns
    -------
    (size, size) int8 ndarray
        Row ``i``, column ``j`` covers fine rows ``i * pool ...``, columns ``j * pool ...``.
    """
    fine = size * pool
    own_row, own_col = start_b - own_b, start_a - own_a
    layer_row, layer_col = start_b - layer_b, start_a - layer_a
    # 0. The default pool of 2 on a window inside the robot's grid (nearly always):
    # pooled from the grids' rows, with no window built.
    if pool == 2 and covers(own, own_row, own_col, fine):
        return pool_pairs(own, own_row, own_col, layer, layer_row, layer_col, size)
    # 1. The fine window, by row slices: own cells, then the layer's where own are unknown.
    window = np.full((fine, fine), np.int8(-1))
    fill_window(window, own, own_row, own_col, False)
    fill_window(window, layer, layer_row, layer_col, True)
    # 2. The maximum of each block (pairs of rows and columns spelt out for the default).
    out = np.empty((size, size), dtype=np.int8)
    if pool == 2:
        for i in range(size):
            upper = window[2 * i]
            lower = window[2 * i + 1]
            row = out[i]
            for j in range(size):
                row[j] = max(
                    max(upper[2 * j], upper[2 * j + 1]), max(lower[2 * j], lower[2 * j + 1])
                )
        return out
    for i in range(size):
        for j in range(size):
            best = np.int8(-1)
            for di in range(pool):
                for dj in range(pool):
                    best = max(best, window[i * pool + di, j * pool + dj])
            out[i, j] = best
    return out
