"""Joins of two linked groups of maps that the maps across them contradict.

A pair placed on its own evidence joins two maps. Once either map is linked
to others, the pair also places every map of one group on every map of the
other, through the links already made: maps the pair's own verification
never saw together. A wrong match of two maps that share little (a room
matched to its twin half a turn away, in a building that repeats) can fit
those two maps as well as a right one, and confirm itself round after round
on the same repeated walls, yet lay a teammate's walls across the other
group's open space. The triangles of :func:`merging.linking.forest.consistent_pairs`
catch it only once some pair across is accepted too, which for maps that
barely overlap may take many rounds.

:func:`contradicted_joins` walks the pairs as the spanning forest takes
them, most confident first, and before a pair joins two groups (one of them
of more than one map) it verifies every pair of maps across the join, placed
through it (:func:`merging.evidence.verify.verify`, both ways). When the walls
of two such maps meet the other map's known cells enough to judge
(``LinkingParams.across_overlap_cells``) and too many of them land on its
clear open space (``LinkingParams.across_conflict``), the pair is dropped:
what it says of the maps across is false. Maps that bend against each other
(separate sessions of a floor, :func:`merging.linking.forest.bends`) are not
judged this way, since right links of theirs lay walls a few cells off.

What it cannot see
------------------
A join of two maps linked to nothing else has nothing across it: the pair
is taken on its own evidence. Blame goes by confidence: a wrong pair more
confident than the right ones it contradicts joins first, and the right
ones are then dropped as the maps across them disagree (the triangles of
the next rounds may still drop the wrong one). And a wrong pair that slides
a map along a corridor whose doors repeat lays the maps across wall on wall
too.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from merging.evidence.verify import PreparedMap, Verification, prepare_map, verify
from merging.grid import observed_part
from merging.params import LinkingParams
from merging.result import MergeResult
from merging.transforms import translation_matrix

Pair = tuple[int, int]


def contradicted_joins(
    pairs: Mapping[Pair, MergeResult],
    cells: Sequence[NDArray[np.int8]],
    bends: Callable[[MergeResult], bool],
    *,
    params: LinkingParams,
) -> tuple[dict[Pair, MergeResult], list[str], dict[Pair, float]]:
    """Drop the pairs whose join of two groups the maps across contradict (module docstring).

    Parameters
    ----------
    pairs : mapping
        ``(i, j) -> MergeResult`` of the usable pairs, ``i < j``; the matrix takes
        grid ``j``'s cells to grid ``i``'s.
    cells : sequence of (rows, cols) int8 ndarray
        The grids, validated.
    bends : callable
        Whether a pair was vouched for as maps that bend against each other.
    params : LinkingParams
        ``across_conflict`` and ``across_overlap_cells``.

    Returns
    -------
    (dict, list of str, dict)
        The pairs kept, a line per pair dropped, and per pair judged the share
        it was judged by (the largest over the pairs of maps across its join
        that met enough; pairs with none are left out).
    """
    kept = dict(pairs)
    notes: list[str] = []
    shares: dict[Pair, float] = {}
    groups = _Groups(len(cells))
    prepared = _PreparedMaps(cells)
    for key in _by_confidence(pairs):
        i, j = key
        if groups.root[i] == groups.root[j]:
            continue  # a cycle: the forest does not use it, the triangles judge it
        result = pairs[key]
        join = groups.join_of(key, result)
        judged = not (bends(result) or groups.bent[groups.root[i]] or groups.bent[groups.root[j]])
        found = _worst_across(groups, prepared, key, join, params) if judged else None
        if found is not None:
            one, other, check = found
            shares[key] = float(check.conflict)
            if check.conflict > params.across_conflict:
                del kept[key]
                notes.append(
                    f"pair {i}-{j} (accepted, confidence {result.confidence:.2f}) dropped: placed "
                    f"through it and the links already made, maps {one} and {other} lay "
                    f"{check.conflict:.0%} of their walls that meet the other's known cells on "
                    f"its open space (limit {params.across_conflict:.0%})"
                )
                continue
        groups.join(i, j, join, bent=not judged)
    return kept, notes, shares


def _by_confidence(pairs: Mapping[Pair, MergeResult]) -> list[Pair]:
    """The pairs as the spanning forest takes them: most confident first, then lower pair."""
    return sorted(pairs, key=lambda key: (-pairs[key].confidence, key))


class _Groups:
    """The groups the pairs taken so far link: per grid, its root and its cells -> root cells."""

    def __init__(self, count: int) -> None:
        self.root = list(range(count))
        self.place = [np.eye(3) for _ in range(count)]
        self.members = {k: [k] for k in range(count)}
        self.bent = [False] * count

    def join_of(self, key: Pair, result: MergeResult) -> NDArray[np.float64]:
        """The matrix taking the cells of the root of grid ``j``'s group to those of the
        root of grid ``i``'s, as the pair ``key = (i, j)`` places grid ``j`` on grid ``i``."""
        i, j = key
        return self.place[i] @ result.matrix @ np.linalg.inv(self.place[j])

    def join(self, i: int, j: int, join: NDArray[np.float64], *, bent: bool) -> None:
        """Add grid ``j``'s group to grid ``i``'s, ``join`` taking the cells of the root of
        ``j``'s group to those of the root of ``i``'s; ``bent``: the joining pair bends."""
        into, out = self.root[i], self.root[j]
        for member in self.members.pop(out):
            self.root[member] = into
            self.place[member] = join @ self.place[member]
            self.members[into].append(member)
        self.bent[into] = self.bent[into] or self.bent[out] or bent


class _PreparedMaps:
    """Each grid's observed part prepared for verification, made on first use."""

    def __init__(self, cells: Sequence[NDArray[np.int8]]) -> None:
        self._cells = cells
        self._made: dict[int, tuple[PreparedMap, NDArray[np.float64]]] = {}

    def __getitem__(self, index: int) -> tuple[PreparedMap, NDArray[np.float64]]:
        """The prepared map and the matrix taking its cells to the grid's."""
        if index not in self._made:
            part, offset = observed_part(self._cells[index])
            self._made[index] = (prepare_map(part), translation_matrix(offset))
        return self._made[index]


def _worst_across(
    groups: _Groups,
    prepared: _PreparedMaps,
    key: Pair,
    join: NDArray[np.float64],
    params: LinkingParams,
) -> tuple[int, int, Verification] | None:
    """The pair of maps across the join of ``key`` laying most walls on open space, or None.

    Grids of grid ``i``'s group against those of grid ``j``'s, the pair itself
    left out; a pair counts when its walls meet the other map's known cells
    at least ``across_overlap_cells`` times (both ways). None when none does.
    """
    i, j = key
    worst: tuple[int, int, Verification] | None = None
    for near in groups.members[groups.root[i]]:
        for far in groups.members[groups.root[j]]:
            if (near, far) == (i, j):
                continue
            (first, into_near), (second, into_far) = prepared[near], prepared[far]
            # Grid far's cells -> grid near's through the join; then between observed parts.
            matrix = np.linalg.inv(groups.place[near]) @ join @ groups.place[far]
            check = verify(first, second, np.linalg.inv(into_near) @ matrix @ into_far)
            if check.overlap < params.across_overlap_cells:
                continue
            if worst is None or check.conflict > worst[2].conflict:
                worst = (min(near, far), max(near, far), check)
    return worst
