"""Each robot's best map: its own grid, completed from its linked teammates' grids.

After a merge round links robot ``i``'s map to teammates' maps (through
accepted estimates only), robot ``i``'s *best map* is, in its own map frame,

* its own grid as it is now, combined with
* a *teammate layer*: every linked teammate's grid carried into robot ``i``'s
  frame by the round's transform, rebuilt after each merge round and every
  ``refresh_interval`` steps (teammates share their maps at that rate).

Where the robot's own grid knows a cell, its own value is kept; teammates fill
in only the cells it has not observed (where several teammates know a cell,
the fusion rule of :mod:`merging.linking.fusion` combines them: known beats unknown,
occupied beats free). Own knowledge comes first because it is in the robot's
own frame exactly, while teammates' grids arrive through estimated transforms
and odometry drift of a few decimetres, and because teammates map each other:
robots see one another as obstacles, and a teammate's map remembers a robot
where it once stood. Laid over the robot's own free space with the maximum,
those blobs and misaligned walls closed corridors and doors to the planner
(on ``aces3``, a robot found no reachable frontier left and stopped). A robot
that is linked to nobody has its own grid as its best map.

Limited communication
---------------------
With a communication range (:mod:`tomosim.team.comms`), ``reach`` labels
tell who can talk at a step. A robot then takes in a linked teammate's grid,
when its layer is rebuilt, only if it reaches the teammate at that step, and
keeps the last one it received otherwise; and a link to a teammate it does
not reach when a merge round runs is kept from the earlier round (that round
could not see both maps, so it has nothing new to say about the pair).
Without ``reach`` every robot reaches every other, and the received grids are
the current ones.

Cell lattice
------------
Every robot's grid (:class:`~tomosim.mapping.LogOddsMap`) has yaw 0 and an
origin a whole number of cells from its frame's origin, so all of one robot's
grids, and its teammate layer, share one lattice: lattice cell ``(a, b)``
covers ``[a r, (a + 1) r) x [b r, (b + 1) r)`` metres of the robot's frame
(``r`` the resolution). Arrays are placed on it by the lattice index of their
cell ``(0, 0)``, their *anchor*.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import UNKNOWN, OccupancyGrid
from merging.validators import whole_number
from merging.warp import warp_cells
from tomosim.kernels.crop import crop_max_pool
from tomosim.team.merger import TeamMerge

ANCHOR_TOLERANCE = 1e-6
"""Cells: largest distance of a grid origin from the lattice still taken as on it
(origins are sums of whole cells in metres, so only rounding separates them)."""


NO_LAYER = np.zeros((0, 0), dtype=np.int8)
"""The teammate layer of a robot that has none, as the crop kernel takes it."""
EDGE_TOLERANCE = 1e-6
"""Cells: a cell centre this close outside a carried grid's outline still counts as
inside, so that rounding in rotation matrices cannot drop a row of the layer."""


def grid_anchor(grid: OccupancyGrid) -> tuple[int, int]:
    """Lattice index ``(a, b)`` of ``grid``'s cell ``(0, 0)`` (module docstring).

    Raises
    ------
    ValueError
        If the grid is rotated or its origin lies off the lattice.
    """
    ox, oy, yaw = grid.origin
    res = grid.resolution
    a, b = ox / res, oy / res
    if (
        abs(math.remainder(yaw, 2 * math.pi)) > ANCHOR_TOLERANCE
        or max(abs(a - round(a)), abs(b - round(b))) > ANCHOR_TOLERANCE
    ):
        raise ValueError(
            f"grid origin {grid.origin} is not a whole number of {res} m cells at yaw 0; "
            "best maps need the robots' own (LogOddsMap) grids"
        )
    return round(a), round(b)


def window(
    cells: NDArray[np.int8], anchor: tuple[int, int], start: tuple[int, int], shape: tuple[int, int]
) -> NDArray[np.int8]:
    """Lattice cells ``start + [0, shape)`` of an anchored array, unknown where it has none.

    ``start`` is ``(a, b)``; ``shape`` is ``(rows, cols)``.
    """
    out = np.full(shape, UNKNOWN, dtype=np.int8)
    rows, cols = cells.shape
    c0, r0 = start[0] - anchor[0], start[1] - anchor[1]
    src_c = slice(max(c0, 0), min(c0 + shape[1], cols))
    src_r = slice(max(r0, 0), min(r0 + shape[0], rows))
    if src_c.start >= src_c.stop or src_r.start >= src_r.stop:
        return out
    rows_out = slice(src_r.start - r0, src_r.stop - r0)
    cols_out = slice(src_c.start - c0, src_c.stop - c0)
    out[rows_out, cols_out] = cells[src_r, src_c]
    return out


def known_box(cells: NDArray[np.int8]) -> tuple[slice, slice] | None:
    """``(rows, cols)`` slices of the smallest box holding every known cell (None if none)."""
    known = cells >= 0
    rows = np.flatnonzero(known.any(axis=1))
    if len(rows) == 0:
        return None
    cols = np.flatnonzero(known.any(axis=0))
    return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)


def teammate_layer(
    grids: Sequence[OccupancyGrid], into_robot: Sequence[NDArray[np.float64]], resolution: float
) -> tuple[NDArray[np.int8], tuple[int, int]] | None:
    """Teammates' grids carried onto a robot's lattice, fused; with the layer's anchor.

    Parameters
    ----------
    grids : sequence of OccupancyGrid
        The teammates' grids, each in its own map frame.
    into_robot : sequence of (3, 3) float ndarray
        Per grid, the rigid matrix taking its map frame to the robot's (metres).
    resolution : float
        The robot's cell size, metres.

    Returns
    -------
    (cells, anchor) or None
        None when no teammate knows any cell.
    """
    lattice_from_frame = np.array(
        [[1 / resolution, 0.0, -0.5], [0.0, 1 / resolution, -0.5], [0.0, 0.0, 1.0]]
    )
    pieces = []
    for grid, matrix in zip(grids, into_robot, strict=True):
        box = known_box(grid.data)
        if box is None:
            continue
        rows, cols = box
        shift = np.array([[1.0, 0.0, cols.start], [0.0, 1.0, rows.start], [0.0, 0.0, 1.0]])
        to_lattice = lattice_from_frame @ matrix @ grid.cell_to_world_matrix() @ shift
        data = grid.data[rows, cols]
        h, w = data.shape
        corners = np.array([[-0.5, -0.5, 1], [w - 0.5, -0.5, 1], [-0.5, h - 0.5, 1]], float)
        corners = np.vstack([corners, [w - 0.5, h - 0.5, 1]]) @ to_lattice.T
        pieces.append((data, to_lattice, corners[:, :2]))
    if not pieces:
        return None
    every = np.vstack([corners for _, _, corners in pieces])
    low = np.ceil(every.min(axis=0) - EDGE_TOLERANCE).astype(int)
    high = np.floor(every.max(axis=0) + EDGE_TOLERANCE).astype(int)
    anchor = (int(low[0]), int(low[1]))
    shape = (int(high[1] - low[1]) + 1, int(high[0] - low[0]) + 1)
    layer = np.full(shape, UNKNOWN, dtype=np.int8)
    into_layer = np.array([[1.0, 0.0, -anchor[0]], [0.0, 1.0, -anchor[1]], [0.0, 0.0, 1.0]])
    for data, to_lattice, _ in pieces:
        warped = warp_cells(data, into_layer @ to_lattice, shape)
        np.maximum(layer, warped, out=layer)
    return layer, anchor


class SharedMaps:
    """Each robot's best map in its own frame (module docstring).

    Parameters
    ----------
    count : int
        Number of robots.
    refresh_interval : int
        Steps between rebuilds of a linked robot's teammate layer (a team's
        ``TeamConfig.share_interval``).
    """

    __slots__ = ("_layers", "_links", "_received", "_refreshed", "count", "refresh_interval")

    def __init__(self, count: int, *, refresh_interval: int) -> None:
        self.count = whole_number(count, "count", minimum=1, unit="robots")
        self.refresh_interval = whole_number(
            refresh_interval, "refresh_interval", minimum=1, unit="steps"
        )
        self._links: list[dict[int, NDArray[np.float64]]] = [{} for _ in range(count)]
        self._layers: list[tuple[NDArray[np.int8], tuple[int, int]] | None] = [None] * count
        self._refreshed: list[int | None] = [None] * count
        self._received: list[dict[int, OccupancyGrid]] = [{} for _ in range(count)]

    def link(self, merge: TeamMerge | None, *, reach: ArrayLike | None = None) -> None:
        """Adopt the links of a merge round (None: every robot alone); layers are rebuilt
        at the next :meth:`refresh`.

        ``reach`` (per robot, its communication group's label at the round) keeps a
        robot's earlier links to the teammates it does not reach (module docstring).
        """
        labels = None if reach is None else np.asarray(reach)
        for robot in range(self.count):
            links: dict[int, NDArray[np.float64]] = {}
            if merge is not None:
                for other in range(self.count):
                    matrix = merge.relative(robot, other) if other != robot else None
                    if matrix is not None:
                        links[other] = matrix
            if labels is not None:
                for other, matrix in self._links[robot].items():
                    if other not in links and labels[other] != labels[robot]:
                        links[other] = matrix
            self.set_links(robot, links)

    def set_links(self, robot: int, into_robot: Mapping[int, ArrayLike]) -> None:
        """Link ``robot`` to teammates: ``into_robot[k]`` takes robot ``k``'s map frame to
        ``robot``'s (3x3, metres). Replaces its links; its layer is rebuilt at the next
        :meth:`refresh`."""
        links = {}
        for other, matrix in into_robot.items():
            if other == robot or not 0 <= other < self.count:
                raise ValueError(f"robot {robot} cannot link to robot {other} of {self.count}")
            values = np.asarray(matrix, dtype=np.float64)
            if values.shape != (3, 3) or not np.all(np.isfinite(values)):
                raise ValueError(f"the matrix into robot {robot} must be finite 3x3")
            links[int(other)] = values
        self._links[robot] = links
        self._layers[robot] = None
        self._refreshed[robot] = None
        self._received[robot] = {k: g for k, g in self._received[robot].items() if k in links}

    def teammates(self, robot: int) -> tuple[int, ...]:
        """Robots whose maps robot ``robot`` sees in its best map."""
        return tuple(sorted(self._links[robot]))

    def links(self, robot: int) -> dict[int, NDArray[np.float64]]:
        """Per teammate robot ``robot`` is linked to, the matrix taking the teammate's map
        frame to robot ``robot``'s (metres); a new dict each call."""
        return {other: matrix.copy() for other, matrix in self._links[robot].items()}

    def due(self, step: int) -> bool:
        """Whether :meth:`refresh` at ``step`` would rebuild some robot's layer."""
        return any(
            links and (last is None or step - last >= self.refresh_interval)
            for links, last in zip(self._links, self._refreshed, strict=True)
        )

    def refresh(
        self, step: int, grids: Sequence[OccupancyGrid], *, reach: ArrayLike | None = None
    ) -> None:
        """Rebuild the teammate layers that are due at ``step``: each such robot takes in the
        current ``grids`` of the linked teammates it reaches (all, without ``reach``) and
        builds its layer from the grids it has received."""
        labels = None if reach is None else np.asarray(reach)
        for robot in range(self.count):
            links = self._links[robot]
            last = self._refreshed[robot]
            if not links or (last is not None and step - last < self.refresh_interval):
                continue
            received = self._received[robot]
            for other in links:
                if labels is None or labels[other] == labels[robot]:
                    received[other] = grids[other]
            others = sorted(k for k in links if k in received)
            self._layers[robot] = teammate_layer(
                [received[k] for k in others], [links[k] for k in others], grids[robot].resolution
            )
            self._refreshed[robot] = step

    def best_grid(self, robot: int, grids: Sequence[OccupancyGrid]) -> OccupancyGrid:
        """Robot ``robot``'s best map as a grid in its own frame (yaw 0, on its lattice)."""
        own = grids[robot]
        layer = self._layers[robot]
        if layer is None:
            return own
        cells, anchor = layer
        own_anchor = grid_anchor(own)
        rows, cols = own.shape
        low = (min(anchor[0], own_anchor[0]), min(anchor[1], own_anchor[1]))
        high = (
            max(anchor[0] + cells.shape[1], own_anchor[0] + cols),
            max(anchor[1] + cells.shape[0], own_anchor[1] + rows),
        )
        out = window(cells, anchor, low, (high[1] - low[1], high[0] - low[0]))
        c0, r0 = own_anchor[0] - low[0], own_anchor[1] - low[1]
        target = out[r0 : r0 + rows, c0 : c0 + cols]
        np.copyto(target, own.data, where=own.data >= 0)
        res = own.resolution
        return OccupancyGrid(out, resolution=res, origin=(low[0] * res, low[1] * res, 0.0))

    def crop(
        self,
        robot: int,
        grids: Sequence[OccupancyGrid],
        centre: ArrayLike,
        *,
        size: int,
        pool: int,
    ) -> NDArray[np.int8]:
        """A ``(size, size)`` window of the best map around ``centre``, ``pool`` cells per cell.

        The window is aligned with the robot's map frame (not with its
        heading); row 0 is its lowest ``y``, like the grids. Own cells come
        before teammates' (module docstring). Each output cell
        is the maximum of the ``pool x pool`` map cells it covers (known beats
        unknown, occupied beats free), so thin walls survive the coarsening.
        The robot's cell is output cell ``(size // 2, size // 2)``.
        """
        own = grids[robot]
        return self.crop_cells(
            robot, own.data, grid_anchor(own), own.resolution, centre, size=size, pool=pool
        )

    def crop_cells(
        self,
        robot: int,
        cells: NDArray[np.int8],
        anchor: tuple[int, int],
        resolution: float,
        centre: ArrayLike,
        *,
        size: int,
        pool: int,
    ) -> NDArray[np.int8]:
        """:meth:`crop` of the robot's own cells given as an array on its lattice, its
        cell ``(0, 0)`` at lattice ``anchor`` (no grid needed: a live map's cells will do)."""
        x, y = (float(v) for v in np.asarray(centre, dtype=float)[:2])
        fine = size * pool
        start = (math.floor(x / resolution) - fine // 2, math.floor(y / resolution) - fine // 2)
        layer = self._layers[robot]
        mates, mates_anchor = layer if layer is not None else (NO_LAYER, (0, 0))
        return crop_max_pool(
            cells,
            anchor[0],
            anchor[1],
            mates,
            mates_anchor[0],
            mates_anchor[1],
            start[0],
            start[1],
            size,
            pool,
        )
