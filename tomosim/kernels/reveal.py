"""Truth cells revealed by newly observed map cells, compiled.

Each robot's counted truth cells are indexed by the lattice cell of its map
frame their centres fall in (:mod:`tomosim.team.coverage`), as a sorted key
array; a map cell observed for the first time reveals the truth cells under
its key, looked up in a table of where each key starts
(:func:`first_of_keys`); one call does a team's step (:func:`reveal_team`).
The oracle is the evaluation rule of :func:`tomosim.evaluation.known_in_world`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel


def first_of_keys(keys: NDArray[np.int64]) -> NDArray[np.int32]:
    """Per key ``0 <= key <= keys[-1]``, the index in the sorted, non-negative ``keys`` of
    its first occurrence, -1 for a key that does not occur (empty for no keys)."""
    if len(keys) == 0:
        return np.zeros(0, dtype=np.int32)
    table = np.full(int(keys[-1]) + 1, -1, dtype=np.int32)
    firsts = np.flatnonzero(np.concatenate([[True], keys[1:] != keys[:-1]]))
    table[keys[firsts]] = firsts
    return table


@kernel
def truth_under_table(
    cells: NDArray[np.int64],
    origin_a: int,
    origin_b: int,
    width: int,
    keys: NDArray[np.int64],
    table: NDArray[np.int32],
    starts: NDArray[np.int64],
) -> int:
    """Find where the truth cells under each of ``cells`` start in ``keys``; count them.

    ``starts[k]`` becomes the index in ``keys`` of the first truth cell under
    ``cells[k]``, or -1 where there is none; the start of a key is looked up in
    ``table`` (:func:`first_of_keys` of ``keys``). Arguments as in :func:`reveal_team`,
    for one robot.
    """
    total = 0
    for k in range(cells.shape[0]):
        starts[k] = -1
        a = cells[k, 0] - origin_a
        if a < 0 or a >= width:
            continue
        key = (cells[k, 1] - origin_b) * width + a
        if key < 0 or key >= table.shape[0]:
            continue
        i = np.int64(table[key])
        if i < 0:
            continue
        starts[k] = i
        while i < keys.shape[0] and keys[i] == key:
            total += 1
            i += 1
    return total


@kernel
def collect_truth(
    starts: NDArray[np.int64],
    keys: NDArray[np.int64],
    members: NDArray[np.int64],
    known: NDArray[np.bool_],
    found: NDArray[np.int64],
) -> int:
    """Mark the truth cells :func:`truth_under_table` found and write those not known before
    into ``found`` (long enough for all); returns how many it wrote."""
    count = 0
    for k in range(starts.shape[0]):
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
    return count


@kernel
def reveal_team(
    cells: NDArray[np.int64],
    starts: NDArray[np.int64],
    origins: NDArray[np.int64],
    widths: NDArray[np.int64],
    keys: NDArray[np.int64],
    members: NDArray[np.int64],
    tables: NDArray[np.int32],
    table_starts: NDArray[np.int64],
    known: NDArray[np.bool_],
    counts: NDArray[np.int64],
    team_known: NDArray[np.bool_],
    finders: NDArray[np.int32],
    found_starts: NDArray[np.int64],
    credit: NDArray[np.float64],
    cell_area: float,
) -> tuple[NDArray[np.int64], int, bool]:
    """Mark the truth cells under every robot's newly observed lattice cells, then what
    the team learnt.

    Parameters
    ----------
    cells : (K, 2) int64 ndarray
        Every robot's newly observed lattice cells, robot after robot.
    starts : (N + 1,) int64 ndarray
        Robot ``k``'s cells are ``cells[starts[k]:starts[k + 1]]``.
    origins : (N, 2) int64 ndarray
    widths : (N,) int64 ndarray
        Per robot, the key of lattice cell ``(a, b)`` is ``(b - origin_b) * width +
        (a - origin_a)`` (cells outside ``0 <= a - origin_a < width`` hold no truth
        cell).
    keys, members : (N, T) int64 ndarray
        Per robot, the sorted keys of its truth cells, and the truth cell (index into
        ``known``) of each key.
    tables : int32 ndarray
    table_starts : (N + 1,) int64 ndarray
        Robot ``k``'s :func:`first_of_keys` of ``keys[k]`` is
        ``tables[table_starts[k]:table_starts[k + 1]]``.
    known : (N, T) bool ndarray
        Per robot, which truth cells it knows; updated in place.
    counts : (N,) int64 ndarray
        Per robot, the number of truth cells it knows; updated in place.
    team_known : (T,) bool ndarray
        Which truth cells the team knows; updated in place.
    finders : (T,) int32 ndarray
        Zeros, used as scratch (zeros again on return).
    found_starts : (N + 1,) int64 ndarray
        Filled: robot ``k``'s cells of ``found`` are ``found[found_starts[k]:found_starts[k + 1]]``.
    credit : (N,) float64 ndarray
        Filled, unless ``shared``: per robot, the number of its ``found`` cells times
        ``cell_area`` (each cell had one finder).
    cell_area : float
        Square metres of a truth cell.

    Returns
    -------
    found : (M,) int64 ndarray
        Per robot, robot after robot, the truth cells it knows for the first time
        and the team knew not before this call.
    newly_team : int
        Truth cells the team knows for the first time (``M`` less repeats).
    shared : bool
        Whether some truth cell was found by more than one robot.
    """
    robots = starts.shape[0] - 1
    # 1. Per robot, where the truth cells under its cells lie, and how many there are.
    under = np.empty(cells.shape[0], dtype=np.int64)
    total = 0
    for k in range(robots):
        total += truth_under_table(
            cells[starts[k] : starts[k + 1]],
            origins[k, 0],
            origins[k, 1],
            widths[k],
            keys[k],
            tables[table_starts[k] : table_starts[k + 1]],
            under[starts[k] : starts[k + 1]],
        )
    # 2. Per robot, those it knows for the first time and the team did not know.
    found = np.empty(total, dtype=np.int64)
    found_starts[0] = 0
    count = 0
    for k in range(robots):
        revealed = collect_truth(
            under[starts[k] : starts[k + 1]], keys[k], members[k], known[k], found[count:]
        )
        counts[k] += revealed
        kept = count
        for m in range(count, count + revealed):
            truth = found[m]
            if not team_known[truth]:
                found[kept] = truth
                kept += 1
                finders[truth] += 1
        count = kept
        found_starts[k + 1] = count
    # 3. What the team learnt; the scratch back to zeros.
    shared = False
    newly_team = 0
    for m in range(count):
        truth = found[m]
        shared = shared or finders[truth] > 1
        finders[truth] = 0
        if not team_known[truth]:
            team_known[truth] = True
            newly_team += 1
    if not shared:
        for k in range(robots):
            credit[k] = np.float64(found_starts[k + 1] - found_starts[k]) * cell_area
    return found[:count], newly_team, shared
