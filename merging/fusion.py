"""Fusing occupancy grids once the transforms between them are known.

:func:`merge` lays map 2 over map 1 through a map transformation matrix (eq. 1
of the paper); :func:`fuse` does the same for any number of grids;
:func:`merge_all` estimates the transforms between N robots' grids, links them
by a maximum spanning tree of confident pairwise merges, and fuses them.

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
independent of the order the spanning tree is walked in.

The fused grid's cells are the reference grid's (map 1's) cells shifted by a
whole number of cells, so that the canvas grows in every direction as needed:
``offset`` takes the reference's cells to the fused grid's cells, and the
fused :class:`~merging.grid.OccupancyGrid`'s origin is moved so that each of
the reference's cells keeps its place in metres.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.api import DEFAULT_METHOD, RngLike, available_methods, estimate_transform
from merging.grid import UNKNOWN, OccupancyGrid, validate_cells
from merging.result import MergeResult
from merging.transforms import apply_transform, matrix_to_pose, wrap_angle
from merging.warp import warp_cells

EDGE_TOLERANCE = 1e-6
"""Cells. A cell centre this close outside a transformed map's edge still counts
as inside, so that rounding in rotation matrices (``cos(pi/2) = 6e-17``) can
neither drop a row of the canvas nor add an empty one."""
AFFINE_TOLERANCE = 1e-9
"""Largest deviation of a matrix's last row from ``[0, 0, 1]`` that is taken as
rounding; a larger one is a projective matrix, which grids cannot be warped by."""
MAX_FUSED_CELLS = 50_000_000
"""Largest fused canvas, in cells (about 7000 x 7000, a few gigabytes of warping
work); a wrong transform with a huge translation must fail, not exhaust memory."""
CONSISTENCY_TOLERANCE = 2.0
"""Cells RMS. An accepted pair that the spanning tree does not use is reported
when the tree's transform moves the grid's corners by more than this from the
pair's own estimate; 2 cells is the accuracy the merger is held to."""


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


def _check_affine(matrix: ArrayLike, *, name: str = "matrix") -> NDArray[np.float64]:
    """Return ``matrix`` as a finite, invertible 3x3 affine float matrix, or raise ValueError."""
    m = np.asarray(matrix, dtype=float)
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be a finite 3x3 array, got shape {m.shape}")
    if np.max(np.abs(m[2] - (0.0, 0.0, 1.0))) > AFFINE_TOLERANCE:
        raise ValueError(f"{name} must be affine with last row [0, 0, 1], got {m[2].tolist()}")
    if abs(np.linalg.det(m[:2, :2])) < AFFINE_TOLERANCE:
        raise ValueError(f"{name} is singular (determinant {np.linalg.det(m[:2, :2]):.3g})")
    return m


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
        resolution and (shifted) origin. Every OccupancyGrid in ``maps`` must
        have its resolution.

    Returns
    -------
    FusedMap
        ``offset`` takes the common frame's cells to the fused grid's.
    """
    if len(maps) != len(matrices):
        raise ValueError(f"got {len(maps)} maps but {len(matrices)} matrices; give one per map")
    if frame is not None and not isinstance(frame, OccupancyGrid):
        raise TypeError(f"frame must be an OccupancyGrid or None, got {type(frame).__name__}")
    moves = {
        k: _check_affine(m, name=f"matrices[{k}]") for k, m in enumerate(matrices) if m is not None
    }
    if not moves:
        raise ValueError("no map to fuse: every matrix is None")
    used = sorted(moves)
    cells = {k: validate_cells(maps[k], name=f"maps[{k}]") for k in used}
    if frame is not None:
        for k in used:
            item = maps[k]
            if isinstance(item, OccupancyGrid) and not np.isclose(
                item.resolution, frame.resolution
            ):
                raise ValueError(
                    f"maps[{k}] has resolution {item.resolution} m but the frame has "
                    f"{frame.resolution} m; resample it first"
                )
    boxes = {k: _cell_box(cells[k].shape, moves[k]) for k in used}
    low = np.min([b[0] for b in boxes.values()], axis=0)
    high = np.max([b[1] for b in boxes.values()], axis=0)
    cols, rows = (high - low + 1).tolist()
    if rows * cols > MAX_FUSED_CELLS:
        raise ValueError(
            f"the fused grid would be {rows} x {cols} cells (limit {MAX_FUSED_CELLS}); "
            "check the transforms, their translations look too large"
        )
    offset = _translation(-float(low[0]), -float(low[1]))
    canvas = np.full((rows, cols), UNKNOWN, dtype=np.int8)
    for k in used:
        (x0, y0), (x1, y1) = (boxes[k] - low).tolist()
        into_box = _translation(-float(x0), -float(y0)) @ offset @ moves[k]
        warped = warp_cells(cells[k], into_box, (y1 - y0 + 1, x1 - x0 + 1))
        window = canvas[y0 : y1 + 1, x0 : x1 + 1]
        window[...] = combine(window, warped)
    to_fused = tuple(offset @ moves[k] if k in moves else None for k in range(len(maps)))
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
        ``to_fused == (offset, offset @ matrix)``. The canvas grows in any
        direction map 2 sticks out; conflicting cells combine by
        :func:`combine` (known beats unknown, occupied beats free). When
        ``map1`` is an OccupancyGrid, ``grid`` keeps its resolution and its
        cells' places in metres.

    References
    ----------
    .. [1] H. Lee, "Tomographic Feature-Based Map Merging for Multi-Robot
       Systems", Electronics 2020, 9(1), 107.
    """
    frame = map1 if isinstance(map1, OccupancyGrid) else None
    return fuse([map1, map2], [np.eye(3), matrix], frame=frame)


@dataclass(frozen=True, slots=True)
class MergeAllResult:
    """What :func:`merge_all` returns.

    Attributes
    ----------
    fused : FusedMap
        The linked grids fused in the reference grid's frame.
    reference : int
        Index of the grid whose cell frame the transforms point into.
    transforms : tuple of (3, 3) float ndarray or None
        Per grid, the matrix taking its cells to the reference's cells; None
        for a grid that is not linked to the reference.
    pairs : dict
        ``(i, j) -> MergeResult`` for every ``i < j``; its matrix takes grid
        ``j``'s cells to grid ``i``'s. Use :meth:`pair` for either order.
    tree : tuple of (int, int)
        The accepted pairs the spanning forest uses, most confident first.
    unlinked : tuple of int
        Grids not linked to the reference, left out of ``fused``.
    notes : tuple of str
        One line each: how the reference was chosen when it is not grid 0,
        why each unlinked grid is unlinked, accepted pairs the tree disagrees with.
    """

    fused: FusedMap
    reference: int
    transforms: tuple[NDArray[np.float64] | None, ...]
    pairs: dict[tuple[int, int], MergeResult]
    tree: tuple[tuple[int, int], ...]
    unlinked: tuple[int, ...]
    notes: tuple[str, ...]

    def pair(self, i: int, j: int) -> MergeResult:
        """The pairwise result whose matrix takes grid ``j``'s cells to grid ``i``'s."""
        if (i, j) in self.pairs:
            return self.pairs[(i, j)]
        if (j, i) not in self.pairs:
            raise KeyError(f"no pair ({i}, {j}); grids are numbered 0..{len(self.transforms) - 1}")
        forward = self.pairs[(j, i)]
        metres = forward.matrix_metres
        return replace(
            forward,
            matrix=np.asarray(np.linalg.inv(forward.matrix), dtype=np.float64),
            matrix_metres=None if metres is None else np.asarray(np.linalg.inv(metres), np.float64),
        )

    def fused_transform(self, index: int) -> NDArray[np.float64] | None:
        """Matrix taking grid ``index``'s cells to the fused grid's cells (None if unlinked)."""
        return self.fused.to_fused[index]


Estimator = Callable[[Any, Any], MergeResult]
"""``estimator(map_i, map_j) -> MergeResult`` with matrix taking j's cells to i's."""


def merge_all(
    grids: Sequence[OccupancyGrid | NDArray[Any]],
    *,
    method: str = DEFAULT_METHOD,
    estimator: Estimator | None = None,
    rng: RngLike = None,
    **options: Any,
) -> MergeAllResult:
    """Estimate the transforms between N grids, link them and fuse them.

    1. Estimate a transform for every unordered pair ``i < j``
       (:func:`~merging.api.estimate_transform`, or ``estimator``).
    2. Keep the accepted pairs and build a maximum spanning forest over them,
       weighted by confidence (Kruskal), so that one weak wrong pair cannot
       override a chain of confident ones.
    3. Pick the reference: grid 0's tree, or if grid 0 links to nothing, the
       largest tree (its lowest index); compose each linked grid's transform
       into the reference along the tree.
    4. Fuse the linked grids with :func:`fuse`.

    Parameters
    ----------
    grids : sequence of OccupancyGrid or (rows, cols) array
        At least one grid in the ROS coding; OccupancyGrids must share a resolution.
    method : str
        Passed to :func:`~merging.api.estimate_transform`.
    estimator : callable, optional
        ``estimator(grid_i, grid_j) -> MergeResult`` used instead of
        ``estimate_transform`` (its matrix takes j's cells to i's).
    rng : numpy.random.Generator, int or None
        Seeds one independent stream per pair.
    **options
        Passed to ``estimate_transform``.

    Returns
    -------
    MergeAllResult
    """
    if isinstance(grids, OccupancyGrid | np.ndarray) or not isinstance(grids, Sequence):
        raise TypeError(f"grids must be a sequence of grids, got {type(grids).__name__}")
    if len(grids) == 0:
        raise ValueError("grids is empty; give at least one grid")
    if estimator is None and method not in available_methods():
        raise ValueError(f"unknown method {method!r}; choose one of {available_methods()}")
    for k, grid in enumerate(grids):
        validate_cells(grid, name=f"grids[{k}]")
    resolutions = {k: g.resolution for k, g in enumerate(grids) if isinstance(g, OccupancyGrid)}
    if resolutions and not np.allclose(list(resolutions.values()), min(resolutions.values())):
        listed = ", ".join(f"grids[{k}] {r} m" for k, r in resolutions.items())
        raise ValueError(f"resolutions differ ({listed}); resample the grids to one resolution")
    count = len(grids)
    pair_keys = [(i, j) for i in range(count) for j in range(i + 1, count)]
    streams = np.random.default_rng(rng).spawn(len(pair_keys))
    pairs: dict[tuple[int, int], MergeResult] = {}
    for (i, j), stream in zip(pair_keys, streams, strict=True):
        if estimator is None:
            result = estimate_transform(grids[i], grids[j], method=method, rng=stream, **options)
        else:
            result = estimator(grids[i], grids[j])
            if not isinstance(result, MergeResult):
                raise TypeError(f"estimator must return a MergeResult, got {type(result).__name__}")
        pairs[(i, j)] = result
    tree = _spanning_forest(count, pairs)
    reference, groups = _choose_reference(count, tree)
    transforms = _chain_transforms(count, reference, tree, pairs)
    unlinked = tuple(k for k in range(count) if transforms[k] is None)
    notes = list(_describe(reference, groups, unlinked, pairs))
    notes += _check_cycles(transforms, tree, pairs, grids)
    home = grids[reference]
    fused = fuse(grids, transforms, frame=home if isinstance(home, OccupancyGrid) else None)
    return MergeAllResult(fused, reference, transforms, pairs, tree, unlinked, tuple(notes))


def _spanning_forest(
    count: int, pairs: dict[tuple[int, int], MergeResult]
) -> tuple[tuple[int, int], ...]:
    """Kruskal's maximum spanning forest over accepted pairs by confidence (ties: lower pair)."""
    parent = list(range(count))

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    usable = [key for key, r in pairs.items() if r.accepted and np.all(np.isfinite(r.matrix))]
    edges: list[tuple[int, int]] = []
    for i, j in sorted(usable, key=lambda key: (-pairs[key].confidence, key)):
        a, b = root(i), root(j)
        if a != b:
            parent[b] = a
            edges.append((i, j))
    return tuple(edges)


def _choose_reference(count: int, tree: tuple[tuple[int, int], ...]) -> tuple[int, list[list[int]]]:
    """The reference grid and the trees (sorted lists of grid indices, largest first)."""
    group_of = list(range(count))
    for i, j in tree:  # relabel j's whole group to i's: N is small
        old, new = group_of[j], group_of[i]
        group_of = [new if g == old else g for g in group_of]
    groups = sorted(
        ([k for k in range(count) if group_of[k] == g] for g in set(group_of)),
        key=lambda members: (-len(members), members[0]),
    )
    home = next(members for members in groups if 0 in members)
    reference = 0 if len(home) > 1 else groups[0][0]
    return reference, groups


def _chain_transforms(
    count: int,
    reference: int,
    tree: tuple[tuple[int, int], ...],
    pairs: dict[tuple[int, int], MergeResult],
) -> tuple[NDArray[np.float64] | None, ...]:
    """Each grid's cells -> reference cells, composed along the tree (None off the tree)."""
    transforms: list[NDArray[np.float64] | None] = [None] * count
    transforms[reference] = np.eye(3)
    frontier = [reference]
    while frontier:
        here = frontier.pop()
        known = transforms[here]
        assert known is not None  # only reached grids enter the frontier
        for i, j in tree:
            if here == i and transforms[j] is None:  # matrix takes j to i
                transforms[j] = known @ pairs[(i, j)].matrix
                frontier.append(j)
            elif here == j and transforms[i] is None:
                transforms[i] = known @ np.linalg.inv(pairs[(i, j)].matrix)
                frontier.append(i)
    return tuple(transforms)


def _describe(
    reference: int,
    groups: list[list[int]],
    unlinked: tuple[int, ...],
    pairs: dict[tuple[int, int], MergeResult],
) -> list[str]:
    """Lines explaining the reference choice and each unlinked grid."""
    lines = []
    if reference != 0:
        members = ", ".join(map(str, next(g for g in groups if reference in g)))
        lines.append(
            f"grid 0 links to no other grid; reference is grid {reference}, "
            f"the lowest index of the largest linked group (grids {members})"
        )
    for k in unlinked:
        group = next(g for g in groups if k in g)
        if len(group) > 1:
            others = ", ".join(str(g) for g in group if g != k)
            lines.append(f"grid {k} links to grid(s) {others} but not to grid {reference}'s group")
            continue
        own = [(key, r) for key, r in pairs.items() if k in key]
        if not own:
            lines.append(f"grid {k} has no other grid to link to")
            continue
        (i, j), best = max(own, key=lambda item: item[1].confidence)
        why = f": {best.reason}" if best.reason else ""
        lines.append(
            f"grid {k} not linked: no accepted pair (best {i}-{j}, "
            f"confidence {best.confidence:.2f}{why})"
        )
    return lines


def _check_cycles(
    transforms: tuple[NDArray[np.float64] | None, ...],
    tree: tuple[tuple[int, int], ...],
    pairs: dict[tuple[int, int], MergeResult],
    grids: Sequence[OccupancyGrid | NDArray[Any]],
) -> list[str]:
    """Lines for accepted pairs off the tree whose estimate disagrees with the tree's."""
    lines = []
    for (i, j), result in pairs.items():
        ti, tj = transforms[i], transforms[j]
        if not result.accepted or (i, j) in tree or ti is None or tj is None:
            continue
        implied = np.linalg.inv(ti) @ tj
        rows, cols = validate_cells(grids[j]).shape
        corners = np.array([[0, 0], [cols - 1, 0], [0, rows - 1], [cols - 1, rows - 1]], float)
        diff = apply_transform(implied, corners) - apply_transform(result.matrix, corners)
        rms = float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))
        if rms > CONSISTENCY_TOLERANCE:
            turn = np.degrees(abs(float(wrap_angle(matrix_to_pose(implied)[2] - result.rotation))))
            lines.append(
                f"pair {i}-{j} (accepted, confidence {result.confidence:.2f}) disagrees with "
                f"the tree by {rms:.1f} cells RMS and {turn:.1f} deg; not used"
            )
    return lines
