"""One lidar scan against wall segments and circular robots, compiled.

The algorithm is that of :func:`tomosim.ray_geometry.cast_segments` (an angular
sweep: each segment is intersected only with the beams whose directions lie
between those of its end points) followed by
:func:`tomosim.ray_geometry.cast_circles`, with the bounding-box culling of
:func:`tomosim.ray_geometry.cull_segments` folded in. Those numpy functions are
its specification and its test oracle; the tolerances are theirs.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel
from tomosim.ray_geometry import ANGLE_TOLERANCE, COLLINEAR_TOLERANCE

TWO_PI = 2.0 * math.pi


@kernel
def turn_remainder(angle: float) -> float:
    """``angle % TWO_PI`` as Python and numba compute it (``fmod``, then ``TWO_PI`` added
    to a negative remainder), without ``fmod`` for the angles within a turn of zero,
    where it changes nothing: the same number for every ``angle``."""
    if 0.0 < angle < TWO_PI:
        return angle
    if -TWO_PI < angle < 0.0:
        return angle + TWO_PI
    return angle % TWO_PI


@kernel
def cast_scan(
    x: float,
    y: float,
    first_angle: float,
    increment: float,
    count: int,
    segments: NDArray[np.float64],
    centres: NDArray[np.float64],
    radii: NDArray[np.float64],
    max_range: float,
) -> NDArray[np.float64]:
    """Distance along each beam to the first wall or circle it hits.

    Parameters
    ----------
    x, y : float
        Where the beams start, metres; outside every circle.
    first_angle : float
        Direction of beam 0, radians (world frame).
    increment : float
        Angle between consecutive beams, radians; ``count * increment <= 2 pi``.
    count : int
        Number of beams ``B``; beam ``k`` points at ``first_angle + k * increment``.
    segments : (S, 4) float ndarray
        Wall segments ``(x0, y0, x1, y1)``, metres, C-contiguous.
    centres : (C, 2) float ndarray
        Circle centres, metres.
    radii : (C,) float ndarray
        Circle radii, metres.
    max_range : float
        Hits farther than this are ignored.

    Returns
    -------
    (B,) float ndarray
        Ranges in metres, ``inf`` where nothing is hit within ``max_range``.
    """
    ranges = np.full(count, np.inf)
    ux = np.empty(count)
    uy = np.empty(count)
    for k in range(count):
        angle = first_angle + increment * k
        ux[k] = math.cos(angle)
        uy[k] = math.sin(angle)
    for s in range(segments.shape[0]):
        x0 = segments[s, 0] - x
        y0 = segments[s, 1] - y
        x1 = segments[s, 2] - x
        y1 = segments[s, 3] - y
        # Culling: the segment's bounding box must meet the square of half-side max_range.
        if max(x0, x1) < -max_range or min(x0, x1) > max_range:
            continue
        if max(y0, y1) < -max_range or min(y0, y1) > max_range:
            continue
        ex = x1 - x0
        ey = y1 - y0
        # 1. Angular extent relative to beam 0: [low, high], high - low < pi.
        a0 = math.atan2(y0, x0)
        start = turn_remainder(a0 - first_angle)
        delta = turn_remainder(math.atan2(y1, x1) - a0 + math.pi) - math.pi
        low = start + min(delta, 0.0)
        high = low + abs(delta)
        cross = x0 * ey - y0 * ex
        collinear = abs(cross) <= COLLINEAR_TOLERANCE * math.hypot(ex, ey)
        # A beam along a collinear segment meets its nearer end (needed for those alone).
        nearer = min(math.hypot(x0, y0), math.hypot(x1, y1)) if collinear else 0.0
        # 2. The beams of the extent and of its copies one turn either side.
        for turn in (-TWO_PI, 0.0, TWO_PI):
            k_low = max(math.ceil((low + turn - ANGLE_TOLERANCE) / increment), 0)
            k_high = min(math.floor((high + turn + ANGLE_TOLERANCE) / increment), count - 1)
            for k in range(k_low, k_high + 1):
                # 3. Intersect beam k with the segment's line: t = cross(p0, e) / cross(u, e).
                distance = nearer if collinear else cross / (ux[k] * ey - uy[k] * ex)
                # Parallel beams (nan or inf) and hits behind the origin are no hits.
                if distance >= 0.0 and distance < ranges[k]:
                    ranges[k] = distance
    for c in range(centres.shape[0]):
        ox = centres[c, 0] - x
        oy = centres[c, 1] - y
        miss_sq = ox * ox + oy * oy - radii[c] * radii[c]
        for k in range(count):
            along = ux[k] * ox + uy[k] * oy
            discriminant = along * along - miss_sq
            if discriminant >= 0.0 and along > 0.0:
                distance = along - math.sqrt(discriminant)
                if distance < ranges[k]:
                    ranges[k] = distance
    for k in range(count):
        if ranges[k] > max_range:
            ranges[k] = np.inf
    return ranges


@kernel
def add_noise(
    ranges: NDArray[np.float64],
    normals: NDArray[np.float64],
    uniforms: NDArray[np.float64],
    noise_std: float,
    dropout_probability: float,
    max_range: float,
) -> None:
    """Turn noise-free ranges into a scan in place (:meth:`tomosim.lidar.Lidar.scan`).

    A return (finite range) gets ``noise_std * normals[k]`` added and is
    clipped to ``[0, max_range]``; a beam whose ``uniforms[k]`` falls below
    ``dropout_probability`` reports ``nan`` whatever it saw.
    """
    for k in range(ranges.shape[0]):
        value = ranges[k]
        if math.isfinite(value):
            value = min(max(value + normals[k] * noise_std, 0.0), max_range)
        if uniforms[k] < dropout_probability:
            value = np.nan
        ranges[k] = value


@kernel
def scan_team(
    poses: NDArray[np.float64],
    first_angle: float,
    increment: float,
    count: int,
    segments: NDArray[np.float64],
    radius: float,
    max_range: float,
    normals: NDArray[np.float64],
    uniforms: NDArray[np.float64],
    noise_std: float,
    dropout_probability: float,
) -> NDArray[np.float64]:
    """A noisy scan from every robot of a team, each seeing the others as circles.

    Robot ``k``'s scan is :func:`cast_scan` from ``poses[k]`` (its first beam
    at ``poses[k, 2] + first_angle``) with the other robots, in index order,
    as circles of ``radius``, then :func:`add_noise` with ``normals[k]`` and
    ``uniforms[k]``.

    Parameters
    ----------
    poses : (N, 3) float ndarray
        True poses ``(x, y, theta)``.
    normals, uniforms : (N, B) float ndarray
        Each robot's noise draws.

    Returns
    -------
    (N, B) float ndarray
        The scans' ranges.
    """
    robots = poses.shape[0]
    out = np.empty((robots, count))
    centres = np.empty((robots - 1, 2))
    radii = np.full(robots - 1, radius)
    for k in range(robots):
        seen = 0
        for other in range(robots):
            if other != k:
                centres[seen, 0] = poses[other, 0]
                centres[seen, 1] = poses[other, 1]
                seen += 1
        ranges = cast_scan(
            poses[k, 0],
            poses[k, 1],
            poses[k, 2] + first_angle,
            increment,
            count,
            segments,
            centres,
            radii,
            max_range,
        )
        add_noise(ranges, normals[k], uniforms[k], noise_std, dropout_probability, max_range)
        # Element by element: assigning the row whole compiles numba's shape checks and
        # their messages, a second and a half on a fresh install.
        for beam in range(count):
            out[k, beam] = ranges[beam]
    return out
