"""Painting shapes given in metres into a grid's cells (for building truth grids).

A cell is painted when its *centre* lies inside the shape, so shapes that
share an edge never both claim a cell and a shape narrower than a cell may
paint none.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from merging.grid import OccupancyGrid


def _span(low: float, high: float, origin: float, resolution: float, size: int) -> slice:
    """Indices of cells whose centres ``origin + (i + 0.5) * resolution`` lie in ``[low, high]``."""
    first = math.ceil((low - origin) / resolution - 0.5)
    last = math.floor((high - origin) / resolution - 0.5)
    return slice(max(first, 0), min(last + 1, size))


def paint_rectangle(
    data: NDArray[np.int8],
    grid: OccupancyGrid,
    corners: tuple[float, float, float, float],
    value: int,
) -> None:
    """Set cells whose centres lie in the axis-aligned box ``(x0, y0, x1, y1)`` (metres).

    ``grid`` supplies the resolution and origin (its yaw must be 0); ``data``
    is painted in place and must have ``grid``'s shape.
    """
    x0, y0, x1, y1 = corners
    ox, oy, yaw = grid.origin
    if yaw != 0.0:
        raise ValueError(f"painting needs an axis-aligned grid, got origin yaw {yaw}")
    rows, cols = data.shape
    res = grid.resolution
    data[
        _span(min(y0, y1), max(y0, y1), oy, res, rows),
        _span(min(x0, x1), max(x0, x1), ox, res, cols),
    ] = value


def box_mask(
    shape: tuple[int, int],
    grid: OccupancyGrid,
    box: tuple[float, float, float, float, float],
) -> NDArray[np.bool_]:
    """Mask of cells whose centres lie in a rotated box ``(cx, cy, length, width, angle)``.

    ``angle`` (radians, counter-clockwise) is the direction of the ``length``
    side; lengths in metres. ``shape`` is the mask's ``(rows, cols)``.
    """
    cx, cy, length, width, angle = box
    half = 0.5 * math.hypot(length, width)
    ox, oy, _ = grid.origin
    res = grid.resolution
    rows, cols = shape
    row_span = _span(cy - half, cy + half, oy, res, rows)
    col_span = _span(cx - half, cx + half, ox, res, cols)
    ys = oy + (np.arange(row_span.start, row_span.stop) + 0.5) * res - cy
    xs = ox + (np.arange(col_span.start, col_span.stop) + 0.5) * res - cx
    c, s = math.cos(angle), math.sin(angle)
    along = xs[None, :] * c + ys[:, None] * s
    across = -xs[None, :] * s + ys[:, None] * c
    mask = np.zeros(shape, dtype=bool)
    mask[row_span, col_span] = (np.abs(along) <= 0.5 * length) & (np.abs(across) <= 0.5 * width)
    return mask
