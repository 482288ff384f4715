"""Checking a candidate transform against both grids, shared by every method.

A transform is *verified* by carrying each map's occupied cells into the other
map and asking where they land:

* on or next to an occupied cell of the other map: *agreement*;
* on a free cell with no occupied cell nearby: *conflict* (a wall where the
  other robot saw open space; the failure that makes a merged map dangerous);
* on an unknown cell or off the map: no evidence either way.

The same numbers drive the ranking of hypotheses, the ``confidence`` of a
:class:`~merging.result.MergeResult` and its ``accepted`` flag.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from merging.grid import free_mask, occupied_mask
from merging.transforms import apply_transform

MAX_VERIFY_POINTS = 4000
"""Occupied cells per map used for verification; more add time, not evidence."""
NEAR_RADIUS = 1
"""Cells (chessboard) within which a carried cell counts as landing on a wall:
rasterising a rotated wall moves its cells by up to one cell."""
CONFLICT_CLEARANCE = 2
"""A free cell is evidence against a wall only this many cells (chessboard)
away from any occupied cell, so slightly offset walls are not punished."""
FIELD_SIGMA = 1.0
"""Standard deviation, in cells, of the smoothed occupancy used for refinement."""
CONFLICT_WEIGHT = 3.0
"""How much a conflicting cell costs relative to what an agreeing one earns."""
SUPPORT_SCALE = 80.0
"""Agreeing cells (at full resolution) at which support reaches 1 - 1/e; about
four metres of wall at 0.05 m, below which a match is too small to trust."""
SHARED_SPACE_SCALE = 1000.0
"""Clear free cells landing on clear free cells (both directions together) at
which the shared-space factor reaches 1 - 1/e: about a square metre seen by
both robots at 0.05 m. Maps laid side by side along one wall share none."""
FIT_CENTRE = 0.80
"""Quality at which the fit factor is one half: right merges of real and
simulated maps score 0.85-1; wrong ones that fit a repeated room, 0.7-0.86."""
FIT_WIDTH = 0.06
"""Width of the fit factor's logistic, in quality."""
STRENGTH_SCALE = 10.0
"""Constraint strength (matching cells per cell² of motion along the weakest
direction, see :func:`merging.refine.constraint_strength`) at which that
factor reaches 1 - 1/e: an overlap of one short wall scores about 3, a room
corner about 30."""
OVERLAP_PREFERENCE = 0.05
"""Fit (quality) a tenfold larger overlap is worth when ranking hypotheses."""
DISTINCT_MARGIN = 0.25
"""The best transform must explain this much more than the best different one
(as a fraction of its net agreeing cells) for the distinctiveness factor to
pass one half."""
ACCEPT_CONFIDENCE = 0.5
"""Confidence at or above which a result is accepted."""


@dataclass(frozen=True, slots=True)
class PreparedMap:
    """A grid with the lookups verification needs, computed once per map.

    Attributes
    ----------
    cells : (rows, cols) int8 ndarray
        The grid.
    walls : (N, 2) float ndarray
        ``(x, y)`` of every occupied cell.
    points : (N, 2) float ndarray
        ``(x, y)`` of at most :data:`MAX_VERIFY_POINTS` occupied cells, spread
        evenly over all of them.
    point_weight : float
        Occupied cells each point stands for.
    near_occupied : (rows, cols) bool ndarray
        Occupied cells grown by :data:`NEAR_RADIUS`.
    clear_free : (rows, cols) bool ndarray
        Free cells at least :data:`CONFLICT_CLEARANCE` + 1 cells from a wall.
    open_points : (M, 2) float ndarray
        ``(x, y)`` of at most :data:`MAX_VERIFY_POINTS` clear free cells.
    open_weight : float
        Clear free cells each of those stands for.
    """

    cells: NDArray[np.int8]
    walls: NDArray[np.float64]
    points: NDArray[np.float64]
    point_weight: float
    near_occupied: NDArray[np.bool_]
    clear_free: NDArray[np.bool_]
    open_points: NDArray[np.float64]
    open_weight: float

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the grid."""
        return (int(self.cells.shape[0]), int(self.cells.shape[1]))


def dilate(mask: NDArray[np.bool_], radius: int) -> NDArray[np.bool_]:
    """Grow ``mask`` by ``radius`` cells in the chessboard metric (a square element).

    Separable shifted ORs: far cheaper than a general binary dilation.
    """
    rows = mask.copy()
    for k in range(1, radius + 1):
        rows[:, k:] |= mask[:, :-k]
        rows[:, :-k] |= mask[:, k:]
    out = rows.copy()
    for k in range(1, radius + 1):
        out[k:, :] |= rows[:-k, :]
        out[:-k, :] |= rows[k:, :]
    return out


def prepare_map(cells: NDArray[np.int8], *, max_points: int = MAX_VERIFY_POINTS) -> PreparedMap:
    """Compute the verification lookups of a validated grid."""
    occupied = occupied_mask(cells)
    rows, cols = np.divmod(np.flatnonzero(occupied), cells.shape[1])
    all_points = np.column_stack([cols, rows]).astype(np.float64)
    stride = max(1, int(np.ceil(len(all_points) / max_points)))
    points = all_points[::stride]
    weight = len(all_points) / max(len(points), 1)
    near = dilate(occupied, NEAR_RADIUS)
    blocked = dilate(occupied, NEAR_RADIUS + CONFLICT_CLEARANCE)
    clear_free = free_mask(cells) & ~blocked
    open_points, open_weight = _spread(clear_free, max_points)
    return PreparedMap(
        cells, all_points, points, weight, near, clear_free, open_points, open_weight
    )


def _spread(mask: NDArray[np.bool_], count: int) -> tuple[NDArray[np.float64], float]:
    """At most ``count`` of ``mask``'s cells as ``(x, y)``, evenly spread, and cells per point."""
    flat = np.flatnonzero(mask)
    stride = max(1, int(np.ceil(len(flat) / count)))
    rows, cols = np.divmod(flat[::stride], mask.shape[1])
    points = np.column_stack([cols, rows]).astype(np.float64)
    return points, len(flat) / max(len(points), 1)


@dataclass(frozen=True, slots=True)
class Verification:
    """How well a transform explains both maps.

    Attributes
    ----------
    agreement : float
        Of the occupied cells that land on known cells of the other map, the
        fraction landing on or next to a wall there (both directions pooled).
    conflict : float
        The fraction landing on clear free space.
    overlap : float
        Occupied cells (full resolution, both directions) landing on known cells.
    agreeing : float
        Occupied cells landing on walls, ``agreement * overlap``.
    shared_space : float
        Clear free cells (full resolution, both directions) landing on clear
        free cells of the other map: open space both robots saw. Two maps
        laid side by side along one wall (two adjacent rooms, each seen from
        inside) share walls but no space.
    """

    agreement: float
    conflict: float
    overlap: float
    agreeing: float
    shared_space: float = 0.0

    @property
    def quality(self) -> float:
        """``agreement - CONFLICT_WEIGHT * conflict``: how well the overlap fits, at most 1."""
        return self.agreement - CONFLICT_WEIGHT * self.conflict

    @property
    def net(self) -> float:
        """Agreeing cells minus ``CONFLICT_WEIGHT`` times conflicting ones: the ranking score.

        A count, not a fraction: a transform that overlaps only one corner of
        a building can fit that corner perfectly, yet explains far less than
        the true one.
        """
        return self.quality * self.overlap

    @property
    def score(self) -> float:
        """The ranking score: :attr:`quality` plus a weak preference for larger overlaps.

        The fit fraction alone lets one exactly fitting corner of a building
        tie the whole building; the net count alone lets a large, loosely
        fitting overlap beat a smaller exact one. A tenfold larger overlap is
        worth :data:`OVERLAP_PREFERENCE` of fit.
        """
        return self.quality + OVERLAP_PREFERENCE * float(np.log10(max(self.overlap, 1.0)))


def _landing(points: NDArray[np.float64], target: PreparedMap) -> tuple[float, float, float]:
    """Counts of ``points`` (in ``target``'s cells) on known, near-wall and clear-free cells."""
    cols = np.rint(points[:, 0]).astype(np.intp)
    rows = np.rint(points[:, 1]).astype(np.intp)
    rows_n, cols_n = target.shape
    inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
    rows, cols = rows[inside], cols[inside]
    known = target.cells[rows, cols] >= 0
    near = target.near_occupied[rows, cols]
    clear = target.clear_free[rows, cols]
    return (
        float(np.count_nonzero(known | near)),
        float(np.count_nonzero(near)),
        float(np.count_nonzero(clear)),
    )


def _open_landing(points: NDArray[np.float64], target: PreparedMap) -> float:
    """How many of ``points`` (in ``target``'s cells) land on its clear free space."""
    cols = np.rint(points[:, 0]).astype(np.intp)
    rows = np.rint(points[:, 1]).astype(np.intp)
    rows_n, cols_n = target.shape
    inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
    return float(np.count_nonzero(target.clear_free[rows[inside], cols[inside]]))


def verify(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    stride: int = 1,
    space: bool = True,
) -> Verification:
    """Carry each map's occupied cells into the other with ``matrix`` and count landings.

    ``matrix`` takes ``second``'s cells to ``first``'s (eq. 1 of the paper).
    ``stride`` uses every ``stride``-th prepared point only, for a quick screen.
    ``space=False`` skips counting the shared open space (left 0), which only
    :func:`confidence` needs, to rank hypotheses faster.
    """
    inverse = np.linalg.inv(matrix)
    forward = apply_transform(matrix, second.points[::stride])
    backward = apply_transform(inverse, first.points[::stride])
    known_f, near_f, clear_f = _landing(forward, first)
    known_b, near_b, clear_b = _landing(backward, second)
    weight1, weight2 = first.point_weight * stride, second.point_weight * stride
    known = known_f * weight2 + known_b * weight1
    near = near_f * weight2 + near_b * weight1
    clear = clear_f * weight2 + clear_b * weight1
    shared = 0.0
    if space:
        shared = _open_landing(apply_transform(matrix, second.open_points[::stride]), first) * (
            second.open_weight * stride
        ) + _open_landing(apply_transform(inverse, first.open_points[::stride]), second) * (
            first.open_weight * stride
        )
    if known <= 0:
        return Verification(0.0, 0.0, 0.0, 0.0, shared)
    return Verification(near / known, clear / known, known, near, shared)


def confidence(
    best: Verification, runner_up: Verification | None = None, *, strength: float | None = None
) -> float:
    """Map a verification (and the best *distinct* alternative) to ``[0, 1]``.

    Up to five factors, each in ``[0, 1]``, multiplied. Their constants were
    set on 200 window pairs of four real maps and 144 pairs of robots' maps
    from six simulated episodes, so that no merge more than 2 cells (windows)
    or 1 m (episodes) off reaches confidence 0.2, while nine in ten right
    window merges are accepted; ``scripts/calibrate_confidence.py`` reruns
    that check on other seeds.

    * fit: a logistic of :attr:`Verification.quality` centred at
      :data:`FIT_CENTRE`;
    * support: ``1 - exp(-agreeing / SUPPORT_SCALE)``, so a few metres of
      matching wall cannot vouch for a transform;
    * distinctiveness: a logistic of ``1 - net(runner-up) / net(best)``, so
      that two equally good explanations (a symmetric building) give a low
      confidence instead of a coin toss;
    * constraint (when ``strength`` is given): ``1 - exp(-strength /
      STRENGTH_SCALE)``, so that an overlap that lets one map slide or turn
      along a wall is not vouched for;
    * shared space: ``1 - exp(-shared_space / SHARED_SPACE_SCALE)``, so that
      two maps of neighbouring rooms, which fit along their common wall,
      are not taken for one room.
    """
    fit = 1.0 / (1.0 + np.exp(-(best.quality - FIT_CENTRE) / FIT_WIDTH))
    support = 1.0 - np.exp(-best.agreeing / SUPPORT_SCALE)
    share = 0.0
    if runner_up is not None and best.net > 0:
        share = max(runner_up.net, 0.0) / best.net
    distinct = 1.0 / (1.0 + np.exp(-((1.0 - share) - DISTINCT_MARGIN) / 0.05))
    constrained = 1.0 if strength is None else 1.0 - np.exp(-max(strength, 0.0) / STRENGTH_SCALE)
    shared = 1.0 - np.exp(-best.shared_space / SHARED_SPACE_SCALE)
    return float(fit * support * distinct * constrained * shared)
