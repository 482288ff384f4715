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
from scipy import ndimage

from merging.grid import free_mask, occupied_cells, occupied_mask
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
ACCEPT_CONFIDENCE = 0.5
"""Confidence at or above which a result is accepted."""


@dataclass(frozen=True, slots=True)
class PreparedMap:
    """A grid with the lookups verification needs, computed once per map.

    Attributes
    ----------
    cells : (rows, cols) int8 ndarray
        The grid.
    points : (N, 2) float ndarray
        ``(x, y)`` of at most :data:`MAX_VERIFY_POINTS` occupied cells, spread
        evenly over all of them.
    point_weight : float
        Occupied cells each point stands for.
    near_occupied : (rows, cols) bool ndarray
        Occupied cells grown by :data:`NEAR_RADIUS`.
    clear_free : (rows, cols) bool ndarray
        Free cells at least :data:`CONFLICT_CLEARANCE` + 1 cells from a wall.
    """

    cells: NDArray[np.int8]
    points: NDArray[np.float64]
    point_weight: float
    near_occupied: NDArray[np.bool_]
    clear_free: NDArray[np.bool_]

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the grid."""
        return (int(self.cells.shape[0]), int(self.cells.shape[1]))


def prepare_map(cells: NDArray[np.int8], *, max_points: int = MAX_VERIFY_POINTS) -> PreparedMap:
    """Compute the verification lookups of a validated grid."""
    occupied = occupied_mask(cells)
    all_points = occupied_cells(cells)
    stride = max(1, int(np.ceil(len(all_points) / max_points)))
    points = all_points[::stride]
    weight = len(all_points) / max(len(points), 1)
    square = np.ones((3, 3), dtype=bool)
    near = ndimage.binary_dilation(occupied, structure=square, iterations=NEAR_RADIUS)
    blocked = ndimage.binary_dilation(near, structure=square, iterations=CONFLICT_CLEARANCE)
    clear_free = free_mask(cells) & ~blocked
    return PreparedMap(cells, points, weight, near, clear_free)


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
    """

    agreement: float
    conflict: float
    overlap: float
    agreeing: float

    @property
    def quality(self) -> float:
        """``agreement - CONFLICT_WEIGHT * conflict``: the ranking score, at most 1."""
        return self.agreement - CONFLICT_WEIGHT * self.conflict


def _landing(points: NDArray[np.float64], target: PreparedMap) -> tuple[float, float, float]:
    """Counts of ``points`` (already in ``target``'s cells) on known, near-wall and clear-free cells."""
    cols = np.rint(points[:, 0]).astype(np.intp)
    rows = np.rint(points[:, 1]).astype(np.intp)
    rows_n, cols_n = target.shape
    inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
    rows, cols = rows[inside], cols[inside]
    known = target.cells[rows, cols] >= 0
    near = target.near_occupied[rows, cols]
    clear = target.clear_free[rows, cols]
    return float(np.count_nonzero(known | near)), float(np.count_nonzero(near)), float(
        np.count_nonzero(clear)
    )


def verify(first: PreparedMap, second: PreparedMap, matrix: NDArray[np.float64]) -> Verification:
    """Carry each map's occupied cells into the other with ``matrix`` and count landings.

    ``matrix`` takes ``second``'s cells to ``first``'s (eq. 1 of the paper).
    """
    forward = apply_transform(matrix, second.points)
    backward = apply_transform(np.linalg.inv(matrix), first.points)
    known_f, near_f, clear_f = _landing(forward, first)
    known_b, near_b, clear_b = _landing(backward, second)
    known = known_f * second.point_weight + known_b * first.point_weight
    near = near_f * second.point_weight + near_b * first.point_weight
    clear = clear_f * second.point_weight + clear_b * first.point_weight
    if known <= 0:
        return Verification(0.0, 0.0, 0.0, 0.0)
    return Verification(near / known, clear / known, known, near)


def confidence(best: Verification, runner_up: Verification | None = None) -> float:
    """Map a verification (and the best *distinct* alternative) to ``[0, 1]``.

    Three factors, each in ``[0, 1]``, multiplied:

    * fit: a logistic of :attr:`Verification.quality` centred at 0.55;
    * support: ``1 - exp(-agreeing / SUPPORT_SCALE)``, so a handful of
      matching cells cannot vouch for a transform;
    * distinctiveness: a logistic of the quality margin over the runner-up,
      so that two equally good explanations (a symmetric building) give a low
      confidence instead of a coin toss.
    """
    fit = 1.0 / (1.0 + np.exp(-(best.quality - 0.55) / 0.06))
    support = 1.0 - np.exp(-best.agreeing / SUPPORT_SCALE)
    margin = best.quality - (runner_up.quality if runner_up is not None else 0.0)
    distinct = 1.0 / (1.0 + np.exp(-(margin - 0.08) / 0.03))
    return float(fit * support * distinct)
