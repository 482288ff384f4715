"""Per-robot observation and action spaces of the exploration environments, and their values.

Observation of one robot (a ``Dict`` space):

=======  ==============  ========  =====================================================
key      shape           dtype     values
=======  ==============  ========  =====================================================
scan     (beams,)        float32   ranges in metres, ``[0, max_range]``; no return and
                                   dropouts read ``max_range``
map      (size, size)    int8      egocentric window of the robot's best map in the ROS
                                   coding: -1 unknown, 0..100 percent occupied
pose     (3,)            float32   pose estimate ``(x, y, theta)`` in the robot's own
                                   map frame (metres, radians in ``[-pi, pi]``)
=======  ==============  ========  =====================================================

The map window is centred on the robot's estimated position and aligned with
its map frame, not rotated with its heading (``pose[2]`` gives the heading);
row 0 is the window's lowest ``y``. Each window cell covers ``pool x pool``
map cells and holds their maximum, so walls survive the coarsening.

In the *normalised* format (``observation_format="normalised"``), for
learners, every value lies in a fixed small range and the map is an image:

=======  ==================  ========  =================================================
key      shape               dtype     values
=======  ==================  ========  =================================================
scan     (beams,)            float32   ranges as fractions of ``max_range``, ``[0, 1]``
map      (3, size, size)     uint8     channels *free*, *occupied*, *unknown* of the same
                                       window: 255 where the cell is free (<= 19),
                                       occupied (>= 65) or unknown (-1), else 0 (a cell
                                       in between is none of them)
pose     (4,)                float32   ``(x / bound, y / bound, cos theta, sin theta)``,
                                       ``[-1, 1]``
=======  ==================  ========  =================================================

Action of one robot: ``Box(-1, 1, (2,), float32)``, the linear and angular
velocity as fractions of the robot's maximum forward speed and turn rate;
values outside the box are clipped.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from merging.grid import FREE_THRESHOLD, OCCUPIED, OCCUPIED_THRESHOLD, UNKNOWN
from tomosim.team import TeamSession
from tomosim.worlds import World

OBSERVATION_FORMATS = ("metric", "normalised")
"""The observation formats (module docstring); the first is the default."""
CHANNEL_ON = 255
"""Pixel value of a map cell that is in a channel's class."""
POSE_MARGIN = 10.0
"""Metres added to the world's diagonal for the bound of a pose estimate, room for
odometry drift; an estimate beyond it is clipped."""


def pose_bound(world: World) -> float:
    """Largest ``|x|`` or ``|y|`` a pose estimate in a robot's own frame is given."""
    xmin, ymin, xmax, ymax = world.bounds
    return math.hypot(xmax - xmin, ymax - ymin) + POSE_MARGIN


def observation_space(beams: int, max_range: float, size: int, bound: float) -> spaces.Dict:
    """The space of one robot's observation (module docstring)."""
    return spaces.Dict(
        {
            "scan": spaces.Box(0.0, max_range, shape=(beams,), dtype=np.float32),
            "map": spaces.Box(UNKNOWN, OCCUPIED, shape=(size, size), dtype=np.int8),
            "pose": spaces.Box(
                np.array([-bound, -bound, -math.pi], dtype=np.float32),
                np.array([bound, bound, math.pi], dtype=np.float32),
                dtype=np.float32,
            ),
        }
    )


def normalised_observation_space(beams: int, size: int) -> spaces.Dict:
    """The space of one robot's observation in the normalised format (module docstring)."""
    return spaces.Dict(
        {
            "scan": spaces.Box(0.0, 1.0, shape=(beams,), dtype=np.float32),
            "map": spaces.Box(0, CHANNEL_ON, shape=(3, size, size), dtype=np.uint8),
            "pose": spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32),
        }
    )


def map_image(cells: NDArray[np.int8]) -> NDArray[np.uint8]:
    """``(3, rows, cols)`` uint8 channels free, occupied, unknown of ROS-coded ``cells``."""
    image = np.zeros((3, *cells.shape), dtype=np.uint8)
    image[0][(cells >= 0) & (cells <= FREE_THRESHOLD)] = CHANNEL_ON
    image[1][cells >= OCCUPIED_THRESHOLD] = CHANNEL_ON
    image[2][cells < 0] = CHANNEL_ON
    return image


def normalise(
    observation: dict[str, NDArray[Any]], *, bound: float, max_range: float
) -> dict[str, NDArray[Any]]:
    """A metric-format observation in the normalised format (module docstring)."""
    x, y, theta = (float(v) for v in observation["pose"])
    return {
        "scan": (observation["scan"] / np.float32(max_range)).astype(np.float32),
        "map": map_image(observation["map"]),
        "pose": np.array(
            [x / bound, y / bound, math.cos(theta), math.sin(theta)], dtype=np.float32
        ).clip(-1.0, 1.0),
    }


def action_space() -> spaces.Box:
    """The space of one robot's action (module docstring)."""
    return spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)


def observe(
    session: TeamSession, robot: int, *, size: int, pool: int, bound: float
) -> dict[str, NDArray[np.float32] | NDArray[np.int8]]:
    """Robot ``robot``'s observation now (new arrays every call)."""
    scan = session.simulation.scans[robot]
    ranges = scan.ranges.astype(np.float32)  # returns already lie in [0, max_range]
    ranges[~np.isfinite(ranges)] = scan.max_range
    x, y, theta = session.simulation.odometry[robot].pose.tolist()
    return {
        "scan": ranges,
        "map": session.best_crop(robot, size=size, pool=pool),
        "pose": np.array(
            [min(max(x, -bound), bound), min(max(y, -bound), bound), theta], dtype=np.float32
        ),
    }


def observe_team(
    session: TeamSession, *, size: int, pool: int, bound: float
) -> tuple[NDArray[np.float32], NDArray[np.int8], NDArray[np.float32]]:
    """Every robot's observation now, as arrays with one row a robot (new every call).

    Row ``k`` of each is what :func:`observe` gives robot ``k``.

    Returns
    -------
    scans : (N, beams) float32 ndarray
    maps : (N, size, size) int8 ndarray
    poses : (N, 3) float32 ndarray
    """
    simulation = session.simulation
    # Returns lie in [0, max_range] already; fmin reads no return (inf) and dropouts (nan)
    # as max_range.
    scans = np.fmin(simulation.ranges, simulation.lidar.config.max_range).astype(np.float32)
    poses = np.array(
        [
            (min(max(x, -bound), bound), min(max(y, -bound), bound), theta)
            for x, y, theta in (odometry.pose.tolist() for odometry in simulation.odometry)
        ],
        dtype=np.float32,
    )
    maps = np.empty((simulation.count, size, size), dtype=np.int8)
    for robot in range(simulation.count):
        maps[robot] = session.best_crop(robot, size=size, pool=pool)
    return scans, maps, poses


def normalise_team(
    scans: NDArray[np.float32],
    maps: NDArray[np.int8],
    poses: NDArray[np.float32],
    *,
    bound: float,
    max_range: float,
) -> tuple[NDArray[np.float32], NDArray[np.uint8], NDArray[np.float32]]:
    """:func:`normalise` of every robot's observation from :func:`observe_team`, in rows."""
    image = np.zeros((len(maps), 3, *maps.shape[1:]), dtype=np.uint8)
    image[:, 0][(maps >= 0) & (maps <= FREE_THRESHOLD)] = CHANNEL_ON
    image[:, 1][maps >= OCCUPIED_THRESHOLD] = CHANNEL_ON
    image[:, 2][maps < 0] = CHANNEL_ON
    pose = np.array(
        [
            [x / bound, y / bound, math.cos(theta), math.sin(theta)]  # as normalise() does
            for x, y, theta in poses.tolist()
        ],
        dtype=np.float32,
    ).reshape(-1, 4)
    return (scans / np.float32(max_range)).astype(np.float32), image, pose.clip(-1.0, 1.0)


def command(action: object, *, name: str) -> tuple[float, float]:
    """An action as a ``(linear, angular)`` command clipped to ``[-1, 1]``."""
    if type(action) is np.ndarray and action.shape == (2,) and action.dtype.kind == "f":
        linear, angular = action.tolist()  # the common case, a sampled action, at once
        if math.isfinite(linear) and math.isfinite(angular):
            return (min(max(linear, -1.0), 1.0), min(max(angular, -1.0), 1.0))
    values = np.empty(0)
    try:
        given = np.asarray(action)
        if given.dtype.kind in "iuf":  # numbers, not text, booleans or complex numbers
            values = given.astype(np.float64).reshape(-1)
    except (TypeError, ValueError):  # text, dicts, ragged lists: refused below
        pass
    if values.shape == (2,):
        linear, angular = values.tolist()
        if math.isfinite(linear) and math.isfinite(angular):
            return (min(max(linear, -1.0), 1.0), min(max(angular, -1.0), 1.0))
    raise ValueError(
        f"the action of {name} must be two finite numbers (linear, angular), got {action!r}"
    )
