"""Resampling a grid through a map transformation matrix (nearest neighbour), compiled.

The resampling is that of :func:`scipy.ndimage.affine_transform` of order 0
with ``mode="grid-constant"`` (the tests compare the two cell for cell): the
pre-image of output cell ``(row, col)`` is computed in double precision in
the same order of operations as scipy does, rounded half up to the nearest
input cell, and looked up. A compiled loop does this several times faster
than scipy's general n-dimensional one, which matters because every merge
round warps every robot's grid once or twice (fusion, scoring, teammate layers).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from merging.grid import UNKNOWN


@numba.njit(cache=True, nogil=True)
def _warp_nearest(
    cells: NDArray[np.int8],
    inverse: NDArray[np.float64],
    rows_out: int,
    cols_out: int,
    fill: int,
) -> NDArray[np.int8]:
    """Output cell ``(r, c)`` takes input cell ``round(inverse @ (c, r, 1))`` (``fill`` off it).

    ``inverse`` is the 3x3 matrix taking output cell coordinates ``(x, y)`` to
    the input's. The row coordinate is ``(inverse[1, 2] + r * inverse[1, 1]) +
    c * inverse[1, 0]`` and the column ``(inverse[0, 2] + r * inverse[0, 1]) +
    c * inverse[0, 0]``, summed in this order (scipy's), and rounded by
    ``floor(v + 0.5)``.
    """
    rows, cols = cells.shape
    out = np.empty((rows_out, cols_out), dtype=np.int8)
    row_by_row, row_by_col, row_shift = inverse[1, 1], inverse[1, 0], inverse[1, 2]
    col_by_row, col_by_col, col_shift = inverse[0, 1], inverse[0, 0], inverse[0, 2]
    value_fill = np.int8(fill)
    for r in range(rows_out):
        fr = float(r)
        for c in range(cols_out):
            fc = float(c)
            # Rounded in floating point, and compared before any conversion to an index.
            source_row = np.floor(row_shift + fr * row_by_row + fc * row_by_col + 0.5)
            source_col = np.floor(col_shift + fr * col_by_row + fc * col_by_col + 0.5)
            value = value_fill
            if 0.0 <= source_row < rows and 0.0 <= source_col < cols:
                value = cells[np.uint64(source_row), np.uint64(source_col)]
            out[r, c] = value
    return out


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
    its pre-image (nearest neighbour keeps the ROS coding exact; a pre-image
    half-way between two cells takes the higher one); output cells whose
    pre-image falls off the input get ``fill``.

    The result is that of :func:`scipy.ndimage.affine_transform` of order 0,
    ``mode="grid-constant"``, given the inverse matrix with its axes swapped
    (scipy indexes ``(row, col)``), cell for cell (module docstring).
    """
    inverse = np.linalg.inv(np.asarray(matrix, dtype=float))
    rows_out, cols_out = (int(n) for n in shape)
    source = np.ascontiguousarray(cells, dtype=np.int8)
    return _warp_nearest(source, inverse, rows_out, cols_out, int(fill))
