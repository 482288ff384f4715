"""Paths on known free space: an inflated planning grid and a wavefront over it.

1. The map is coarsened to the planning resolution
   (:func:`~tomosim.exploration.frontiers.coarsen`, compiled as
   :func:`~tomosim.kernels.planning.block_states`).
2. Cells closer to an occupied cell than the robot's radius plus a margin
   (:func:`~tomosim.kernels.planning.distances_to_walls`) are blocked
   (*inflation*); unknown cells are blocked too, so paths stay on space the
   robot has seen free.
3. Each passable cell costs 1 per cell crossed, plus a penalty that grows
   towards walls, so that paths keep to the middle of corridors and doors.
4. A wavefront (Dijkstra on the 8-connected grid, :class:`skimage.graph.MCP_Geometric`)
   from the robot's cell gives the cost of reaching every cell, and the
   cheapest path to any of them by back-tracking.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from skimage.graph import MCP_Geometric

from merging.grid import OCCUPIED_THRESHOLD, OccupancyGrid
from merging.validators import real_number
from tomosim.exploration.frontiers import FREE_CELL, OCCUPIED_CELL, UNKNOWN_CELL
from tomosim.kernels.planning import block_states, distances_to_walls
from tomosim.robot import ROBOT_RADIUS_M

CROP_MARGIN_CELLS = 2
"""Planning-grid cells kept around the known area when cropping the wavefront."""


@dataclass(frozen=True)
class PlannerConfig:
    """Planning parameters (metres).

    Attributes
    ----------
    resolution : float
        Planning cell size; the map's cells are merged into cells of about
        this size (a whole number of map cells).
    robot_radius : float
        Radius of the robot disc.
    inflation_margin : float
        Extra clearance beyond the radius that a path must keep from walls.
    wall_penalty_distance : float
        Cells closer than this to a wall cost more.
    wall_penalty : float
        Extra cost per cell at a wall (no clearance), falling linearly with the
        clearance to zero at ``wall_penalty_distance``: the first cell a path may
        take pays ``1 - (robot_radius + inflation_margin) / wall_penalty_distance``
        of it (0.625 with the defaults).
    free_below : int
        Map values (percent) below which a known cell counts as free for
        planning. 50, "more likely free than not", lets a robot plan on what a
        single scan showed it (one pass gives 40 %), where ``map_server``'s
        19 would need four scans.
    occupied_from : int
        Map values at or above which a cell is an obstacle.
    """

    resolution: float = 0.1
    robot_radius: float = ROBOT_RADIUS_M
    inflation_margin: float = 0.1
    wall_penalty_distance: float = 0.8
    wall_penalty: float = 4.0
    free_below: int = 50
    occupied_from: int = OCCUPIED_THRESHOLD

    def __post_init__(self) -> None:
        if not 0 < self.free_below <= self.occupied_from <= 100:
            raise ValueError(
                f"need 0 < free_below <= occupied_from <= 100, got "
                f"{self.free_below} and {self.occupied_from}"
            )
        for name in ("resolution", "robot_radius"):
            real_number(getattr(self, name), name, low=0.0, low_open=True, unit="metres")
        for name in ("inflation_margin", "wall_penalty_distance", "wall_penalty"):
            real_number(getattr(self, name), name, low=0.0)


@dataclass(frozen=True)
class PlanningGrid:
    """A coarse grid ready for planning.

    Attributes
    ----------
    state : (R, C) uint8 ndarray
        Unknown / free / occupied per :mod:`tomosim.exploration.frontiers`.
    costs : (R, C) float ndarray
        Cost per cell crossed; ``inf`` where blocked.
    clearance : (R, C) float ndarray
        Metres from each cell centre to the nearest occupied cell centre.
    cell_to_frame : (3, 3) float ndarray
        Takes planning-cell coordinates ``(x, y) = (col, row)`` to metres in
        the map's frame.
    """

    state: NDArray[np.uint8]
    costs: NDArray[np.float64]
    clearance: NDArray[np.float64]
    cell_to_frame: NDArray[np.float64]

    def to_cells(self, points: ArrayLike) -> NDArray[np.intp]:
        """``(N, 2)`` frame points (metres) to the ``(x, y)`` of their planning cells."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        inverse = np.linalg.inv(self.cell_to_frame)
        return np.rint(pts @ inverse[:2, :2].T + inverse[:2, 2]).astype(np.intp)

    def to_frame(self, cells: ArrayLike) -> NDArray[np.float64]:
        """``(N, 2)`` ``(x, y)`` planning cells to their centres in metres."""
        xy = np.asarray(cells, dtype=float).reshape(-1, 2)
        return xy @ self.cell_to_frame[:2, :2].T + self.cell_to_frame[:2, 2]

    def inside(self, cells: NDArray[np.intp]) -> NDArray[np.bool_]:
        """Which ``(x, y)`` cells lie on the grid."""
        return _inside(cells, self.state.shape)


def _inside(cells: NDArray[np.intp], shape: tuple[int, ...]) -> NDArray[np.bool_]:
    """Which ``(x, y)`` cells lie on a grid of ``shape = (rows, cols)``."""
    rows, cols = shape
    return (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)


def planning_grid(grid: OccupancyGrid, config: PlannerConfig) -> PlanningGrid:
    """Steps 1-3 of the module docstring for ``grid`` (any origin, yaw included)."""
    factor = max(1, round(config.resolution / grid.resolution))
    state = block_states(grid.data, factor, config.free_below, config.occupied_from)
    coarse = grid.resolution * factor
    fine_from_coarse = np.array(
        [[factor, 0.0, 0.5 * (factor - 1)], [0.0, factor, 0.5 * (factor - 1)], [0.0, 0.0, 1.0]]
    )
    occupied = state == OCCUPIED_CELL
    if np.any(occupied):
        # scipy.ndimage.distance_transform_edt(~occupied), compiled (the tests compare them).
        clearance = distances_to_walls(occupied) * coarse
    else:
        clearance = np.full(state.shape, np.inf)
    blocked = (state != FREE_CELL) | (clearance < config.robot_radius + config.inflation_margin)
    penalty = np.clip(1.0 - clearance / max(config.wall_penalty_distance, 1e-9), 0.0, 1.0)
    costs = 1.0 + config.wall_penalty * penalty
    costs[blocked] = np.inf
    return PlanningGrid(state, costs, clearance, grid.cell_to_world_matrix() @ fine_from_coarse)


class Wavefront:
    """Costs of reaching every planning cell from one start cell (step 4).

    The search is limited to the bounding box of the known cells (plus
    :data:`CROP_MARGIN_CELLS`), the only place a path can go. Costs are in
    planning cells (one per free cell crossed, more near walls).
    """

    __slots__ = ("_cumulative", "_mcp", "offset", "reachable", "shape", "start")

    def __init__(self, planning: PlanningGrid, start: tuple[int, int]) -> None:
        rows, cols = planning.state.shape
        x, y = start
        # The rows and columns holding a known cell: the box np.nonzero would give,
        # without listing every cell.
        known = planning.state != UNKNOWN_CELL
        known_rows = np.flatnonzero(known.any(axis=1))
        known_cols = np.flatnonzero(known.any(axis=0))
        if len(known_rows) == 0:
            known_rows, known_cols = np.array([y]), np.array([x])
        r0 = max(0, min(int(known_rows[0]), y) - CROP_MARGIN_CELLS)
        c0 = max(0, min(int(known_cols[0]), x) - CROP_MARGIN_CELLS)
        r1 = min(rows, max(int(known_rows[-1]), y) + CROP_MARGIN_CELLS + 1)
        c1 = min(cols, max(int(known_cols[-1]), x) + CROP_MARGIN_CELLS + 1)
        self.offset = (c0, r0)
        self.shape = (rows, cols)
        costs = planning.costs[r0:r1, c0:c1]
        self._mcp = MCP_Geometric(costs, fully_connected=True)
        self.start = (x - c0, y - r0)
        self.reachable = np.isfinite(costs[self.start[1], self.start[0]])
        if self.reachable:
            # skimage's minimum-cost paths index arrays: (row, col).
            cumulative, _ = self._mcp.find_costs([(self.start[1], self.start[0])])
        else:
            cumulative = np.full(costs.shape, np.inf)
        self._cumulative = cumulative

    def costs(self, cells: NDArray[np.intp]) -> NDArray[np.float64]:
        """Cost of reaching each ``(x, y)`` cell; ``inf`` if unreachable or off the crop."""
        local = cells - np.asarray(self.offset)
        inside = _inside(local, self._cumulative.shape)
        out = np.full(len(cells), np.inf)
        out[inside] = self._cumulative[local[inside, 1], local[inside, 0]]
        return out

    def path(self, cell: tuple[int, int]) -> NDArray[np.intp]:
        """``(K, 2)`` ``(x, y)`` cells from the start to ``cell``, which must be reachable."""
        x, y = cell[0] - self.offset[0], cell[1] - self.offset[1]
        if not np.isfinite(self._cumulative[y, x]):
            raise ValueError(f"cell {cell} cannot be reached from the start")
        steps = np.asarray(self._mcp.traceback((y, x)), dtype=np.intp).reshape(-1, 2)
        return steps[:, ::-1] + np.asarray(self.offset)
