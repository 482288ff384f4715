"""Truth cells revealed by newly observed map cells, compiled.

Each robot's counted truth cells are indexed by the lattice cell of its map
frame their centres fall in (:mod:`tomosim.team.coverage`), as a sorted key
array; a map cell observed for the first time reveals the truth cells under
its key, found by binary search. The oracle is the evaluation rule of
:func:`tomosim.evaluation.known_in_world`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel


@kernel
def reveal_cells(
    cells: NDArray[np.int64],
    origin_a: int,
    origin_b: int,
    width: int,
    keys: NDArray[np.int64],
    members: NDArray[np.int64],
    known: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """Mark and return the truth cells under newly observed lattice cells.

    Parameters
    ----------
    cells : (K, 2) int64 ndarray
        Lattice cells ``(a, b)`` of the robot's map observed for the first time.
    origin_a, origin_b, width : int
        The key of lattice cell ``(a, b)`` is ``(b - origin_b) * width + (a - origin_a)``
        (cells outside ``0 <= a - origin_a < width`` hold no truth cell).
    keys : (T,) int64 ndarray
        Sorted keys of the truth cells.
    members : (T,) int64 ndarray
        The truth cell (index into ``known``) of each key.
    known : (N,) bool ndarray
        Which truth cells the robot knows; updated in place.

    Returns
    -------
    (R,) int64 ndarray
        Indices of the truth cells known for the first time.
    """
    # Two passes: count the truth cells under the cells, then collect the unknown ones.
    starts = np.empty(cells.shape[0], dtype=np.int64)
    total = 0
    for k in range(cells.shape[0]):
        starts[k] = -1
        a = cells[k, 0] - origin_a
        if a < 0 or a >= width:
            continue
        key = (cells[k, 1] - origin_b) * width + a
        i = np.searchsorted(keys, key)
        if i < keys.shape[0] and keys[i] == key:
            starts[k] = i
            while i < keys.shape[0] and keys[i] == key:
                total += 1
                i += 1
    found = np.empty(total, dtype=np.int64)
    count = 0
    for k in range(cells.shape[0]):
        i = starts[k]
        if i < 0:
            continue
        key = keys[i]
        while i < keys.shape[0] and keys[i] == key:
            truth = members[i]
            if not known[truth]:
                known[truth] = True
                found[count] = truth
                count += 1
            i += 1
    return found[:count]
