"""A reference lidar built on pymunk's segment queries, one query per beam.

It is slower than :func:`tomosim.ray_geometry.cast_segments` but independent of
it (Chipmunk's own ray-shape tests and spatial index), which makes it the
oracle the numpy caster is tested against, and the baseline the benchmark
compares it with.
"""

from __future__ import annotations

import numpy as np
import pymunk
from numpy.typing import ArrayLike, NDArray

from tomosim.physics import ROBOT_GROUP_OFFSET


def cast_pymunk(
    space: pymunk.Space,
    pose: ArrayLike,
    angles: ArrayLike,
    max_range: float,
    *,
    robot: int | None = None,
) -> NDArray[np.float64]:
    """Noise-free ranges by ``space.segment_query_first`` along each beam.

    Parameters
    ----------
    space : pymunk.Space
        Walls and robots, e.g. :attr:`tomosim.physics.Physics.space` or
        :func:`tomosim.physics.build_space`.
    pose : (3,) array_like
        Sensor pose ``(x, y, theta)``, metres and radians.
    angles : (B,) array_like
        Beam directions relative to ``theta``, radians.
    max_range : float
        Length of each query, metres.
    robot : int, optional
        Index of the scanning robot in :class:`~tomosim.physics.Physics`;
        its own shapes are ignored.

    Returns
    -------
    (B,) float ndarray
        Metres to the first shape hit, ``inf`` if none within ``max_range``.
    """
    x, y, theta = (float(v) for v in np.asarray(pose, dtype=float))
    bearings = theta + np.asarray(angles, dtype=float)
    group = 0 if robot is None else robot + ROBOT_GROUP_OFFSET
    shape_filter = pymunk.ShapeFilter(group=group)
    ranges = np.full(len(bearings), np.inf)
    for index, bearing in enumerate(bearings.tolist()):
        end = (x + max_range * np.cos(bearing), y + max_range * np.sin(bearing))
        info = space.segment_query_first((x, y), end, 0.0, shape_filter)
        if info is not None:
            ranges[index] = info.alpha * max_range
    return ranges
