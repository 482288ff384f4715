"""Bringing a grid to a coarser resolution, so that maps of different resolutions merge.

A coarse cell takes the **maximum** of the ROS values of the fine cells whose
centres fall inside it (as :mod:`merging.linking.fusion` combines overlapping maps):
a wall seen in any part of it makes it occupied, otherwise any free part
makes it free, and only a wholly unobserved cell stays unknown. Thin walls
therefore survive the reduction, which is what matching needs.

Resampling keeps the map frame: the coarse grid's origin is the fine grid's,
so a point in metres is the same point in both, and
``resampled.cell_to_world_matrix() @ to_resampled == grid.cell_to_world_matrix()``
up to where the cell centres fall.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging.grid import UNKNOWN, OccupancyGrid

SAME_RESOLUTION = 1e-6
"""Relative difference of two resolutions below which they are the same."""


def scale_matrix(factor: float) -> NDArray[np.float64]:
    """The matrix taking cells of a grid to cells of the same area ``factor`` times coarser.

    A cell of size ``r`` covers ``[x - 0.5, x + 0.5] * r`` (centres at
    integers), so ``x' = (x + 0.5) / factor - 0.5``.
    """
    inverse = 1.0 / factor
    offset = 0.5 * inverse - 0.5
    return np.array([[inverse, 0.0, offset], [0.0, inverse, offset], [0.0, 0.0, 1.0]])


def coarsen_cells(cells: NDArray[np.int8], factor: float) -> NDArray[np.int8]:
    """``cells`` reduced by ``factor`` (> 1) per side, each coarse cell the maximum of its cells.

    A fine cell belongs to the coarse cell its centre falls into.
    """
    if not factor > 1.0:
        raise ValueError(f"factor must exceed 1 (a coarser grid), got {factor}")
    if not np.isfinite(factor):
        raise ValueError(f"factor must be a finite number, got {factor}")
    rows, cols = cells.shape
    whole = round(factor)
    # Whole blocks that fit the grid's short side: a longer block pads that side to the
    # block's length (a factor of a million on a square grid: terabytes); the runs
    # below give the same cells for any factor.
    if abs(factor - whole) < SAME_RESOLUTION * factor and whole <= min(rows, cols):
        # Whole blocks: pad with unknown to a multiple of the block and reduce.
        padded = np.full((-(-rows // whole) * whole, -(-cols // whole) * whole), UNKNOWN, np.int8)
        padded[:rows, :cols] = cells
        blocks = padded.reshape(padded.shape[0] // whole, whole, padded.shape[1] // whole, whole)
        return np.asarray(blocks.max(axis=(1, 3)), dtype=np.int8)
    row_index = np.floor((np.arange(rows) + 0.5) / factor).astype(np.intp)
    col_index = np.floor((np.arange(cols) + 0.5) / factor).astype(np.intp)
    out = np.full((int(row_index[-1]) + 1, int(col_index[-1]) + 1), UNKNOWN, dtype=np.int8)
    # Reduce along columns first (a maximum over each run of equal indices), then rows.
    col_starts = np.flatnonzero(np.r_[True, np.diff(col_index) > 0])
    by_cols = np.maximum.reduceat(cells, col_starts, axis=1)
    row_starts = np.flatnonzero(np.r_[True, np.diff(row_index) > 0])
    reduced = np.maximum.reduceat(by_cols, row_starts, axis=0)
    out[: reduced.shape[0], : reduced.shape[1]] = reduced
    return out


def to_resolution(
    grid: OccupancyGrid, resolution: float
) -> tuple[OccupancyGrid, NDArray[np.float64]]:
    """``grid`` at a coarser ``resolution`` (metres) and the matrix from its cells to the new ones.

    Raises
    ------
    ValueError
        If ``resolution`` is finer than the grid's: only coarsening keeps
        every wall without inventing detail.
    """
    factor = resolution / grid.resolution
    if not np.isfinite(factor):
        raise ValueError(
            f"cannot resample a {grid.resolution} m grid to {resolution} m: their ratio is "
            "not a finite number"
        )
    if abs(factor - 1.0) < SAME_RESOLUTION:
        return grid, np.eye(3)
    if factor < 1.0:
        raise ValueError(
            f"cannot resample a {grid.resolution} m grid to the finer {resolution} m; "
            "resample the finer map to the coarser resolution instead"
        )
    coarse = OccupancyGrid(
        coarsen_cells(grid.data, factor), resolution=resolution, origin=grid.origin
    )
    return coarse, scale_matrix(factor)


def common_resolution(grids: list[OccupancyGrid]) -> list[OccupancyGrid]:
    """The grids, each finer one coarsened to the coarsest resolution among them.

    For tools that need one resolution throughout (fusing N maps into one
    grid); each grid keeps its frame, so transforms in metres are unchanged.
    """
    coarsest = max(grid.resolution for grid in grids)
    return [to_resolution(grid, coarsest)[0] for grid in grids]
