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
it (one compiled call does all robots of a step,
:func:`tomosim.kernels.reveal.reveal_team`): a step
costs in proportion to the cells it observed first, which
:class:`~tomosim.mapping.LogOddsMap` journals, not to the size of the grids.
:meth:`TeamCoverage.update` takes whole grids instead (any grids, at any time;
it looks at every known cell).
The cells the team knows for the first time at a step are credited to the
robots that newly know them, shared equally when several do at the same step.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from tomosim.frames import pose_matrix
from tomosim.kernels.reveal import first_of_keys, reveal_team
from tomosim.team.sharing import grid_anchor
from tomosim.worlds.world import World


def _moved(matrix: NDArray[Any], points: NDArray[Any]) -> NDArray[np.float64]:
    """``(N, 2)`` points moved by a 3x3 homogeneous ``matrix``, one coordinate at a time.

    Not ``points @ matrix[:2, :2].T``: on the hundreds of thousands of cells of a
    world, that product runs on numpy's BLAS threads, which then spin for about a
    tenth of a second after every reset, on the core the merge search worker (or a
    sibling environment) needs.
    """
    x, y = points[:, 0], points[:, 1]
    return np.column_stack(
        [
            x * matrix[0, 0] + y * matrix[0, 1] + matrix[0, 2],
            x * matrix[1, 0] + y * matrix[1, 1] + matrix[1, 2],
        ]
    )


def _lattice_keys(
    lattice: NDArray[np.int64],
) -> tuple[tuple[int, int], int, NDArray[np.int64], NDArray[np.int64]]:
    """One robot's counted truth cells keyed by their lattice cell in its map frame:
    the lattice origin and width of the keys, the sorted keys, and the truth cell of
    each (:func:`tomosim.kernels.reveal.reveal_team`)."""
    low = lattice.min(axis=0) if len(lattice) else np.zeros(2, dtype=np.int64)
    high = lattice.max(axis=0) if len(lattice) else np.zeros(2, dtype=np.int64)
    width = int(high[0] - low[0]) + 1
    keys = (lattice[:, 1] - low[1]) * width + (lattice[:, 0] - low[0])
    members = np.argsort(keys, kind="stable").astype(np.int64)
    return (int(low[0]), int(low[1])), width, keys[members], members


MAX_SPAN_CELLS = 20_000
"""Most robot-grid cells across a world's diagonal that the coverage count takes: its
per-robot lookup tables grow with the square of the span (a kilometre at 0.05 m, 20 000
cells, takes about 3 GB and 20 s to set up); a world past it is most likely a map saved
at a wrong resolution (a 60 x 80-cell map at 1e6 m a cell failed in numpy)."""


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
    resolution : float
        Cell size of the robots' grids it takes, metres.
    team_known : (total,) bool ndarray
        Which counted cells (in ``np.nonzero(region)`` order) the team knows.
    """

    __slots__ = (
        "_finders",
        "_keys",
        "_known",
        "_members",
        "_origins",
        "_robot_counts",
        "_table_starts",
        "_tables",
        "_team_count",
        "_widths",
        "cell_area",
        "region",
        "resolution",
        "team_known",
        "total",
    )

    def __init__(self, world: World, start_poses: ArrayLike, *, resolution: float) -> None:
        starts = np.asarray(start_poses, dtype=float)
        if starts.ndim != 2 or starts.shape[1] != 3:
            raise ValueError(f"start_poses must have shape (N, 3), got {starts.shape}")
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive number of metres, got {resolution}")
        # A robot's lattice, turned with its start, spans up to the world's diagonal.
        height, width = (side * world.resolution for side in world.truth.data.shape)
        span = math.hypot(width, height) / resolution
        if span > MAX_SPAN_CELLS:
            raise ValueError(
                f"the world is {width:g} m x {height:g} m, {span:.0f} cells across at the "
                f"robots' {resolution} m a cell, more than the coverage count takes "
                f"({MAX_SPAN_CELLS}); check the map's resolution (metres per cell)"
            )
        self.resolution = float(resolution)
        self.region = world.explorable
        self.cell_area = world.resolution**2
        rows, cols = np.nonzero(self.region)
        self.total = len(rows)
        points = _moved(world.truth.cell_to_world_matrix(), np.column_stack([cols, rows]))
        robots = len(starts)
        # Per robot, its counted truth cells keyed by lattice cell (reveal_team's arguments).
        self._origins = np.zeros((robots, 2), dtype=np.int64)
        self._widths = np.zeros(robots, dtype=np.int64)
        self._keys = np.zeros((robots, self.total), dtype=np.int64)
        self._members = np.zeros((robots, self.total), dtype=np.int64)
        tables = []
        for k, start in enumerate(starts):
            local = _moved(np.linalg.inv(pose_matrix(start)), points)
            origin, width, keys, members = _lattice_keys(
                np.floor(local / resolution).astype(np.int64)
            )
            self._origins[k] = origin
            self._widths[k] = width
            self._keys[k] = keys
            self._members[k] = members
            tables.append(first_of_keys(keys))
        self._tables = np.concatenate(tables) if tables else np.zeros(0, dtype=np.int32)
        self._table_starts = np.array(
            [0, *itertools.accumulate(len(table) for table in tables)], dtype=np.int64
        )
        self._known = np.zeros((robots, self.total), dtype=bool)
        self._robot_counts = np.zeros(robots, dtype=np.int64)
        self.team_known = np.zeros(self.total, dtype=bool)
        self._team_count = 0
        self._finders = np.zeros(self.total, dtype=np.int32)  # reveal_team's scratch

    @property
    def fraction(self) -> float:
        """Fraction of the counted free cells the team knows (0 when there are none)."""
        return self._team_count / self.total if self.total else 0.0

    def robot_fraction(self, robot: int) -> float:
        """Fraction of the counted free cells robot ``robot`` knows."""
        return int(self._robot_counts[robot]) / self.total if self.total else 0.0

    def robot_fractions(self) -> NDArray[np.float64]:
        """``(N,)`` :meth:`robot_fraction` of every robot (the same numbers; a new array)."""
        if not self.total:
            return np.zeros(len(self._robot_counts))
        return self._robot_counts / self.total

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
        if len(grids) != len(self._widths):
            raise ValueError(f"expected {len(self._widths)} grids, got {len(grids)}")
        cells = []
        for k, grid in enumerate(grids):
            if not math.isclose(grid.resolution, self.resolution, rel_tol=1e-9):
                raise ValueError(
                    f"grid {k} is at {grid.resolution} m a cell, but this coverage counts "
                    f"cells of {self.resolution} m; make it with the grids' resolution"
                )
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
        robots = len(self._widths)
        if len(cells) != robots:
            raise ValueError(f"expected cells of {robots} robots, got {len(cells)}")
        lattices = [np.asarray(observed, dtype=np.int64).reshape(-1, 2) for observed in cells]
        starts = np.array([0, *itertools.accumulate(len(lattice) for lattice in lattices)])
        found_starts = np.empty(robots + 1, dtype=np.int64)
        credit = np.empty(robots)
        found, newly, shared = reveal_team(
            np.ascontiguousarray(np.concatenate(lattices)),
            starts,
            self._origins,
            self._widths,
            self._keys,
            self._members,
            self._tables,
            self._table_starts,
            self._known,
            self._robot_counts,
            self.team_known,
            self._finders,
            found_starts,
            credit,
            self.cell_area,
        )
        self._team_count += newly
        if not shared:  # every cell has one finder: credit is the count, exactly
            return credit
        fresh = [found[found_starts[k] : found_starts[k + 1]] for k in range(robots)]
        finders = np.zeros(self.total, dtype=np.int32)
        for found_k in fresh:
            finders[found_k] += 1
        shares = np.array([float(np.sum(1.0 / finders[found_k])) for found_k in fresh])
        return shares * self.cell_area

    def known_mask(self) -> NDArray[np.bool_]:
        """``(rows, cols)`` mask over the truth grid of the free cells the team knows."""
        mask = np.zeros(self.region.shape, dtype=bool)
        rows, cols = np.nonzero(self.region)
        mask[rows[self.team_known], cols[self.team_known]] = True
        return mask
