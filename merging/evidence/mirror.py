"""Evidence that looks the same in a mirror: when a placement cannot tell a place from its twin.

Why a mirror
------------
A placement of map 2 on map 1 is trusted because the walls of the part the
maps share (their *overlap*) line up: a building rarely holds two places
that look alike. Floor plans, however, are often mirror-symmetric (two wings
about a hall, a round crossing of four corridors, rooms mirrored about a
shared wall, a plain corridor about its axis). Suppose the shared part looks
the same in a mirror: map 2's part of the overlap, mirrored (its columns
reversed), can be laid on map 1's part and fits it about as well as itself.
Then that part is congruent to its own mirror image, so map 2 could just as
well show the mirror twin of the place in a mirror-symmetric building,
somewhere else entirely, and the walls that agree cannot tell the two
apart. If the shared part is *chiral* (it differs from its mirror image: a
door on one side, clutter, the way a corridor leaves a room), the mirrored
part fits clearly worse, and the twin is ruled out: a mirror-symmetric
building holds the mirror image of a place at its twin, and map 2 does not
look like that.

Two windows cut side by side around the round hall of ``aces3`` are the
case in point: each shows a corridor entering the hall, a shape symmetric
about the corridor's axis, and the hall is symmetric across it too. Map 2
turned by half a turn (a mirror about the axis followed by one across it)
fits map 1 wall for wall, while the truth overlaps a sliver of the hall with
almost no wall. The maps do not contain the truth's evidence, but they do
show that their agreement is achiral.

Only a twin of the *same* evidence counts: map 2 mirrored may fit some other
part of map 1, but that says map 1 holds a mirror copy of map 2 elsewhere,
not that the evidence for the placement is ambiguous. So the search for the
twin places only the part of map 2 that the placement lays on map 1, mirrored
(:func:`mirrored_part`), on map 1's cells around the overlap
(:func:`twin_ground`), the evidence is counted inside the overlap only
(:func:`region_net`), and the placement must explain a margin more than the
best mirrored one there (:func:`mirror_share`), as it must explain more than
the best different placement (:func:`merging.evidence.verify.confidence`).

What it cannot see
------------------
A building symmetric under a half turn but not under a mirror (a pinwheel
of corridors) shows its twin places as rigid copies; when each map holds
only one of them, no measure of the two maps tells the places apart, and the
merger, like the paper (section 2.2), assumes such repetitions away. The
search's runner-up catches those that one of the maps shows whole.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from merging.evidence.verify import DEFAULT_VERIFY, PreparedMap, dilate, prepare_map
from merging.grid import UNKNOWN, observed_part
from merging.params import VerifyParams
from merging.transforms import apply_transform

REGION_SAMPLES = 100_000
"""Cells of a map (about 300 x 300) up to which the overlap is decided cell by cell; on
larger maps blocks of cells are decided together (``_landing_mask``), so that the
overlap of two whole buildings takes milliseconds and is off by a few cells at its
edge at most, where both the placement's and its mirror image's evidence are
counted alike."""

WHOLE_GROUND_SHARE = 0.9
"""Share of map 1's observed cells within the margin of the overlap from which the twin
is searched for on the whole map 1 (:func:`twin_ground`): nearly the same ground, and the
first search's fields of map 1 are reused."""

Masks = tuple[NDArray[np.bool_], NDArray[np.bool_]]
"""Where a carried wall cell agrees (near a wall) and where it conflicts (clear free space)."""


@dataclass(frozen=True, slots=True)
class MirroredPart:
    """The part of map 2 that a placement lays on map 1, seen in a mirror.

    Attributes
    ----------
    mirrored : PreparedMap
        Map 2's cells that the placement carries within a margin of the
        overlap (unknown elsewhere), cropped to their observed part, with the
        columns reversed (:func:`mirrored_cells`).
    overlap : (rows, cols) bool ndarray
        The overlap in map 1's cells (:func:`overlap_region`): where evidence
        counts.
    unmirror : (3, 3) float ndarray
        Takes ``mirrored``'s cells back to map 2's (a reflection).
    around : (rows, cols) bool ndarray
        Map 1's cells within the margin of the overlap: where the twin is
        searched for (:func:`twin_ground`).
    """

    mirrored: PreparedMap
    overlap: NDArray[np.bool_]
    unmirror: NDArray[np.float64]
    around: NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class MirrorCandidates:
    """Placements on map 1 of the mirrored part of map 2 that a placement overlaps.

    Attributes
    ----------
    part : MirroredPart
        The overlap of the placement held against its mirror image.
    matrices : tuple of (3, 3) float ndarray
        Each takes ``part.mirrored``'s cells to map 1's, best first.
    """

    part: MirroredPart
    matrices: tuple[NDArray[np.float64], ...]


def mirrored_cells(cells: NDArray[np.int8]) -> NDArray[np.int8]:
    """``cells`` with its columns reversed: the map seen in a mirror (a new array)."""
    return np.ascontiguousarray(cells[:, ::-1])


def overlap_region(
    first: PreparedMap, second: PreparedMap, matrix: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Cells of map 1 known in both maps when ``matrix`` (map 2 -> map 1) lays map 2 on it.

    Decided for blocks of cells on maps of more than :data:`REGION_SAMPLES`
    cells (``_landing_mask``).
    """
    back = np.asarray(np.linalg.inv(matrix), dtype=np.float64)
    return _landing_mask(first.cells >= 0, back, second.cells >= 0)


def mirrored_part(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    margin: int,
    params: VerifyParams = DEFAULT_VERIFY,
) -> MirroredPart:
    """The part of map 2 that ``matrix`` (map 2 -> map 1) lays on map 1, seen in a mirror.

    Map 2 keeps the cells it lays within ``margin`` cells (chessboard) of
    the overlap, so that the agreeing and conflicting cells inside the
    overlap are those of the whole map for walls met within ``margin -
    conflict_clearance`` cells; the rest becomes unknown. Searching for this
    part on the same neighbourhood of map 1 (:func:`twin_ground`) looks for
    the mirror image of the evidence, not for the mirrored map anywhere.
    """
    overlap = overlap_region(first, second, matrix)
    around = dilate(overlap, margin)
    kept = _landing_mask(second.cells >= 0, matrix, around)
    cells, corner = observed_part(np.where(kept, second.cells, UNKNOWN).astype(np.int8))
    width = cells.shape[1]
    # Mirrored column x is the part's column width - 1 - x, map 2's column corner_x + that.
    unmirror = np.array(
        [[-1.0, 0.0, corner[0] + width - 1.0], [0.0, 1.0, corner[1]], [0.0, 0.0, 1.0]]
    )
    mirrored = prepare_map(mirrored_cells(cells), params=params)
    return MirroredPart(mirrored, overlap, unmirror, around & (first.cells >= 0))


def twin_ground(
    first: PreparedMap, part: MirroredPart, *, params: VerifyParams = DEFAULT_VERIFY
) -> tuple[PreparedMap, NDArray[np.float64]] | None:
    """Map 1's cells around the overlap, where the mirrored part's twin placement lies.

    Only placements that lay the mirrored part's walls inside the overlap
    count (:func:`mirror_share`), so the twin is searched for on map 1's
    cells within the margin of the overlap (the rest unknown), cropped: on
    the whole map 1 a search for a small part may rank placements elsewhere
    first and never reach the twin inside a small overlap. Returns the
    prepared part of map 1 and its corner ``(x, y)`` in map 1's cells, or
    None when it holds at least :data:`WHOLE_GROUND_SHARE` of map 1's
    observed cells: map 1 is then searched whole, with the fields the first
    search made of it.
    """
    known = np.count_nonzero(first.cells >= 0)
    if np.count_nonzero(part.around) >= WHOLE_GROUND_SHARE * known:
        return None
    cells, corner = observed_part(np.where(part.around, first.cells, UNKNOWN).astype(np.int8))
    return prepare_map(cells, params=params), corner


def region_net(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    region: NDArray[np.bool_],
    *,
    tolerance: int | None = None,
    conflict_weight: float | None = None,
    params: VerifyParams = DEFAULT_VERIFY,
) -> float:
    """Agreeing minus ``conflict_weight`` times conflicting wall cells, inside ``region`` only.

    As :func:`merging.evidence.verify.verify` counts them (both directions; a wall
    agrees within ``near_radius`` cells of a wall and conflicts on free space
    ``conflict_clearance`` cells beyond that), but only map 2's walls that
    land inside ``region`` and map 1's walls that lie inside it count. With
    ``tolerance``, walls agree within that many cells instead, as in
    :func:`merging.evidence.robust.tolerant_fit`.

    Parameters
    ----------
    first, second : PreparedMap
        Map 1 and map 2.
    matrix : (3, 3) float ndarray
        Map 2 cells -> map 1 cells.
    region : (rows, cols) bool ndarray
        Cells of map 1 where evidence counts.
    tolerance : int, optional
        Cells (chessboard) within which a wall agrees; ``params.near_radius``
        when not given.
    conflict_weight : float, optional
        What a conflicting cell costs; ``params.conflict_weight`` when not
        given, 0 to count agreeing cells only.
    params : VerifyParams
        The verification settings :func:`merging.evidence.verify.prepare_map` made
        the maps' masks with.

    Returns
    -------
    float
        Net wall cells (full resolution, both directions).
    """
    weight = params.conflict_weight if conflict_weight is None else conflict_weight
    masks1, masks2 = _masks(first, tolerance, params), _masks(second, tolerance, params)
    rows, cols = landing_cells(apply_transform(matrix, second.points), first.shape)
    keep = region[rows, cols]
    forward = _net(masks1, rows[keep], cols[keep], weight) * second.point_weight
    inside = region[first.points[:, 1].astype(np.intp), first.points[:, 0].astype(np.intp)]
    carried = apply_transform(np.linalg.inv(matrix), first.points[inside])
    rows, cols = landing_cells(carried, second.shape)
    backward = _net(masks2, rows, cols, weight) * first.point_weight
    return forward + backward


def mirror_share(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    mirror: MirrorCandidates,
    *,
    tolerance: int | None = None,
    conflict_weight: float | None = None,
    params: VerifyParams = DEFAULT_VERIFY,
) -> float:
    """How much of the evidence for ``matrix`` map 2's mirror image explains as well.

    The best wall evidence (:func:`region_net`) of any mirrored placement
    inside the overlap, over that of ``matrix`` (map 2 -> map 1, whose
    overlap ``mirror`` holds) itself: near 1 when the shared part looks the
    same in a mirror, small when it is chiral. The evidence is counted as
    the way that vouches for the placement counts it: the close fit within
    ``near_radius`` cells (or its tolerant fit's ``tolerance``), conflicts
    weighing against; the robust evidence within its ``tolerance``,
    agreeing walls only (``conflict_weight=0``: maps that bend lay many
    walls on open space even when right). Returns 0 when the placement has
    no such evidence or there is no mirrored placement.
    """
    overlap = mirror.part.overlap

    def evidence(other: PreparedMap, move: NDArray[np.float64]) -> float:
        return region_net(
            first,
            other,
            move,
            overlap,
            tolerance=tolerance,
            conflict_weight=conflict_weight,
            params=params,
        )

    base = evidence(second, matrix)
    if base <= 0 or not mirror.matrices:
        return 0.0
    twin = max(evidence(mirror.part.mirrored, m) for m in mirror.matrices)
    return max(twin, 0.0) / base


def _landing_mask(
    source: NDArray[np.bool_], matrix: NDArray[np.float64], target: NDArray[np.bool_]
) -> NDArray[np.bool_]:
    """Cells set in ``source`` whose centres, carried by ``matrix``, land on ``target``'s.

    On a grid of more than :data:`REGION_SAMPLES` cells, decided for every
    ``stride``-th row and column, each sample standing for the block of
    ``stride`` x ``stride`` cells it starts: the overlap of two whole
    buildings is then known to within a few cells at its edge, in a few
    milliseconds instead of a few tenths of a second.
    """
    stride = max(1, int(np.sqrt(source.size / REGION_SAMPLES)))
    matrix = np.ascontiguousarray(matrix, dtype=np.float64)
    return _lands_on(
        np.ascontiguousarray(source),
        matrix,
        np.ascontiguousarray(target),
        stride,
        _reach(matrix, source.shape, target, stride),
    )


def _reach(
    matrix: NDArray[np.float64],
    source_shape: tuple[int, ...],
    target: NDArray[np.bool_],
    stride: int,
) -> tuple[int, int, int, int]:
    """Rows and columns ``(row_lo, row_hi, col_lo, col_hi)`` of ``source`` outside which
    no cell centre, carried by ``matrix``, lands on a set cell of ``target``.

    The box around the target's set cells, carried back, is a parallelogram;
    its bounding box, grown by a cell and starting on a sample of the
    ``stride`` grid, is all that :func:`_lands_on` needs to visit. On a
    low-overlap pair it is a sliver of the map.
    """
    rows, cols = source_shape[0], source_shape[1]
    set_rows, set_cols = np.flatnonzero(target.any(axis=1)), np.flatnonzero(target.any(axis=0))
    if not len(set_rows):
        return 0, 0, 0, 0
    top, bottom = set_rows[0] - 0.5, set_rows[-1] + 0.5
    left, right = set_cols[0] - 0.5, set_cols[-1] + 0.5
    corners = np.array([[left, top], [right, top], [left, bottom], [right, bottom]])
    back = apply_transform(np.linalg.inv(matrix), corners)
    if not np.all(np.isfinite(back)):
        return 0, rows, 0, cols
    low, high = np.floor(back.min(axis=0)) - 1.0, np.ceil(back.max(axis=0)) + 1.0
    col_lo = int(np.clip(low[0], 0, cols)) // stride * stride
    row_lo = int(np.clip(low[1], 0, rows)) // stride * stride
    col_hi, row_hi = int(np.clip(high[0] + 1, 0, cols)), int(np.clip(high[1] + 1, 0, rows))
    return row_lo, row_hi, col_lo, col_hi


@numba.njit(cache=True, nogil=True)
def _lands_on(
    source: NDArray[np.bool_],
    matrix: NDArray[np.float64],
    target: NDArray[np.bool_],
    stride: int,
    reach: tuple[int, int, int, int],
) -> NDArray[np.bool_]:
    """:func:`_landing_mask` for every ``stride``-th row and column of ``source`` within
    ``reach`` (:func:`_reach`): a sample carried (to the nearest cell, halves to even)
    onto ``target`` sets the cells of ``source`` in its block."""
    rows, cols = source.shape
    row_lo, row_hi, col_lo, col_hi = reach
    out = np.zeros((rows, cols), dtype=np.bool_)
    a, b, c = matrix[0, 0], matrix[0, 1], matrix[0, 2]
    d, e, f = matrix[1, 0], matrix[1, 1], matrix[1, 2]
    for row in range(row_lo, row_hi, stride):
        for col in range(col_lo, col_hi, stride):
            if not source[row, col]:
                continue
            x = int(np.rint(a * col + b * row + c))
            y = int(np.rint(d * col + e * row + f))
            if y < 0 or y >= target.shape[0] or x < 0 or x >= target.shape[1]:
                continue
            if not target[y, x]:
                continue
            for r in range(row, min(row + stride, rows)):
                for k in range(col, min(col + stride, cols)):
                    out[r, k] = source[r, k]
    return out


def landing_cells(
    points: NDArray[np.float64], shape: tuple[int, int]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Rows and columns of the cells ``(x, y)`` points land on, those inside ``shape`` only."""
    cols = np.rint(points[:, 0]).astype(np.intp)
    rows = np.rint(points[:, 1]).astype(np.intp)
    inside = (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
    return rows[inside], cols[inside]


def _masks(prepared: PreparedMap, tolerance: int | None, params: VerifyParams) -> Masks:
    """The agreeing and conflicting cells of a map for walls met within ``tolerance`` cells."""
    if tolerance is None or tolerance == params.near_radius:
        return prepared.near_occupied, prepared.clear_free
    return prepared.tolerant_masks(tolerance, params.conflict_clearance)


def _net(masks: Masks, rows: NDArray[np.intp], cols: NDArray[np.intp], weight: float) -> float:
    """Of points landing on ``(rows, cols)``: near a wall minus ``weight`` times on clear free."""
    near, clear = masks
    agreeing = np.count_nonzero(near[rows, cols])
    conflicting = np.count_nonzero(clear[rows, cols]) if weight else 0
    return float(agreeing) - weight * float(conflicting)
