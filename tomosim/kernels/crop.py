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
    out = np.full((size, size), -1, dtype=np.int8)
    rows, cols = own.shape
    layer_rows, layer_cols = layer.shape
    for i in range(size):
        for di in range(pool):
            b = start_b + i * pool + di
            r = b - own_b
            lr = b - layer_b
            for j in range(size):
                best = out[i, j]
                for dj in range(pool):
                    a = start_a + j * pool + dj
                    value = -1
                    c = a - own_a
                    if 0 <= r < rows and 0 <= c < cols:
                        value = own[r, c]
                    if value < 0:
                        lc = a - layer_a
                        if 0 <= lr < layer_rows and 0 <= lc < layer_cols:
                            value = layer[lr, lc]
                    if value > best:
                        best = value
                out[i, j] = best
    return out
