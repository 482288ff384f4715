"""Team coverage of the world, kept up to date step by step, and who discovered what.

The free space counted is that of :func:`tomosim.evaluation.coverage`: the
world's explorable space (:attr:`World.explorable
<tomosim.worlds.World.explorable>`), the largest 8-connected region of free
truth cells without strands too thin to be space. A truth cell is *known* to
robot ``k`` when its centre, carried into robot ``k``'s map frame by the
robot's true start pose, falls on a known cell of its grid (the rule of
:func:`tomosim.evaluation.known_in_world`); it is known to the *team* when
some robot knows it. Coverage only grows: an observed cell never becomes
unknown again.

A step can only reveal cells within the lidar's reach of where the robot's
map puts it, so each robot's not-yet-known cells are kept in square buckets
of its map frame and a step looks only at the buckets within reach, and only
at those whose square of the grid gained known cells since they were last
looked at (known cells never become unknown, so an unchanged count means no
change). The cells
the team knows for the first time at a step are credited to the robots that
newly know them, shared equally when several do at the same step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from tomosim.frames import pose_matrix
from tomosim.team.sharing import grid_anchor
from tomosim.worlds.world import World

BUCKET_CELLS = 64
"""Side of a bucket of pending cells, in map cells (3.2 m at 0.05 m): a few dozen
buckets cover a lidar's reach, each holding few enough cells to check at once."""
REACH_MARGIN_CELLS = 3
"""Map cells beyond the lidar range that a scan may still mark (the hit cell's
depth and rounding of the ray ends)."""


class _Pending:
    """One robot's not-yet-known truth cells, bucketed by their lattice cell in its frame."""

    __slots__ = ("buckets", "counts", "lattice", "remaining")

    def __init__(self, lattice: NDArray[np.int64]) -> None:
        self.lattice = lattice
        keys = np.floor_divide(lattice, BUCKET_CELLS)
        order = np.lexsort((keys[:, 1], keys[:, 0]))
        ordered = keys[order]
        change = np.flatnonzero(np.any(np.diff(ordered, axis=0) != 0, axis=1)) + 1
        self.buckets: dict[tuple[int, int], NDArray[np.intp]] = {}
        for part in np.split(order, change):
            if len(part):
                key = keys[part[0]]
                self.buckets[(int(key[0]), int(key[1]))] = part
        self.counts: dict[tuple[int, int], int] = {}
        self.remaining = len(lattice)

    def reveal(
        self, grid: OccupancyGrid, position: NDArray[np.float64], reach: float
    ) -> NDArray[np.intp]:
        """Drop and return the pending cells ``grid`` knows, looking within ``reach`` metres."""
        res = grid.resolution
        a0, b0 = grid_anchor(grid)
        rows, cols = grid.shape
        low = np.floor((position - reach) / res).astype(int) // BUCKET_CELLS
        high = np.floor((position + reach) / res).astype(int) // BUCKET_CELLS
        found = []
        for bx in range(int(low[0]), int(high[0]) + 1):
            for by in range(int(low[1]), int(high[1]) + 1):
                cells = self.buckets.get((bx, by))
                if cells is None:
                    continue
                r0, c0 = by * BUCKET_CELLS - b0, bx * BUCKET_CELLS - a0
                block = grid.data[
                    max(r0, 0) : max(r0 + BUCKET_CELLS, 0), max(c0, 0) : max(c0 + BUCKET_CELLS, 0)
                ]
                count = int(np.count_nonzero(block >= 0))
                if self.counts.get((bx, by)) == count:
                    continue
                self.counts[(bx, by)] = count
                lattice = self.lattice[cells]
                c, r = lattice[:, 0] - a0, lattice[:, 1] - b0
                inside = (c >= 0) & (c < cols) & (r >= 0) & (r < rows)
                seen = np.zeros(len(cells), dtype=bool)
                seen[inside] = grid.data[r[inside], c[inside]] >= 0
                if np.any(seen):
                    found.append(cells[seen])
                    left = cells[~seen]
                    if len(left):
                        self.buckets[(bx, by)] = left
                    else:
                        del self.buckets[(bx, by)]
        newly = np.concatenate(found) if found else np.zeros(0, dtype=np.intp)
        self.remaining -= len(newly)
        return newly


class TeamCoverage:
    """What the team has seen of the world's free space (module docstring).

    Parameters
    ----------
    world : World
        The world and its truth grid.
    start_poses : (N, 3) array_like
        True start poses; they place each robot's map frame in the world.
    resolution : float
        Cell size of the robots' grids, metres.
    reach : float
        Metres from a robot's estimated position within which one step can
        reveal cells (its lidar's range).

    Attributes
    ----------
    region : (rows, cols) bool ndarray
        The counted free cells of ``world.truth``.
    total : int
        Number of counted cells.
    cell_area : float
        Square metres of one truth cell.
    team_known : (total,) bool ndarray
        Which counted cells (in ``np.nonzero(region)`` order) the team knows.
    """

    __slots__ = ("_pending", "_reach", "cell_area", "region", "team_known", "total")

    def __init__(
        self, world: World, start_poses: ArrayLike, *, resolution: float, reach: float
    ) -> None:
        starts = np.asarray(start_poses, dtype=float)
        if starts.ndim != 2 or starts.shape[1] != 3:
            raise ValueError(f"start_poses must have shape (N, 3), got {starts.shape}")
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive number of metres, got {resolution}")
        if not (math.isfinite(reach) and reach > 0):
            raise ValueError(f"reach must be a positive number of metres, got {reach}")
        self.region = world.explorable
        self.cell_area = world.resolution**2
        rows, cols = np.nonzero(self.region)
        self.total = len(rows)
        points = world.truth.cell_to_world(np.column_stack([cols, rows]))
        self._pending: list[_Pending] = []
        for start in starts:
            frame = np.linalg.inv(pose_matrix(start))
            local = points @ frame[:2, :2].T + frame[:2, 2]
            self._pending.append(_Pending(np.floor(local / resolution).astype(np.int64)))
        self._reach = reach + REACH_MARGIN_CELLS * resolution
        self.team_known = np.zeros(self.total, dtype=bool)

    @property
    def fraction(self) -> float:
        """Fraction of the counted free cells the team knows (0 when there are none)."""
        return float(np.count_nonzero(self.team_known)) / self.total if self.total else 0.0

    def robot_fraction(self, robot: int) -> float:
        """Fraction of the counted free cells robot ``robot`` knows."""
        return 1.0 - self._pending[robot].remaining / self.total if self.total else 0.0

    def update(self, grids: Sequence[OccupancyGrid], positions: ArrayLike) -> NDArray[np.float64]:
        """Take in the robots' grids after a step; returns the square metres each discovered.

        Parameters
        ----------
        grids : sequence of OccupancyGrid
            Each robot's grid in its map frame.
        positions : (N, 2) array_like
            Each robot's estimated position in its map frame, where its last
            scan was mapped from.

        Returns
        -------
        (N,) float ndarray
            Per robot, the area of the counted free space the team knows for
            the first time, credited as in the module docstring; the entries
            sum to the growth of the team's known area.
        """
        where = np.asarray(positions, dtype=float)
        if len(grids) != len(self._pending) or where.shape != (len(self._pending), 2):
            raise ValueError(
                f"expected {len(self._pending)} grids and positions of shape "
                f"({len(self._pending)}, 2), got {len(grids)} and {where.shape}"
            )
        fresh = []
        for pending, grid, position in zip(self._pending, grids, where, strict=True):
            newly = pending.reveal(grid, position, self._reach)
            fresh.append(newly[~self.team_known[newly]])
        finders = np.zeros(self.total, dtype=np.int32)
        for cells in fresh:
            finders[cells] += 1
        credit = np.array([float(np.sum(1.0 / finders[cells])) for cells in fresh])
        for cells in fresh:
            self.team_known[cells] = True
        return credit * self.cell_area

    def known_mask(self) -> NDArray[np.bool_]:
        """``(rows, cols)`` mask over the truth grid of the free cells the team knows."""
        mask = np.zeros(self.region.shape, dtype=bool)
        rows, cols = np.nonzero(self.region)
        mask[rows[self.team_known], cols[self.team_known]] = True
        return mask
