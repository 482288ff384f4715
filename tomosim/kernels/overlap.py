"""Free space two grids both know, compiled: the overlap a merge round is scored with.

:func:`shared_free` counts what :func:`tomosim.team.quality.shared_free_area`
states in array operations (its oracle), in one loop over grid ``j``'s cells
with no arrays of the size of the grid in between: a round scores every pair
of a team, and a floor's grids hold hundreds of thousands of free cells.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging.grid import FREE_THRESHOLD
from tomosim.kernels.jit import kernel


@kernel
def shared_free(
    first: NDArray[np.int8], second: NDArray[np.int8], matrix: NDArray[np.float64]
) -> int:
    """Free cells of ``second`` whose centres ``matrix`` (``second``'s cells ``(x, y)``
    to ``first``'s) carries onto free cells of ``first`` (nearest cell, rounding half
    to even; free: known and at most :data:`merging.grid.FREE_THRESHOLD`). ``matrix``
    must be a finite 3x3 array: numba does not check its bounds."""
    height, width = first.shape
    a, b, c = matrix[0, 0], matrix[0, 1], matrix[0, 2]
    d, e, f = matrix[1, 0], matrix[1, 1], matrix[1, 2]
    count = 0
    for row in range(second.shape[0]):
        for col in range(second.shape[1]):
            value = second[row, col]
            if value < 0 or value > FREE_THRESHOLD:
                continue
            x = np.rint(a * col + b * row + c)
            y = np.rint(d * col + e * row + f)
            # Written so that a NaN fails too (the caller checks the matrix).
            if not (0 <= x < width and 0 <= y < height):
                continue
            landed = first[int(y), int(x)]
            if 0 <= landed <= FREE_THRESHOLD:
                count += 1
    return count
