"""Evidence for maps that bend against each other: walls met within a tolerance, open space.

Two maps of one floor made in separate sessions, or by different robots or
sources, bend against each other by up to half a metre, draw walls 2-3 cells
thick, and each shows clutter the other does not. The close fit of
:mod:`merging.evidence.verify` (walls within a cell) cannot vouch for them. These
measures can, and :func:`robust_confidence` combines them into the second
way the default method vouches for a placement (:mod:`merging.evidence.verdict`):

* :func:`tolerant_fit`: walls counted as met within a few cells;
* :func:`open_consistency`: open space carried onto open space;
* ``open_share`` (shared open space over the smaller map's): how much
  overlaps;

besides the amount of agreeing wall, the margin over the best placement
farther than the bending (``RobustParams.distinct_cells``) and the
constraint strength.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging.evidence.verify import DEFAULT_VERIFY, PreparedMap
from merging.params import RobustParams, VerifyParams
from merging.transforms import apply_transform

DEFAULT_ROBUST = RobustParams()
"""The default thresholds of the robust way to vouch for a merge."""


def tolerant_fit(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    tolerance: int,
    params: VerifyParams = DEFAULT_VERIFY,
) -> tuple[float, float]:
    """``(agreement, quality)`` of ``matrix`` with walls counted as met within ``tolerance`` cells.

    As :func:`~merging.evidence.verify.verify`, but a carried wall cell agrees within ``tolerance``
    cells (chessboard) of a wall, and conflicts on free space more than
    ``tolerance + conflict_clearance`` cells from any wall: the fit of maps
    that bend against each other by up to ``tolerance`` cells.
    """
    inverse = np.linalg.inv(matrix)
    known = near = clear = 0.0
    for points, target, move, weight in (
        (second.points, first, matrix, second.point_weight),
        (first.points, second, inverse, first.point_weight),
    ):
        grown, far_free = target.tolerant_masks(tolerance, params.conflict_clearance)
        cols, rows, inside = _cells_of(apply_transform(move, points), target.shape)
        rows, cols = rows[inside], cols[inside]
        on_known = target.cells[rows, cols] >= 0
        on_wall = grown[rows, cols]
        known += float(np.count_nonzero(on_known | on_wall)) * weight
        near += float(np.count_nonzero(on_wall)) * weight
        clear += float(np.count_nonzero(far_free[rows, cols])) * weight
    if known <= 0:
        return 0.0, 0.0
    return near / known, (near - params.conflict_weight * clear) / known


def open_consistency(first: PreparedMap, second: PreparedMap, matrix: NDArray[np.float64]) -> float:
    """Of the clear free cells carried onto known cells of the other map, the share on clear free.

    Both directions pooled. Open space laid on open space is what a right
    placement of two maps of one floor does, however much their walls bend;
    a wrong one lays open rooms across the other map's walls and clutter.
    Returns 0 when no clear free cell lands on a known cell.
    """
    on_known = on_clear = 0.0
    for points, target, move, weight in (
        (second.open_points, first, matrix, second.open_weight),
        (first.open_points, second, np.linalg.inv(matrix), first.open_weight),
    ):
        cols, rows, inside = _cells_of(apply_transform(move, points), target.shape)
        rows, cols = rows[inside], cols[inside]
        on_known += float(np.count_nonzero(target.cells[rows, cols] >= 0)) * weight
        on_clear += float(np.count_nonzero(target.clear_free[rows, cols])) * weight
    return on_clear / on_known if on_known > 0 else 0.0


def open_cells(prepared: PreparedMap) -> float:
    """How many clear free cells the map has (``open_points`` times the cells each stands for)."""
    return len(prepared.open_points) * prepared.open_weight


def _cells_of(
    points: NDArray[np.float64], shape: tuple[int, int]
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
    """Nearest cells ``(cols, rows)`` of ``(x, y)`` points and which lie inside ``shape``."""
    cols = np.rint(points[:, 0]).astype(np.intp)
    rows = np.rint(points[:, 1]).astype(np.intp)
    inside = (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
    return cols, rows, inside


ROBUST_FACTORS = (
    "margin",
    "agreeing",
    "agreement",
    "quality",
    "open_share",
    "open_consistency",
    "strength",
)
"""Names of the factors of :func:`robust_confidence`, in the order of ``RobustParams.widths``."""


def robust_factors(
    measures: dict[str, float], params: RobustParams = DEFAULT_ROBUST
) -> dict[str, float]:
    """The factors of :func:`robust_confidence` for the measures given.

    ``measures`` may hold any of :data:`ROBUST_FACTORS`; each one present
    gets its factor, the logistic of the measure against its threshold: in
    ``[0, 1]`` and one half at the threshold (``margin`` is the margin over
    the best placement farther than ``params.distinct_cells``; ``agreeing``
    and ``strength`` are weighed
    in log10).
    """
    thresholds = {
        "margin": params.margin,
        "agreeing": np.log10(params.agreeing),
        "agreement": params.agreement,
        "quality": params.quality,
        "open_share": params.open_share,
        "open_consistency": params.open_consistency,
        "strength": np.log10(params.strength),
    }
    widths = dict(zip(ROBUST_FACTORS, params.widths, strict=True))
    factors: dict[str, float] = {}
    for name in ROBUST_FACTORS:
        if name not in measures:
            continue
        value = measures[name]
        if name == "agreeing":
            value = np.log10(max(value, 1.0))
        elif name == "strength":
            value = np.log10(max(value, 1e-3))
        factors[name] = float(1.0 / (1.0 + np.exp(-(value - thresholds[name]) / widths[name])))
    return factors


def robust_confidence(
    measures: dict[str, float], params: RobustParams = DEFAULT_ROBUST
) -> tuple[float, dict[str, float]]:
    """The second way to vouch for a merge (see :class:`~merging.params.RobustParams`).

    Parameters
    ----------
    measures : dict
        ``margin``, ``agreeing``, ``agreement``, ``quality``, ``open_share``,
        ``open_consistency`` and ``strength`` of the placement, in the units
        of :class:`~merging.params.RobustParams`.

    Returns
    -------
    confidence : float
        The weakest of the factors: at least one half exactly when every
        measure reaches its threshold.
    factors : dict
        Each factor, in ``[0, 1]`` (:func:`robust_factors`).
    """
    missing = [name for name in ROBUST_FACTORS if name not in measures]
    if missing:
        raise KeyError(f"robust_confidence needs every measure; missing {missing}")
    factors = robust_factors(measures, params)
    return min(factors.values()), factors
