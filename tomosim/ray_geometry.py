"""Vectorised 2-D ray casting against line segments and circles (pure numpy).

The segment caster sweeps angles instead of testing every ray against every
segment: each segment covers the beams whose directions lie between the
directions of its two end points, and only those (segment, beam) pairs are
intersected. Work grows with the number of such pairs (about the number of
beams times the depth complexity of the scene) rather than beams x segments.

Conventions: points are ``(x, y)`` metres, angles radians counter-clockwise
from ``+x``; a range is the distance along the beam to the first hit, and
``inf`` where nothing is hit within ``max_range``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

ANGLE_TOLERANCE = 1e-9
"""Radians by which a segment's angular extent is widened, so that a beam
through the vertex shared by two segments is not lost to rounding between
them (it then hits the line within 1e-9 rad of the vertex)."""
COLLINEAR_TOLERANCE = 1e-12
"""Metres from a segment's line within which the origin counts as on that line;
a beam along such a segment hits its nearer end point."""
TWO_PI = 2.0 * np.pi
WINDOW_SHIFTS_LOW = np.array([-TWO_PI, 0.0, TWO_PI]) - ANGLE_TOLERANCE
WINDOW_SHIFTS_HIGH = np.array([-TWO_PI, 0.0, TWO_PI]) + ANGLE_TOLERANCE


def segment_bounds(segments: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(4, S)`` array of the segments' bounding boxes: rows ``xmin, ymin, xmax, ymax``."""
    low = segments.min(axis=1)
    high = segments.max(axis=1)
    return np.ascontiguousarray(np.vstack([low.T, high.T]))


def cull_segments(
    origin: NDArray[np.float64], bounds: NDArray[np.float64], max_range: float
) -> NDArray[np.intp]:
    """Indices of the segments whose bounding boxes meet the square of half-side
    ``max_range`` around ``origin``; ``bounds`` comes from :func:`segment_bounds`."""
    x, y = origin
    near = (bounds[2] >= x - max_range) & (bounds[0] <= x + max_range)
    near &= (bounds[3] >= y - max_range) & (bounds[1] <= y + max_range)
    return np.flatnonzero(near)


def cast_segments(
    origin: NDArray[np.float64],
    first_angle: float,
    increment: float,
    count: int,
    segments: NDArray[np.float64],
    max_range: float,
) -> NDArray[np.float64]:
    """Distance along each beam to the first segment it hits.

    Parameters
    ----------
    origin : (2,) float ndarray
        Where the beams start, metres.
    first_angle : float
        Direction of beam 0, radians (world frame).
    increment : float
        Angle between consecutive beams, radians, ``0 < increment``;
        ``count * increment`` must not exceed ``2 pi``.
    count : int
        Number of beams ``B``; beam ``k`` points at ``first_angle + k * increment``.
    segments : (S, 2, 2) float ndarray
        Segments ``[[x0, y0], [x1, y1]]``, metres.
    max_range : float
        Hits farther than this are ignored.

    Returns
    -------
    (B,) float ndarray
        Ranges in metres, ``inf`` where no segment is hit within ``max_range``.
    """
    ranges = np.full(count, np.inf)
    if len(segments) == 0 or count == 0:
        return ranges
    ends = segments.reshape(-1, 4) - np.tile(origin, 2)
    x0, y0, x1, y1 = ends.T
    ex, ey = x1 - x0, y1 - y0
    # 1. Angular extent of each segment relative to beam 0: [low, high], high - low < pi.
    a0 = np.arctan2(y0, x0)
    start = np.mod(a0 - first_angle, TWO_PI)
    delta = np.mod(np.arctan2(y1, x1) - a0 + np.pi, TWO_PI) - np.pi
    low = start + np.minimum(delta, 0.0)
    high = low + np.abs(delta)
    # 2. Beam index windows: the extent itself and its copies one turn either side.
    k_low = np.ceil((low[:, None] + WINDOW_SHIFTS_LOW) / increment).astype(np.int64)
    k_high = np.floor((high[:, None] + WINDOW_SHIFTS_HIGH) / increment).astype(np.int64)
    np.maximum(k_low, 0, out=k_low)
    np.minimum(k_high, count - 1, out=k_high)
    lengths = (k_high - k_low + 1).ravel()
    np.maximum(lengths, 0, out=lengths)
    ends_cum = np.cumsum(lengths)
    total = int(ends_cum[-1])
    if total == 0:
        return ranges
    # 3. One (segment, beam) pair per covered beam.
    pair_segment = np.repeat(np.repeat(np.arange(len(segments)), 3), lengths)
    pair_beam = np.repeat(k_low.ravel() - (ends_cum - lengths), lengths)
    pair_beam += np.arange(total)
    # 4. Intersect beam k with the segment's line: t = cross(p0, e) / cross(u, e).
    angles = first_angle + increment * np.arange(count)
    ux, uy = np.cos(angles)[pair_beam], np.sin(angles)[pair_beam]
    cross = x0 * ey - y0 * ex
    denominator = ux * ey[pair_segment] - uy * ex[pair_segment]
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = cross[pair_segment] / denominator
    collinear = np.abs(cross) <= COLLINEAR_TOLERANCE * np.hypot(ex, ey)
    if np.any(collinear):
        nearer = np.minimum(np.hypot(x0, y0), np.hypot(x1, y1))
        on_line = collinear[pair_segment]
        distance[on_line] = nearer[pair_segment[on_line]]
    # Parallel beams (0/0 or x/0) and hits behind the origin are no hits.
    distance[~(distance >= 0.0)] = np.inf
    # 5. Nearest hit per beam.
    np.minimum.at(ranges, pair_beam, distance)
    ranges[ranges > max_range] = np.inf
    return ranges


def cast_circles(
    origin: NDArray[np.float64],
    directions: NDArray[np.float64],
    centres: NDArray[np.float64],
    radii: NDArray[np.float64],
    max_range: float,
) -> NDArray[np.float64]:
    """Distance along each beam to the first circle it enters.

    Parameters
    ----------
    origin : (2,) float ndarray
        Start of the beams, metres; assumed outside every circle.
    directions : (B, 2) float ndarray
        Unit beam directions.
    centres : (C, 2) float ndarray
        Circle centres, metres.
    radii : (C,) float ndarray
        Circle radii, metres.
    max_range : float
        Hits farther than this are ignored.

    Returns
    -------
    (B,) float ndarray
        Ranges in metres, ``inf`` where no circle is hit within ``max_range``.
    """
    ranges = np.full(len(directions), np.inf)
    if len(centres) == 0:
        return ranges
    offset = centres - origin
    along = directions @ offset.T
    miss_sq = np.sum(offset**2, axis=1) - radii**2
    discriminant = along**2 - miss_sq
    hit = (discriminant >= 0.0) & (along > 0.0)
    distance = np.where(hit, along - np.sqrt(np.where(hit, discriminant, 0.0)), np.inf)
    ranges = distance.min(axis=1)
    ranges[ranges > max_range] = np.inf
    return ranges


def distance_to_segments(
    points: NDArray[np.float64], segments: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distance from each of ``(N, 2)`` points to the nearest of ``(S, 2, 2)`` segments.

    Returns ``(N,)`` metres, ``inf`` when there are no segments.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(segments) == 0:
        return np.full(len(pts), np.inf)
    start = segments[:, 0]
    edge = segments[:, 1] - start
    length_sq = np.maximum(np.sum(edge**2, axis=1), np.finfo(float).tiny)
    offset = pts[:, None, :] - start[None, :, :]
    along = np.clip(np.sum(offset * edge[None], axis=2) / length_sq, 0.0, 1.0)
    nearest = start[None] + along[..., None] * edge[None]
    return np.sqrt(np.min(np.sum((pts[:, None, :] - nearest) ** 2, axis=2), axis=1))
