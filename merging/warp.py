"""Resampling a grid through a map transformation matrix (nearest neighbour)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging.grid import UNKNOWN


def warp_cells(
    cells: NDArray[np.int8],
    matrix: NDArray[np.float64],
    shape: tuple[int, int],
    *,
    fill: int = UNKNOWN,
) -> NDArray[np.int8]:
    """Carry ``cells`` into an output grid of ``shape`` through ``matrix``.

    ``matrix`` takes the input's cell coordinates ``(x, y) = (col, row)`` to
    the output's. Each output cell takes the value of the input cell nearest to
    its pre-image (nearest neighbour keeps the ROS coding exact); output cells
    whose pre-image falls off the input get ``fill``.
    """
    rows_out, cols_out = shape
    inverse = np.linalg.inv(np.asarray(matrix, dtype=float))
    ys, xs = np.mgrid[0:rows_out, 0:cols_out]
    src_x = np.rint(inverse[0, 0] * xs + inverse[0, 1] * ys + inverse[0, 2]).astype(np.intp)
    src_y = np.rint(inverse[1, 0] * xs + inverse[1, 1] * ys + inverse[1, 2]).astype(np.intp)
    rows_in, cols_in = cells.shape
    inside = (src_x >= 0) & (src_x < cols_in) & (src_y >= 0) & (src_y < rows_in)
    out = np.full(shape, fill, dtype=np.int8)
    out[inside] = cells[src_y[inside], src_x[inside]]
    return out
