"""Fusing occupancy grids once the transforms between them are known.

:func:`merge` lays map 2 over map 1 through a map transformation matrix (eq. 1
of the paper); :func:`fuse` does the same for any number of grids. Finding
the transforms between N robots' grids is :mod:`merging.linking`'s job.

The conflict rule
-----------------
Where the grids overlap, the fused cell is the **maximum** of the values in
the ROS coding (-1 unknown, 0..100 percent occupied):

* known beats unknown (every known value exceeds -1);
* where both are known, the more occupied value wins, so occupied beats free:
  a robot must not plan through a wall that either robot saw.

Evidence fusion (adding log-odds) would instead let one robot's free
observation cancel the other's wall, leaving a cell in between that a planner
treats as passable; it also double-counts the many cells that both maps
share. The maximum is commutative and associative, so fusing N grids gives
the same map in any order, which makes the result of :func:`merge_all`
independent of the order :func:`merging.linking.forest.merge_all` walks its tree in.

The fused grid's cells are the reference grid's (map 1's) cells shifted by a
whole number of cells, so that the canvas holds every input's observed cells
and nothing more (the inputs' unknown borders are left out):
``offset`` takes the reference's cells to the fused grid's cells, and the
fused :class:`~merging.grid.OccupancyGrid`'s origin is moved so that each of
the reference's cells keeps its place in metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import UNKNOWN, OccupancyGrid, observed_part, validate_cells
from merging.resample import to_resolution
from merging.transforms import apply_transform, checked_transform
from merging.warp import warp_cells

EDGE_TOLERANCE = 1e-6
"""Cells. A cell centre this close outside a transformed map's edge still counts
as inside, so that rounding in rotation matrices (``cos(pi/2) = 6e-17``) can
neither drop a row of the canvas nor add an empty one."""
MAX_CELL_COORDINATE = 2.0**62
"""Farthest a map may be laid from the common frame's zero, in cells: the fused grid's
corners are integers of 64 bits."""
MAX_FUSED_CELLS = 50_000_000
"""Largest fused canvas, in cells (about 7000 x 7000, a few gigabytes of warping
work); a wrong transform with a huge translation must fail, not exhaust memory."""


@dataclass(frozen=True, slots=True)
class FusedMap:
    """A fused grid and how each input lies in it.

    Attributes
    ----------
    cells : (rows, cols) int8 ndarray
        The fused grid in the ROS coding.
    offset : (3, 3) float ndarray
        Pure translation by whole cells taking the reference grid's cells
        (map 1's for :func:`merge`) to the fused grid's cells.
    to_fused : tuple of (3, 3) float ndarray or None
        Per input, in input order, the matrix taking its cells to the fused
        grid's cells; None for an input that was left out.
    grid : OccupancyGrid or None
        ``cells`` with the reference grid's resolution and an origin moved by
        ``offset``, when the reference was an :class:`OccupancyGrid`.
    """

    cells: NDArray[np.int8]
    offset: NDArray[np.float64]
    to_fused: tuple[NDArray[np.float64] | None, ...]
    grid: OccupancyGrid | None = None


def combine(first: NDArray[np.int8], second: NDArray[np.int8]) -> NDArray[np.int8]:
    """The conflict rule: the cell-wise maximum (see the module docstring)."""
    return np.maximum(first, second)


def _translation(dx: float, dy: float) -> NDArray[np.float64]:
    """The 3x3 homogeneous translation by ``(dx, dy)`` cells."""
    return np.array([[1.0, 0.0, dx], [0.0, 1.0, dy], [0.0, 0.0, 1.0]])


def _cell_box(shape: tuple[int, int], matrix: NDArray[np.float64]) -> NDArray[np.int64]:
    """Range of target cells ``[[x_lo, y_lo], [x_hi, y_hi]]`` (inclusive) a warped grid can fill.

    A grid of ``shape`` covers ``[-0.5, cols - 0.5] x [-0.5, rows - 0.5]`` in its
    own cell coordinates (cell centres at integers); the box holds every target
    cell whose centre falls in the bounding box of that rectangle's image.
    """
    rows, cols = shape
    corners = np.array(
        [[-0.5, -0.5], [cols - 0.5, -0.5], [-0.5, rows - 0.5], [cols - 0.5, rows - 0.5]]
    )
    moved = apply_transform(matrix, corners)
    low = np.ceil(moved.min(axis=0) - EDGE_TOLERANCE)
    high = np.floor(moved.max(axis=0) + EDGE_TOLERANCE)
    return np.array([low, high]).astype(np.int64)


def fuse(
    maps: Sequence[OccupancyGrid | NDArray[Any]],
    matrices: Sequence[ArrayLike | None],
    *,
    frame: OccupancyGrid | None = None,
    names: Sequence[tuple[str, str]] | None = None,
) -> FusedMap:
    """Fuse grids whose transforms into one common cell frame are known.

    Parameters
    ----------
    maps : sequence of OccupancyGrid or (rows, cols) array
        Grids in the ROS coding.
    matrices : sequence of (3, 3) array_like or None
        Per map, the affine matrix taking its cells ``(x, y) = (col, row)``
        to the common frame's cells; None leaves the map out.
    frame : OccupancyGrid, optional
        The grid whose cells the common frame is; it gives the fused grid its
        resolution and (shifted) origin. An OccupancyGrid in ``maps`` of
        another resolution needs a matrix that scales by the ratio of the
        resolutions (as :func:`merging.estimate_transform` gives); a finer
        one is coarsened to the frame's resolution before it is laid in.
    names : sequence of (str, str), optional
        Per map, how error messages call it and its matrix (by default
        ``maps[k]`` and ``matrices[k]``).

    Returns
    -------
    FusedMap
        ``offset`` takes the common frame's cells to the fused grid's.
    """
    if len(maps) != len(matrices):
        raise ValueError(f"got {len(maps)} maps but {len(matrices)} matrices; give one per map")
    if frame is not None and not isinstance(frame, OccupancyGrid):
        raise TypeError(f"frame must be an OccupancyGrid or None, got {type(frame).__name__}")
    called = list(names) if names is not None else []
    if len(called) > len(maps) or not all(
        isinstance(pair, tuple) and len(pair) == 2 and all(isinstance(n, str) for n in pair)
        for pair in called
    ):
        raise ValueError(
            f"names must hold at most one (map name, matrix name) pair of strings per map, "
            f"got {names!r}"
        )
    called += [(f"maps[{k}]", f"matrices[{k}]") for k in range(len(called), len(maps))]
    moves = {
        k: checked_transform(m, name=called[k][1]) for k, m in enumerate(matrices) if m is not None
    }
    if not moves:
        raise ValueError("no map to fuse: every matrix is None")
    used = sorted(moves)
    given = dict(moves)  # each map's own cells -> the frame's, for to_fused
    cells = {k: validate_cells(maps[k], name=called[k][0]) for k in used}
    if frame is not None:
        for k in used:
            item = maps[k]
            if isinstance(item, OccupancyGrid):
                cells[k], moves[k] = _at_frame_resolution(
                    item, moves[k], frame, name=called[k][0], matrix_name=called[k][1]
                )
    seen = [k for k in used if np.any(cells[k] >= 0)]
    if seen:
        # Only what was observed is laid in: unknown borders of the inputs' canvases,
        # and inputs with nothing observed, would only widen the fused grid.
        used = seen
        for k in used:
            cells[k], corner = observed_part(cells[k])
            moves[k] = moves[k] @ _translation(float(corner[0]), float(corner[1]))
    for k in used:
        # Past 2**62 cells the boxes' integers would wrap and slip past the size check.
        if not np.all(np.abs(moves[k][:2, 2]) < MAX_CELL_COORDINATE):
            raise ValueError(
                f"{called[k][1]} lays {called[k][0]} {np.abs(moves[k][:2, 2]).max():.3g} cells "
                "from the frame's zero, too far to fuse; check the transforms, their "
                "translations look too large"
            )
    boxes = {k: _cell_box(cells[k].shape, moves[k]) for k in used}
    low = np.min([b[0] for b in boxes.values()], axis=0)
    high = np.max([b[1] for b in boxes.values()], axis=0)
    cols, rows = (high - low + 1).tolist()
    if rows * cols > MAX_FUSED_CELLS:
        raise ValueError(
            f"the fused grid would be {rows} x {cols} cells (limit {MAX_FUSED_CELLS}) to hold "
            "every map's observed cells; check the transforms, their translations look too "
            "large (or fuse fewer or smaller maps)"
        )
    offset = _translation(-float(low[0]), -float(low[1]))
    canvas = np.full((rows, cols), UNKNOWN, dtype=np.int8)
    for k in used:
        (x0, y0), (x1, y1) = (boxes[k] - low).tolist()
        into_box = _translation(-float(x0), -float(y0)) @ offset @ moves[k]
        warped = warp_cells(cells[k], into_box, (y1 - y0 + 1, x1 - x0 + 1))
        window = canvas[y0 : y1 + 1, x0 : x1 + 1]
        window[...] = combine(window, warped)
    to_fused = tuple(offset @ given[k] if k in given else None for k in range(len(maps)))
    fused_grid = None
    if frame is not None:
        ox, oy, yaw = frame.origin
        shift = frame.resolution * np.array(
            [
                np.cos(yaw) * low[0] - np.sin(yaw) * low[1],
                np.sin(yaw) * low[0] + np.cos(yaw) * low[1],
            ]
        )
        origin = (ox + float(shift[0]), oy + float(shift[1]), yaw)
        fused_grid = OccupancyGrid(canvas, resolution=frame.resolution, origin=origin)
    return FusedMap(cells=canvas, offset=offset, to_fused=to_fused, grid=fused_grid)


SCALE_TOLERANCE = 0.01
"""Relative difference allowed between a matrix's scale and the ratio of two grids'
resolutions: estimated similarity transforms are not exact."""


def _at_frame_resolution(
    grid: OccupancyGrid,
    matrix: NDArray[np.float64],
    frame: OccupancyGrid,
    *,
    name: str,
    matrix_name: str,
) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
    """The grid's cells and matrix ready to warp into ``frame``'s cells.

    A grid of another resolution than the frame's must come with a matrix
    that scales by the ratio (as :func:`merging.estimate_transform` returns
    it); a finer grid is first coarsened to the frame's resolution
    (:func:`merging.resample.to_resolution`), so that warping it keeps its
    thin walls.
    """
    ratio = grid.resolution / frame.resolution
    scale = float(np.sqrt(abs(np.linalg.det(matrix[:2, :2]))))
    if abs(scale - ratio) > SCALE_TOLERANCE * ratio:
        raise ValueError(
            f"{name} has resolution {grid.resolution} m and the frame {frame.resolution} m, "
            f"so {matrix_name} must scale by {ratio:.4g}, but it scales by {scale:.4g}; "
            "use the matrix merging.estimate_transform returns for the two grids"
        )
    if ratio >= 1.0 - SCALE_TOLERANCE:
        return grid.data, matrix
    coarse, to_coarse = to_resolution(grid, frame.resolution)
    return coarse.data, matrix @ np.linalg.inv(to_coarse)


def merge(
    map1: OccupancyGrid | NDArray[Any],
    map2: OccupancyGrid | NDArray[Any],
    matrix: ArrayLike,
) -> FusedMap:
    """One grid holding both maps, map 2 carried into map 1's frame.

    Parameters
    ----------
    map1, map2 : OccupancyGrid or (rows, cols) array
        Grids in the ROS coding (-1 unknown, 0..100).
    matrix : (3, 3) array_like
        Map transformation matrix of eq. (1): map 2 cells -> map 1 cells
        (``MergeResult.matrix``).

    Returns
    -------
    FusedMap
        ``offset`` takes map 1's cells to the fused cells and
        ``to_fused == (offset, offset @ matrix)``. The canvas is the box of
        both maps' observed cells (their unknown borders are left out), so
        it grows in any direction map 2 sticks out; conflicting cells combine by
        :func:`combine` (known beats unknown, occupied beats free). When
        ``map1`` is an OccupancyGrid, ``grid`` keeps its resolution and its
        cells' places in metres.

    References
    ----------
    .. [1] H. Lee, "Tomographic Feature-Based Map Merging for Multi-Robot
       Systems", Electronics 2020, 9(1), 107.
    """
    if matrix is None:  # fuse() reads None as "leave this map out"
        raise TypeError(
            "matrix is None: map 2 has no transform to map 1 (a refused or unlinked pair); "
            "merge only pairs with a (3, 3) matrix, or use fuse() to leave maps out"
        )
    frame = map1 if isinstance(map1, OccupancyGrid) else None
    names = [("map1", "the identity"), ("map2", "matrix")]
    return fuse([map1, map2], [np.eye(3), matrix], frame=frame, names=names)
