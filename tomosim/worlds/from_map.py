"""Worlds from occupancy grids: any ROS ``map_server`` map becomes a :class:`World`.

The walls are the outlines of the grid's obstacle cells: marching squares at
level 0.5 on the obstacle mask puts each outline on the boundary between an
obstacle cell and a free cell, and Douglas-Peucker simplification (within
:data:`SIMPLIFY_TOLERANCE_CELLS`) turns the staircases into few long segments.
The truth grid is the map itself.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from skimage import measure

from merging.grid import OccupancyGrid
from merging.mapio import load_map
from tomosim.worlds.world import World

SIMPLIFY_TOLERANCE_CELLS = 0.5
"""Largest distance, in cells, between a simplified wall and the outline of the
obstacle cells: half a cell keeps every wall inside the cells it bounds."""
MIN_SEGMENT_CELLS = 1e-6
"""Segments shorter than this (in cells) carry no geometry and are dropped."""


def walls_from_mask(obstacle: NDArray[np.bool_], grid: OccupancyGrid) -> NDArray[np.float64]:
    """Outline the ``True`` cells of ``obstacle`` as wall segments in metres.

    Parameters
    ----------
    obstacle : (rows, cols) bool ndarray
        Cells robots may not enter, indexed like ``grid.data``. Cells off the
        grid count as obstacles, so free space touching the border is closed.
    grid : OccupancyGrid
        Gives the resolution and origin that place cells in metres.

    Returns
    -------
    (N, 2, 2) float ndarray
        Segments ``[[x0, y0], [x1, y1]]`` in the grid's frame, metres.
    """
    mask = np.asarray(obstacle)
    if mask.dtype != np.bool_ or mask.shape != grid.shape:
        raise ValueError(
            f"obstacle must be a boolean mask of shape {grid.shape}, "
            f"got dtype {mask.dtype} shape {mask.shape}"
        )
    padded = np.pad(mask, 1, constant_values=True).astype(np.float64)
    segments: list[NDArray[np.float64]] = []
    for contour in measure.find_contours(padded, 0.5):
        chain = measure.approximate_polygon(contour, SIMPLIFY_TOLERANCE_CELLS)
        # (row, col) in the padded image -> (x, y) = (col, row) cells of the grid.
        cells = chain[:, ::-1] - 1.0
        starts, ends = cells[:-1], cells[1:]
        keep = np.hypot(*(ends - starts).T) > MIN_SEGMENT_CELLS
        if np.any(keep):
            segments.append(np.stack([starts[keep], ends[keep]], axis=1))
    if not segments:
        return np.zeros((0, 2, 2))
    cells = np.concatenate(segments).reshape(-1, 2)
    return grid.cell_to_world(cells).reshape(-1, 2, 2)


def world_from_grid(
    grid: OccupancyGrid, *, unknown_is_obstacle: bool = True, name: str = "map"
) -> World:
    """Build a :class:`World` whose truth is ``grid``.

    Parameters
    ----------
    grid : OccupancyGrid
        The map, in the world frame.
    unknown_is_obstacle : bool
        If True (default), unknown cells are solid like occupied ones, so
        robots stay in the space the map shows as free and the lidar sees the
        edge of that space; if False only occupied cells become walls (robots
        may then leave through gaps in a broken wall).
    name : str
        Description stored in the world.
    """
    if not isinstance(grid, OccupancyGrid):
        raise TypeError(f"grid must be an OccupancyGrid, got {type(grid).__name__}")
    obstacle = ~grid.free() if unknown_is_obstacle else grid.occupied()
    return World(walls_from_mask(obstacle, grid), grid, name=name)


def world_from_map(
    source: str | Path | OccupancyGrid, *, unknown_is_obstacle: bool = True
) -> World:
    """Turn a ``map_server`` map (its YAML path or its name) or a grid into a :class:`World`.

    Parameters
    ----------
    source : str, Path or OccupancyGrid
        A ``map_server`` YAML file, the name of a map of the maps path (``"aces3"``;
        :func:`merging.catalog.find_map`), or a grid.
    unknown_is_obstacle : bool
        See :func:`world_from_grid`.

    Returns
    -------
    World
        Walls outlining the obstacle cells, the map as truth, in the map frame.
    """
    if isinstance(source, OccupancyGrid):
        return world_from_grid(source, unknown_is_obstacle=unknown_is_obstacle, name="grid")
    if not isinstance(source, str | Path):
        raise TypeError(
            f"source must be a YAML path, a map name or an OccupancyGrid, got "
            f"{type(source).__name__}"
        )
    grid = load_map(source)
    return world_from_grid(grid, unknown_is_obstacle=unknown_is_obstacle, name=Path(source).stem)
