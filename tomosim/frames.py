"""Frames in metres: poses as rigid matrices, and grids placed in another frame.

A pose ``(x, y, theta)`` of frame B in frame A is the 3x3 matrix taking
points of B to points of A (``[p_A, 1]^T = M [p_B, 1]^T``). A robot's map
frame is its start pose, so its start pose (known to the simulator alone) is
the matrix taking its map into the world.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from merging.transforms import matrix_to_pose, rigid_matrix


def pose_matrix(pose: ArrayLike) -> NDArray[np.float64]:
    """3x3 rigid matrix of ``pose = (x, y, theta)`` (metres, radians).

    The same matrix as :func:`merging.rigid_matrix` (eq. 1 of the paper), taking
    the pose as one array.
    """
    x, y, theta = (float(v) for v in np.asarray(pose, dtype=float))
    return rigid_matrix(x, y, theta)


def frame_errors(estimate: ArrayLike, truth: ArrayLike) -> tuple[float, float]:
    """``(rotation_deg, translation_m)`` between two transforms of one frame (metres).

    Both are 3x3 rigid matrices taking one frame B to another frame A: the
    rotation error is ``|wrap(yaw_est - yaw_true)|`` in degrees, in
    ``[0, 180]``; the translation error is the distance between where the two
    put B's origin in A, in metres. Returns ``(inf, inf)`` when ``estimate``
    is not a finite 3x3 matrix.
    """
    est = np.asarray(estimate, dtype=float)
    ref = np.asarray(truth, dtype=float)
    if ref.shape != (3, 3) or not np.all(np.isfinite(ref)):
        raise ValueError(f"truth must be a finite 3x3 matrix, got shape {ref.shape}")
    if est.shape != (3, 3) or not np.all(np.isfinite(est)):
        return math.inf, math.inf
    turn = math.remainder(matrix_to_pose(est)[2] - matrix_to_pose(ref)[2], 2 * math.pi)
    shift = float(np.hypot(*(est[:2, 2] - ref[:2, 2])))
    return abs(math.degrees(turn)), shift


RIGID_TOLERANCE = 1e-6
"""How far a matrix :func:`place_grid` takes may be from a rigid one (products of
rigid matrices drift by about 1e-15)."""


def place_grid(grid: OccupancyGrid, frame_from_grid: ArrayLike) -> OccupancyGrid:
    """The same cells placed in another frame.

    ``frame_from_grid`` is a 3x3 rigid matrix taking points of ``grid``'s
    frame (metres) to the new frame: e.g. :func:`pose_matrix` of a robot's
    true start pose puts its map in the world, and the transform from a
    merged map's frame into a robot's odometry frame puts the merged map
    where that robot can plan on it.
    """
    matrix = np.asarray(frame_from_grid, dtype=float)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"frame_from_grid must be a finite 3x3 matrix, got shape {matrix.shape}")
    turn_part = matrix[:2, :2]
    if not (
        np.allclose(turn_part.T @ turn_part, np.eye(2), atol=RIGID_TOLERANCE)
        and np.linalg.det(turn_part) > 0
        and np.allclose(matrix[2], (0.0, 0.0, 1.0), atol=RIGID_TOLERANCE)
    ):
        raise ValueError(
            "frame_from_grid must be rigid (a turn and a shift): it would scale or mirror "
            f"the grid, which keeps its cells and resolution; got {matrix.round(6).tolist()}"
        )
    ox, oy, yaw = grid.origin
    x, y = matrix[:2, :2] @ np.array([ox, oy]) + matrix[:2, 2]
    turn = math.atan2(matrix[1, 0], matrix[0, 0])
    return OccupancyGrid(
        grid.data,
        resolution=grid.resolution,
        origin=(float(x), float(y), math.remainder(yaw + turn, 2 * math.pi)),
    )
