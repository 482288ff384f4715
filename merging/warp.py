"""Resampling a grid through a map transformation matrix (nearest neighbour)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

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

    The work is :func:`scipy.ndimage.affine_transform` of order 0, which
    indexes ``(row, col)``: the inverse matrix is handed over with its axes
    swapped.
    """
    inverse = np.linalg.inv(np.asarray(matrix, dtype=float))
    # ndimage maps an output index (row, col) to the input index M @ (row, col) + offset.
    swapped = np.array([[inverse[1, 1], inverse[1, 0]], [inverse[0, 1], inverse[0, 0]]])
    offset = np.array([inverse[1, 2], inverse[0, 2]])
    return ndimage.affine_transform(
        np.asarray(cells, dtype=np.int8),
        swapped,
        offset=offset,
        output_shape=tuple(int(n) for n in shape),
        order=0,
        mode="grid-constant",
        cval=fill,
        prefilter=False,
    )
