"""Rigid map transformation matrices (eq. 1 of the paper) and their algebra.

A *map transformation matrix* ``T`` is 3x3 homogeneous with
``[x1, y1, 1]^T = T [x2, y2, 1]^T``: it takes map 2's cell coordinates
``(x, y) = (col, row)`` into map 1's, rotating counter-clockwise by ``theta``
and then translating by ``(dx, dy)`` (eq. 1).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid

AFFINE_TOLERANCE = 1e-9
"""Largest deviation of a matrix's last row from ``[0, 0, 1]``, and smallest
determinant of its 2 x 2 part, taken as rounding: a larger deviation is a
projective matrix, which grids cannot be warped by; a smaller determinant folds
map 2 onto a line."""


def checked_transform(
    matrix: object, *, name: str = "matrix", invertible: bool = True
) -> NDArray[np.float64]:
    """``matrix`` as a 3x3 float array if it is a finite 2-D transform (last row
    ``[0, 0, 1]``) and, with ``invertible``, one that does not fold the plane; else a
    ValueError saying which of these fails, calling it ``name``."""
    try:
        m = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3x3 array of numbers, got {matrix!r}") from None
    if m.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 transform, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError(
            f"{name} must be finite, got {np.array2string(m, precision=3)}; "
            "give a 3x3 transform, map 2 cells -> map 1 cells"
        )
    if np.max(np.abs(m[2] - (0.0, 0.0, 1.0))) > AFFINE_TOLERANCE:
        raise ValueError(
            f"{name} must be affine, with last row [0, 0, 1], got last row {m[2].tolist()}"
        )
    if invertible and abs(np.linalg.det(m[:2, :2])) < AFFINE_TOLERANCE:
        raise ValueError(
            f"{name} is singular (determinant {np.linalg.det(m[:2, :2]):.3g}): it folds map 2 "
            "onto a line; give an invertible transform, map 2 cells -> map 1 cells"
        )
    return m


def rigid_matrix(dx: float, dy: float, theta: float) -> NDArray[np.float64]:
    """``T(dx, dy, theta)`` of eq. (1); ``theta`` in radians, counter-clockwise."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, dx], [s, c, dy], [0.0, 0.0, 1.0]])


def translation_matrix(offset: ArrayLike) -> NDArray[np.float64]:
    """The matrix translating by ``offset = (dx, dy)`` cells."""
    dx, dy = np.asarray(offset, dtype=float).ravel()
    return rigid_matrix(float(dx), float(dy), 0.0)


def rotation_about(theta: float, centre: ArrayLike) -> NDArray[np.float64]:
    """Rotation by ``theta`` (radians, counter-clockwise) about the point ``centre``."""
    cx, cy = np.asarray(centre, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, cx - c * cx + s * cy], [s, c, cy - s * cx - c * cy], [0, 0, 1.0]])


def matrix_to_pose(matrix: ArrayLike) -> tuple[float, float, float]:
    """``(dx, dy, theta)`` of a rigid matrix, ``theta`` in ``(-pi, pi]``."""
    m = np.asarray(matrix, dtype=float)
    if m.shape != (3, 3):
        raise ValueError(f"matrix must be a 3x3 transform, got shape {m.shape}")
    return float(m[0, 2]), float(m[1, 2]), float(np.arctan2(m[1, 0], m[0, 0]))


def apply_transform(matrix: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Apply a 3x3 homogeneous ``matrix`` to ``(N, 2)`` points; returns ``(N, 2)``."""
    m = np.asarray(matrix, dtype=float)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    return pts @ m[:2, :2].T + m[:2, 2]


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap radians into ``(-pi, pi]``."""
    a = np.asarray(angle, dtype=float)
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def cells_to_metres(
    matrix: ArrayLike, grid1: OccupancyGrid, grid2: OccupancyGrid
) -> NDArray[np.float64]:
    """Express a cell transform as a transform between the two maps' frames in metres.

    Returns ``W1 @ T @ inv(W2)`` where ``Wi`` is
    :meth:`OccupancyGrid.cell_to_world_matrix`: it takes a point in map 2's
    frame (metres) to map 1's frame (metres).
    """
    for name, grid in (("grid1", grid1), ("grid2", grid2)):
        if not isinstance(grid, OccupancyGrid):
            raise TypeError(
                f"{name} must be an OccupancyGrid (its resolution and origin place the cells in "
                f"metres), got {type(grid).__name__}"
            )
    w1 = grid1.cell_to_world_matrix()
    w2 = grid2.cell_to_world_matrix()
    return w1 @ np.asarray(matrix, dtype=float) @ np.linalg.inv(w2)


def halfway(
    a: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The rigid transform halfway between ``a`` and ``b``: turned by the mean of their
    angles, and laying the centroid of ``points`` halfway between where they lay it."""
    first, second = matrix_to_pose(a)[2], matrix_to_pose(b)[2]
    angle = float(first + wrap_angle(second - first) / 2.0)
    centre = points.mean(axis=0) if len(points) else np.zeros(2)
    target = (apply_transform(a, centre[None, :]) + apply_transform(b, centre[None, :]))[0] / 2.0
    turned = rigid_matrix(0.0, 0.0, angle)
    shift = target - turned[:2, :2] @ centre
    return rigid_matrix(float(shift[0]), float(shift[1]), angle)
