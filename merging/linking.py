"""Linking N robots' grids: pairwise estimates, a spanning tree, one fused map.

:func:`merge_all` estimates the transform of every pair of grids, keeps a
maximum spanning tree over the accepted pairs weighted by confidence (so one
weak wrong pair cannot override a chain of confident ones), composes each
grid's transform into the reference grid's cells along the tree, and fuses the
linked grids with :func:`merging.fusion.fuse`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.api import DEFAULT_METHOD, RngLike, available_methods, estimate_transform
from merging.fusion import FusedMap, fuse
from merging.grid import OccupancyGrid, validate_cells
from merging.result import MergeResult
from merging.transforms import apply_transform, matrix_to_pose, wrap_angle

CONSISTENCY_TOLERANCE = 2.0
"""Cells RMS. An accepted pair that the spanning tree does not use is reported
when the tree's transform moves the grid's corners by more than this from the
pair's own estimate; 2 cells is the accuracy the merger is held to."""


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
