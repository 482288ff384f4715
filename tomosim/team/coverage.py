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

A robot's counted truth cells are indexed by the lattice cell of its map
frame they fall in (:mod:`tomosim.team.sharing` defines the lattice), so that
a map cell observed for the first time reveals exactly the truth cells under
it (:func:`tomosim.kernels.coverage.reveal_cells`): a step costs in
proportion to the cells it observed first, which :class:`~tomosim.mapping.LogOddsMap`
journals, not to the size of the grids. :meth:`TeamCoverage.update` takes
whole grids instead (any grids, at any time; it looks at every known cell).
The cells the team knows for the first time at a step are credited to the
robots that newly know them, shared equally when several do at the same step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from tomosim.frames import pose_matrix
from tomosim.kernels.coverage import reveal_cells
from tomosim.team.sharing import grid_anchor
from tomosim.worlds.world import World


class _Lookup:
    """One robot's counted truth cells, keyed by their lattice cell in its map frame."""

    __slots__ = ("count", "keys", "known", "members", "origin", "width")

    def __init__(self, lattice: NDArray[np.int64]) -> None:
        low = lattice.min(axis=0) if len(lattice) else np.zeros(2, dtype=np.int64)
        high = lattice.max(axis=0) if len(lattice) else np.zeros(2, dtype=np.int64)
        self.origin = (int(low[0]), int(low[1]))
        self.width = int(high[0] - low[0]) + 1
        keys = (lattice[:, 1] - low[1]) * self.width + (lattice[:, 0] - low[0])
        self.members = np.argsort(keys, kind="stable").astype(np.int64)
        self.keys = np.ascontiguousarray(keys[self.members], dtype=np.int64)
        self.known = np.zeros(len(lattice), dtype=bool)
        self.count = 0

    def reveal(self, cells: NDArray[np.int64]) -> NDArray[np.int64]:
        """Mark and return the truth cells under the lattice ``cells`` ``(K, 2)`` not yet known."""
        newly = reveal_cells(
            np.ascontiguousarray(cells, dtype=np.int64),
            self.origin[0],
            self.origin[1],
            self.width,
            self.keys,
            self.members,
            self.known,
        )
        self.count += len(newly)
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

    __slots__ = ("_robots", "cell_area", "region", "team_known", "total")

    def __init__(self, world: World, start_poses: ArrayLike, *, resolution: float) -> None:
        starts = np.asarray(start_poses, dtype=float)
        if starts.ndim != 2 or starts.shape[1] != 3:
            raise ValueError(f"start_poses must have shape (N, 3), got {starts.shape}")
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive number of metres, got {resolution}")
        self.region = world.explorable
        self.cell_area = world.resolution**2
        rows, cols = np.nonzero(self.region)
        self.total = len(rows)
        points = world.truth.cell_to_world(np.column_stack([cols, rows]))
        self._robots: list[_Lookup] = []
        for start in starts:
            frame = np.linalg.inv(pose_matrix(start))
            local = points @ frame[:2, :2].T + frame[:2, 2]
            self._robots.append(_Lookup(np.floor(local / resolution).astype(np.int64)))
        self.team_known = np.zeros(self.total, dtype=bool)

    @property
    def fraction(self) -> float:
        """Fraction of the counted free cells the team knows (0 when there are none)."""
        return float(np.count_nonzero(self.team_known)) / self.total if self.total else 0.0

    def robot_fraction(self, robot: int) -> float:
        """Fraction of the counted free cells robot ``robot`` knows."""
        return self._robots[robot].count / self.total if self.total else 0.0

    def update(self, grids: Sequence[OccupancyGrid]) -> NDArray[np.float64]:
        """Take in the robots' whole grids; returns the square metres each discovered.

        Parameters
        ----------
        grids : sequence of OccupancyGrid
            Each robot's grid in its map frame (on its lattice, as a
            :class:`~tomosim.mapping.LogOddsMap` exports it).

        Returns
        -------
        (N,) float ndarray
            As :meth:`reveal`.
        """
        if len(grids) != len(self._robots):
            raise ValueError(f"expected {len(self._robots)} grids, got {len(grids)}")
        cells = []
        for grid in grids:
            a0, b0 = grid_anchor(grid)
            rows, cols = np.nonzero(grid.data >= 0)
            cells.append(np.column_stack([cols + a0, rows + b0]).astype(np.int64))
        return self.reveal(cells)

    def reveal(self, cells: Sequence[ArrayLike]) -> NDArray[np.float64]:
        """Take in the map cells each robot observed for the first time since the last call.

        Parameters
        ----------
        cells : sequence of (K, 2) int array_like
            Per robot, lattice cells ``(a, b)`` of its map frame
            (:meth:`tomosim.mapping.LogOddsMap.take_journal`); cells it knew
            before may be repeated.

        Returns
        -------
        (N,) float ndarray
            Per robot, the area of the counted free space the team knows for
            the first time, credited as in the module docstring; the entries
            sum to the growth of the team's known area.
        """
        if len(cells) != len(self._robots):
            raise ValueError(f"expected cells of {len(self._robots)} robots, got {len(cells)}")
        fresh = []
        for lookup, observed in zip(self._robots, cells, strict=True):
            lattice = np.asarray(observed, dtype=np.int64).reshape(-1, 2)
            newly = lookup.reveal(lattice)
            fresh.append(newly[~self.team_known[newly]])
        finders = np.zeros(self.total, dtype=np.int32)
        for found in fresh:
            finders[found] += 1
        credit = np.array([float(np.sum(1.0 / finders[found])) for found in fresh])
        for found in fresh:
            self.team_known[found] = True
        return credit * self.cell_area

    def known_mask(self) -> NDArray[np.bool_]:
        """``(rows, cols)`` mask over the truth grid of the free cells the team knows."""
        mask = np.zeros(self.region.shape, dtype=bool)
        rows, cols = np.nonzero(self.region)
        mask[rows[self.team_known], cols[self.team_known]] = True
        return mask
