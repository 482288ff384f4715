"""Measures that need the ground truth: how much of the world a map covers.

These use the true start pose of a robot, which only the simulator knows;
they are for evaluation and rewards, never for the robots themselves.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from tomosim.frames import pose_matrix
from tomosim.worlds.world import World


def known_in_world(world: World, grid: OccupancyGrid, start_pose: ArrayLike) -> NDArray[np.bool_]:
    """Mask over ``world.truth`` of the cells whose centres fall on known cells of ``grid``.

    ``grid`` is a robot's map in its own frame; ``start_pose`` is the robot's
    true start pose ``(x, y, theta)`` in the world, which places that frame.
    """
    rows, cols = world.truth.shape
    ys, xs = np.mgrid[0:rows, 0:cols]
    cells = np.column_stack([xs.ravel(), ys.ravel()])
    world_from_cells = world.truth.cell_to_world_matrix()
    robot_from_world = np.linalg.inv(pose_matrix(start_pose))
    map_from_cells = (
        np.linalg.inv(grid.cell_to_world_matrix()) @ robot_from_world @ world_from_cells
    )
    mapped = np.rint(cells @ map_from_cells[:2, :2].T + map_from_cells[:2, 2]).astype(np.intp)
    map_rows, map_cols = grid.shape
    inside = (
        (mapped[:, 0] >= 0)
        & (mapped[:, 0] < map_cols)
        & (mapped[:, 1] >= 0)
        & (mapped[:, 1] < map_rows)
    )
    known = np.zeros(len(cells), dtype=bool)
    known[inside] = grid.data[mapped[inside, 1], mapped[inside, 0]] >= 0
    return known.reshape(rows, cols)


def coverage(world: World, grid: OccupancyGrid, start_pose: ArrayLike) -> float:
    """Fraction of the world's explorable free space that ``grid`` has observed.

    The free space counted is :attr:`World.explorable`: the largest
    8-connected region of free truth cells, strands too thin to be space
    left out.
    """
    region = world.explorable
    total = int(np.count_nonzero(region))
    if total == 0:
        return 0.0
    known = known_in_world(world, grid, start_pose)
    return float(np.count_nonzero(known & region)) / total
