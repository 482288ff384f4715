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

from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.special import expit

from merging.evidence.solve3 import inverse3
from merging.grid import free_mask, occupied_mask
from merging.params import ConfidenceParams, VerifyParams

DEFAULT_VERIFY = VerifyParams()
"""The default verification settings."""
DEFAULT_CONFIDENCE = ConfidenceParams()
"""The default confidence factors and acceptance threshold."""
ACCEPT_CONFIDENCE = DEFAULT_CONFIDENCE.accept
"""Confidence at or above which a result is accepted, by default."""


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
        ``(x, y)`` of at most ``VerifyParams.max_points`` occupied cells,
        spread evenly over all of them.
    point_weight : float
        Occupied cells each point stands for.
    near_occupied : (rows, cols) bool ndarray
        Occupied cells grown by ``VerifyParams.near_radius``.
    clear_free : (rows, cols) bool ndarray
        Free cells more than ``near_radius + conflict_clearance`` cells
        (chessboard) from a wall.
    open_points : (M, 2) float ndarray
        ``(x, y)`` of at most ``VerifyParams.max_open_points`` clear free cells.
    open_weight : float
        Clear free cells each of those stands for.
    landing : (rows, cols) uint8 ndarray
        What a point landing on each cell counts as, one bit each (see
        :func:`landing_codes`): one lookup per point instead of three.
    """

    cells: NDArray[np.int8]
    walls: NDArray[np.float64]
    points: NDArray[np.float64]
    point_weight: float
    near_occupied: NDArray[np.bool_]
    clear_free: NDArray[np.bool_]
    open_points: NDArray[np.float64]
    open_weight: float
    landing: NDArray[np.uint8]
    _tolerant: dict[tuple[int, int], tuple[NDArray[np.bool_], NDArray[np.bool_]]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def tolerant_masks(
        self, tolerance: int, clearance: int
    ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """Where a wall met within ``tolerance`` cells agrees, and where one conflicts.

        Occupied cells grown by ``tolerance`` (chessboard), and free cells more
        than ``tolerance + clearance`` cells from any wall; kept for the next
        caller with the same widths (the verdict asks several times per map).
        """
        key = (tolerance, clearance)
        if key not in self._tolerant:
            grown = dilate(occupied_mask(self.cells), tolerance)
            # Square elements compose: growing by t and then by c grows by t + c.
            far_free = free_mask(self.cells) & ~dilate(grown, clearance)
            for mask in (grown, far_free):
                mask.setflags(write=False)  # shared by every later caller
            self._tolerant[key] = (grown, far_free)
        return self._tolerant[key]

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the grid."""
        return (int(self.cells.shape[0]), int(self.cells.shape[1]))


def dilate(mask: NDArray[np.bool_], radius: int) -> NDArray[np.bool_]:
    """Grow ``mask`` by ``radius`` cells in the chessboard metric (a square element).

    The same as ``scipy.ndimage.binary_dilation(mask, np.ones((2 * radius + 1,) * 2))``
    (pinned by a test), done as separable shifted ORs: on a whole building
    (1803 x 1647 cells) 6 to 60 times faster than ``binary_dilation`` or
    ``maximum_filter`` (``python scripts/bench_kernels.py``). Each axis grows
    by doubling (``_dilation_steps``): a reach of ``a`` cells ORed with
    itself shifted by ``s <= a + 1`` both ways reaches ``a + s`` without gaps,
    and the cells an edge cuts off would only have added cells already set,
    so a radius of 6 takes 3 shifts a side, not 6.
    """
    out = mask.copy()
    steps = _dilation_steps(radius)
    # In-place ORs of overlapping views read the operand as it was before the
    # operation (numpy copies it when the memory overlaps).
    for step in steps:
        out[:, step:] |= out[:, :-step]
        out[:, :-step] |= out[:, step:]
    for step in steps:
        out[step:, :] |= out[:-step, :]
        out[:-step, :] |= out[step:, :]
    return out


def _dilation_steps(radius: int) -> list[int]:
    """Shifts that grow a reach of 0 cells to ``radius``, each at most doubling it."""
    steps: list[int] = []
    reach = 0
    while reach < radius:
        step = min(reach + 1, radius - reach)
        steps.append(step)
        reach += step
    return steps


def prepare_map(cells: NDArray[np.int8], *, params: VerifyParams = DEFAULT_VERIFY) -> PreparedMap:
    """Compute the verification lookups of a validated grid."""
    occupied = occupied_mask(cells)
    rows, cols = np.divmod(np.flatnonzero(occupied), cells.shape[1])
    all_points = np.column_stack([cols, rows]).astype(np.float64)
    stride = max(1, int(np.ceil(len(all_points) / params.max_points)))
    points = all_points[::stride]
    weight = len(all_points) / max(len(points), 1)
    near = dilate(occupied, params.near_radius)
    blocked = dilate(near, params.conflict_clearance)  # grown by near_radius + clearance
    clear_free = free_mask(cells) & ~blocked
    open_points, open_weight = _spread(clear_free, params.max_open_points)
    landing = landing_codes(cells, near, clear_free)
    return PreparedMap(
        cells, all_points, points, weight, near, clear_free, open_points, open_weight, landing
    )


KNOWN_BIT, NEAR_BIT, CLEAR_BIT = 1, 2, 4
"""Bits of :attr:`PreparedMap.landing`: a landing there counts as on a known cell (or
next to a wall), next to a wall, and on clear free space."""


@numba.njit(cache=True, nogil=True)
def landing_codes(
    cells: NDArray[np.int8], near_occupied: NDArray[np.bool_], clear_free: NDArray[np.bool_]
) -> NDArray[np.uint8]:
    """Each cell's :data:`KNOWN_BIT` (known or near a wall), :data:`NEAR_BIT` and
    :data:`CLEAR_BIT`, as ``_count_landings`` counts a point landing there."""
    rows, cols = cells.shape
    codes = np.empty((rows, cols), dtype=np.uint8)
    for row in range(rows):
        for col in range(cols):
            codes[row, col] = (
                (KNOWN_BIT | NEAR_BIT) * near_occupied[row, col]
                | KNOWN_BIT * (cells[row, col] >= 0)
                | CLEAR_BIT * clear_free[row, col]
            )
    return codes


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
    conflict_weight : float
        What a conflicting cell costs against an agreeing one
        (``VerifyParams.conflict_weight`` of the verification).
    overlap_preference : float
        Fit a tenfold larger overlap is worth in :attr:`score`
        (``VerifyParams.overlap_preference``).
    space_preference : float
        Fit a tenfold larger shared open space is worth in :attr:`score`
        (``VerifyParams.space_preference``).
    """

    agreement: float
    conflict: float
    overlap: float
    agreeing: float
    shared_space: float = 0.0
    conflict_weight: float = DEFAULT_VERIFY.conflict_weight
    overlap_preference: float = DEFAULT_VERIFY.overlap_preference
    space_preference: float = DEFAULT_VERIFY.space_preference

    @property
    def quality(self) -> float:
        """``agreement - conflict_weight * conflict``: how well the overlap fits, at most 1."""
        return self.agreement - self.conflict_weight * self.conflict

    @property
    def net(self) -> float:
        """Agreeing cells minus ``conflict_weight`` times conflicting ones.

        A count, not a fraction: a transform that overlaps only one corner of
        a building can fit that corner perfectly, yet explains far less than
        the true one.
        """
        return self.quality * self.overlap

    @property
    def score(self) -> float:
        """The ranking score: :attr:`quality`, plus preferences for larger overlaps.

        The fit fraction alone lets one exactly fitting corner of a building
        tie the whole building; the net count alone lets a large, loosely
        fitting overlap beat a smaller exact one. A tenfold larger wall
        overlap is worth :attr:`overlap_preference` of fit, a tenfold larger
        shared open space :attr:`space_preference` (see
        :class:`~merging.params.VerifyParams`; 0 when the space was not
        counted).
        """
        walls = self.overlap_preference * float(np.log10(max(self.overlap, 1.0)))
        space = self.space_preference * float(np.log10(self.shared_space + 1.0))
        return self.quality + walls + space


@numba.njit(cache=True, nogil=True)
def _count_landings(
    matrix: NDArray[np.float64],
    points: NDArray[np.float64],
    stride: int,
    landing: NDArray[np.uint8],
) -> tuple[float, float, float]:
    """Carry every ``stride``-th of ``points`` by ``matrix`` into a map's cells (nearest,
    rounding half to even); counts of those landing on known or near-wall cells, on
    near-wall cells and on clear free cells (the bits of ``landing``, a map's
    :attr:`PreparedMap.landing`). Cells off the map count in none."""
    rows, cols = landing.shape
    a, b, c = matrix[0, 0], matrix[0, 1], matrix[0, 2]
    d, e, f = matrix[1, 0], matrix[1, 1], matrix[1, 2]
    known = near = clear = 0
    for i in range(0, points.shape[0], stride):
        px, py = points[i, 0], points[i, 1]
        col = int(np.rint(px * a + py * b + c))
        row = int(np.rint(px * d + py * e + f))
        if row < 0 or row >= rows or col < 0 or col >= cols:
            continue
        code = landing[row, col]
        known += code & KNOWN_BIT
        near += (code & NEAR_BIT) >> 1
        clear += (code & CLEAR_BIT) >> 2
    return float(known), float(near), float(clear)


def _landing(
    matrix: NDArray[np.float64], points: NDArray[np.float64], stride: int, target: PreparedMap
) -> tuple[float, float, float]:
    """Counts of ``points`` moved by ``matrix`` on ``target``'s known, near-wall and
    clear-free cells (:func:`_count_landings`)."""
    return _count_landings(
        np.ascontiguousarray(matrix, dtype=np.float64), points, stride, target.landing
    )


@numba.njit(cache=True, nogil=True)
def _both_ways(
    matrix: NDArray[np.float64],
    stride: int,
    space: bool,
    first_points: NDArray[np.float64],
    first_open: NDArray[np.float64],
    first_landing: NDArray[np.uint8],
    second_points: NDArray[np.float64],
    second_open: NDArray[np.float64],
    second_landing: NDArray[np.uint8],
) -> tuple[float, float, float, float, float, float, float, float]:
    """The landings :func:`verify` counts, in one call: map 2's walls on map 1 (known,
    near, clear), map 1's on map 2, then map 2's and map 1's open points on the other's
    clear free space (0 unless ``space``)."""
    inverse = inverse3(matrix)
    known_f, near_f, clear_f = _count_landings(matrix, second_points, stride, first_landing)
    known_b, near_b, clear_b = _count_landings(inverse, first_points, stride, second_landing)
    open_f = open_b = 0.0
    if space:
        _, _, open_f = _count_landings(matrix, second_open, stride, first_landing)
        _, _, open_b = _count_landings(inverse, first_open, stride, second_landing)
    return known_f, near_f, clear_f, known_b, near_b, clear_b, open_f, open_b


def verify(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    stride: int = 1,
    space: bool = True,
    params: VerifyParams = DEFAULT_VERIFY,
) -> Verification:
    """Carry each map's occupied cells into the other with ``matrix`` and count landings.

    ``matrix`` takes ``second``'s cells to ``first``'s (eq. 1 of the paper).
    ``stride`` uses every ``stride``-th prepared point only, for a quick screen.
    ``space=False`` skips counting the shared open space (left 0), which only
    :func:`confidence` needs, to rank hypotheses faster. ``params`` gives the
    weights stored in the result (the lookups were made by :func:`prepare_map`).
    """
    known_f, near_f, clear_f, known_b, near_b, clear_b, open_f, open_b = _both_ways(
        np.ascontiguousarray(matrix, dtype=np.float64),
        stride,
        space,
        first.points,
        first.open_points,
        first.landing,
        second.points,
        second.open_points,
        second.landing,
    )
    weight1, weight2 = first.point_weight * stride, second.point_weight * stride
    known = known_f * weight2 + known_b * weight1
    near = near_f * weight2 + near_b * weight1
    clear = clear_f * weight2 + clear_b * weight1
    shared = 0.0
    if space:
        shared = open_f * (second.open_weight * stride) + open_b * (first.open_weight * stride)
    weights = (params.conflict_weight, params.overlap_preference, params.space_preference)
    if known <= 0:
        return Verification(0.0, 0.0, 0.0, 0.0, shared, *weights)
    return Verification(near / known, clear / known, known, near, shared, *weights)


def confidence(
    best: Verification,
    runner_up: Verification | None = None,
    *,
    strength: float | None = None,
    params: ConfidenceParams = DEFAULT_CONFIDENCE,
) -> float:
    """Map a verification (and the best *distinct* alternative) to ``[0, 1]``.

    Up to five factors, each in ``[0, 1]``, multiplied (their scales are
    :class:`~merging.params.ConfidenceParams`, which says how they were set):

    * fit: a logistic of :attr:`Verification.quality` centred at
      ``fit_centre``;
    * support: ``1 - exp(-agreeing / support_scale)``, so a few metres of
      matching wall cannot vouch for a transform;
    * distinctiveness: a logistic of ``1 - net(runner-up) / net(best)``
      centred at ``distinct_margin``, so that two equally good explanations
      (a symmetric building) give a low confidence instead of a coin toss
      (with ``distinct_by_space``, the smaller of that share and the
      runner-up's shared open space over the best's);
    * constraint (when ``strength`` is given): ``1 - exp(-strength /
      strength_scale)``, so that an overlap that lets one map slide or turn
      along a wall is not vouched for;
    * shared space: ``1 - exp(-shared_space / shared_space_scale)``, so that
      two maps of neighbouring rooms, which fit along their common wall,
      are not taken for one room.
    """
    return float(np.prod(confidence_factors(best, runner_up, strength=strength, params=params)))


def confidence_factors(
    best: Verification,
    runner_up: Verification | None = None,
    *,
    strength: float | None = None,
    params: ConfidenceParams = DEFAULT_CONFIDENCE,
    fit_quality: float | None = None,
    pinned: tuple[float, float] | None = None,
    turn_held: bool = False,
    slide_held: bool = False,
) -> tuple[float, float, float, float, float]:
    """The five factors of :func:`confidence`: fit, support, distinctiveness, constraint, space.

    ``fit_quality`` replaces ``best.quality`` in the fit factor when given
    (the default method passes the quality at ``ConfidenceParams.fit_tolerance``).
    ``pinned``, when given, is ``(slide, turn)``: the net evidence lost by
    sliding the placement a little (:func:`merging.evidence.pinning.pinning`) and the
    strength holding its turn (:func:`merging.evidence.refine.turning_strength`); the
    constraint factor is then the larger of the curvature's and the smaller
    of the two :func:`pinned_factors`. ``turn_held`` and ``slide_held`` say
    the turn or the slide was shown to be held another way (the refinement,
    restarted turned or slid a little, comes back:
    :func:`merging.evidence.verdict.judge`), so the other one's factor alone
    stands for the pinning (both held: the placement is pinned).
    """
    quality = best.quality if fit_quality is None else fit_quality
    fit = expit((quality - params.fit_centre) / params.fit_width)
    support = 1.0 - np.exp(-best.agreeing / params.support_scale)
    share = 0.0
    if runner_up is not None and best.net > 0:
        share = max(runner_up.net, 0.0) / best.net
        if params.distinct_by_space:
            # Both verified with their shared open space counted (``space=True``).
            share = min(share, (runner_up.shared_space + 1.0) / (best.shared_space + 1.0))
    distinct = expit(((1.0 - share) - params.distinct_margin) / params.distinct_width)
    constrained = (
        1.0 if strength is None else 1.0 - np.exp(-max(strength, 0.0) / params.strength_scale)
    )
    if pinned is not None:
        slid, turned = pinned_factors(pinned, params)
        held = min(1.0 if slide_held else slid, 1.0 if turn_held else turned)
        constrained = max(constrained, held)
    shared = 1.0 - np.exp(-best.shared_space / params.shared_space_scale)
    return (float(fit), float(support), float(distinct), float(constrained), float(shared))


def pinned_factors(
    pinned: tuple[float, float], params: ConfidenceParams = DEFAULT_CONFIDENCE
) -> tuple[float, float]:
    """How firmly a placement is held against sliding and against turning, each in ``[0, 1]``.

    ``pinned`` is ``(slide, turn)`` as :func:`confidence_factors` takes it:
    ``1 - exp(-slide / pin_scale)`` and ``1 - exp(-turn / turn_scale)``.
    """
    slide, turn = pinned
    return (
        float(1.0 - np.exp(-max(slide, 0.0) / params.pin_scale)),
        float(1.0 - np.exp(-max(turn, 0.0) / params.turn_scale)),
    )
