"""Linking N robots' grids: pairwise estimates, a consistent spanning forest, one fused map.

:func:`link_maps` takes the pairwise estimates of N grids and decides which
of them to trust together:

1. it keeps the accepted pairs with finite matrices;
2. it drops pairs that contradict the others around cycles of three maps
   (:func:`consistent_pairs`): a pair whose transform disagrees with the chain
   of two accepted pairs through a third map more often than it agrees is
   dropped, the worst first; a lone triangle that does not close loses its
   least confident pair, the one that disagrees with the chain of the two
   more confident ones. "Disagrees" means by more than
   :attr:`~merging.params.LinkingParams.contradiction_cells`, or
   :attr:`~merging.params.LinkingParams.bent_contradiction_cells` when a
   pair of the comparison was vouched for as maps that bend (:func:`bends`);
   then, taking the pairs most confident first, it drops a pair that would
   join two groups of maps (one of more than one map, no pair of either
   bending) when it lays the walls of a map of one group across the open
   space of a map of the other
   (:func:`merging.linking.across.contradicted_joins`): maps its own
   verification never saw together;
3. it links the rest by a maximum spanning forest weighted by confidence
   (:func:`scipy.sparse.csgraph.minimum_spanning_tree` on ``2 - confidence``),
   so that one weak wrong pair cannot override a chain of confident ones;
4. in one breadth-first walk per linked group it composes each grid's
   transform into its group's *root*, the group's lowest index;
5. it reports accepted pairs that the forest does not use and that disagree
   with it (a contradiction around a longer cycle) as dropped too; then a
   group holding pairs of bending maps and a cycle is placed by all of its
   pairs not dropped at once (:func:`merging.linking.posegraph.adjust_poses`), since
   a chain of bent links adds up their errors. Transforms follow in metres
   too for georeferenced grids.

:func:`merge_all` estimates every pair with :func:`~merging.api.estimate_transform`,
links them and fuses the *main* group: grid 0's group, or the largest group
when grid 0 links to nothing.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_array
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree

from merging.api import DEFAULT_METHOD, check_method, estimate_transform
from merging.grid import OccupancyGrid, occupied_cells, validate_cells
from merging.linking.across import contradicted_joins
from merging.linking.fusion import FusedMap, fuse
from merging.linking.posegraph import adjust_poses
from merging.params import DEFAULT_LINKING, LinkingParams
from merging.result import MergeResult, checked_result
from merging.transforms import apply_transform, cells_to_metres, matrix_to_pose, wrap_angle
from merging.validators import RngLike, as_generator

MAX_CHECK_POINTS = 2000
"""Occupied cells of a grid used to measure how far two transforms of it differ."""
TREE_WEIGHT_OFFSET = 2.0
"""The spanning forest minimises ``TREE_WEIGHT_OFFSET - confidence``: positive for every
confidence in [0, 1], since the sparse graph treats a zero weight as no edge."""
TIE_BREAK = 1e-9
"""Weight added per rank of a pair in (i, j) order, so that pairs of equal confidence
enter the forest lower pair first, whatever order the graph library visits them in."""

Pair = tuple[int, int]


@dataclass(frozen=True, slots=True)
class Linking:
    """How N grids are linked: what :func:`link_maps` returns.

    Attributes
    ----------
    pairs : dict
        ``(i, j) -> MergeResult`` for the pairs given, ``i < j``; its matrix takes
        grid ``j``'s cells to grid ``i``'s. Use :meth:`pair` for either order.
    tree : tuple of (int, int)
        The pairs the spanning forest uses, most confident first.
    dropped : tuple of (int, int)
        Accepted pairs left out because they contradict the others (module
        docstring, steps 2 and 5); :attr:`notes` says why each was.
    groups : tuple of tuple of int
        The linked groups, each sorted, largest first (ties: lowest index
        first); a grid linked to nothing is a group of its own.
    roots : tuple of int
        Per grid, its group's root: the group's lowest index.
    transforms : tuple of (3, 3) float ndarray
        Per grid, the matrix taking its cells to its root's cells (the
        identity for a root).
    transforms_metres : tuple of (3, 3) float ndarray or None
        Per grid, the same between the map frames in metres (grid frame ->
        root frame), when every grid is an :class:`OccupancyGrid`; else None.
    notes : tuple of str
        One line each: dropped pairs and why; grids linked to nothing and why.
    used : tuple of (int, int)
        The pairs that place the grids: the forest's, and in a group placed
        by all of its pairs (module docstring, step 5) every pair not dropped.
    across : dict
        ``(i, j) -> share`` for each pair judged on the maps across the join
        it made or would have made (:mod:`merging.linking.across`): the
        largest share of walls on open space, the pair dropped above
        ``LinkingParams.across_conflict``.
    """

    pairs: dict[Pair, MergeResult]
    tree: tuple[Pair, ...]
    dropped: tuple[Pair, ...]
    groups: tuple[tuple[int, ...], ...]
    roots: tuple[int, ...]
    transforms: tuple[NDArray[np.float64], ...]
    transforms_metres: tuple[NDArray[np.float64], ...] | None
    notes: tuple[str, ...]
    used: tuple[Pair, ...] = ()
    across: dict[Pair, float] = field(default_factory=dict)

    @property
    def count(self) -> int:
        """Number of grids."""
        return len(self.roots)

    @property
    def main(self) -> int:
        """Root of the main group: grid 0's when it is linked, else the largest group's."""
        if len(self.group(0)) > 1:
            return 0
        return self.groups[0][0]

    def group(self, index: int) -> tuple[int, ...]:
        """The grids linked with grid ``index`` (itself included)."""
        found = next((g for g in self.groups if index in g), None)
        if found is None:
            raise KeyError(f"no grid {index!r}; grids are numbered 0..{self.count - 1}")
        return found

    def linked(self, index: int) -> bool:
        """Whether grid ``index`` is linked to at least one other grid."""
        return len(self.group(index)) > 1

    def pair(self, i: int, j: int) -> MergeResult:
        """The pairwise result whose matrix takes grid ``j``'s cells to grid ``i``'s (for a
        pair estimated the other way round, its matrices inverted, the hypotheses' too;
        their verification figures and the evidence still count as it was estimated)."""
        if (i, j) in self.pairs:
            return self.pairs[(i, j)]
        if (j, i) not in self.pairs:
            raise KeyError(f"no pair ({i}, {j}); grids are numbered 0..{self.count - 1}")
        forward = self.pairs[(j, i)]
        metres = forward.matrix_metres
        return replace(
            forward,
            matrix=_inverse(forward.matrix),
            matrix_metres=None if metres is None else _inverse(metres),
            hypotheses=tuple(replace(h, matrix=_inverse(h.matrix)) for h in forward.hypotheses),
        )

    def relative(self, i: int, j: int) -> NDArray[np.float64] | None:
        """Matrix taking grid ``j``'s cells to grid ``i``'s through the forest (None if not
        linked)."""
        if self.roots[i] != self.roots[j]:
            return None
        return np.asarray(np.linalg.inv(self.transforms[i]) @ self.transforms[j], np.float64)


@dataclass(frozen=True, slots=True)
class MergeAllResult:
    """What :func:`merge_all` returns: the linking and the main group fused.

    Attributes
    ----------
    linking : Linking
        Every pairwise estimate and how the grids are linked.
    fused : FusedMap
        The main group (:attr:`Linking.main`) fused in its root's frame.
    """

    linking: Linking
    fused: FusedMap

    @property
    def reference(self) -> int:
        """The grid whose cell frame the fused map is in (:attr:`Linking.main`)."""
        return self.linking.main

    @property
    def pairs(self) -> dict[Pair, MergeResult]:
        """Every pairwise estimate, ``(i, j) -> MergeResult`` with ``i < j``."""
        return self.linking.pairs

    @property
    def tree(self) -> tuple[Pair, ...]:
        """The pairs the spanning forest uses."""
        return self.linking.tree

    @property
    def notes(self) -> tuple[str, ...]:
        """The linking's notes, after a line on the reference when it is not grid 0."""
        lines = list(self.linking.notes)
        if self.reference != 0:
            members = ", ".join(map(str, self.linking.group(self.reference)))
            lines.insert(
                0,
                f"map 0 links to no other map; reference is map {self.reference}, "
                f"the lowest index of the largest linked group (maps {members})",
            )
        for k in self.unlinked:
            group = self.linking.group(k)
            if len(group) > 1 and k == group[0]:
                others = ", ".join(str(g) for g in group[1:])
                lines.append(
                    f"map {k} links to map(s) {others} but not to map {self.reference}'s group"
                )
        return tuple(lines)

    @property
    def transforms(self) -> tuple[NDArray[np.float64] | None, ...]:
        """Per grid, its cells -> the reference's cells; None off the reference's group."""
        home = self.linking.roots[self.reference]
        return tuple(
            t if root == home else None
            for t, root in zip(self.linking.transforms, self.linking.roots, strict=True)
        )

    @property
    def unlinked(self) -> tuple[int, ...]:
        """Grids not linked to the reference, left out of :attr:`fused`."""
        home = self.linking.roots[self.reference]
        return tuple(k for k, root in enumerate(self.linking.roots) if root != home)

    def pair(self, i: int, j: int) -> MergeResult:
        """The pairwise result whose matrix takes grid ``j``'s cells to grid ``i``'s."""
        return self.linking.pair(i, j)

    def fused_transform(self, index: int) -> NDArray[np.float64] | None:
        """Matrix taking grid ``index``'s cells to the fused grid's cells (None if unlinked)."""
        return self.fused.to_fused[index]


def link_maps(
    grids: Sequence[OccupancyGrid | NDArray[Any]],
    pairs: Mapping[Pair, MergeResult],
    *,
    params: LinkingParams = DEFAULT_LINKING,
) -> Linking:
    """Link grids from their pairwise estimates (steps 1-5 of the module docstring).

    Parameters
    ----------
    grids : sequence of OccupancyGrid or (rows, cols) array
        At least one grid in the ROS coding.
    pairs : mapping
        ``(i, j) -> MergeResult`` for any pairs ``i < j`` of grid indices (a
        missing pair counts as not accepted); the matrix takes grid ``j``'s
        cells to grid ``i``'s, and ``matrix_metres`` frame ``j`` to frame ``i``.
    params : LinkingParams, optional
        How far chained transforms may disagree, and how many walls a join may
        lay on open space across it (default: its documented defaults).

    Returns
    -------
    Linking
    """
    if not isinstance(params, LinkingParams):
        raise TypeError(f"params must be a LinkingParams, got {type(params).__name__}")
    cells = _check_grids(grids)
    count = len(cells)
    given = _check_pairs(pairs, count)
    points = [_check_points(c) for c in cells]
    usable = {key: r for key, r in given.items() if r.accepted and np.all(np.isfinite(r.matrix))}
    trusted, notes = consistent_pairs(usable, points, params=params)
    trusted, across_notes, across = contradicted_joins(trusted, cells, bends, params=params)
    notes += across_notes
    tree = _spanning_forest(count, trusted)
    roots, transforms = _compose(count, tree, trusted)
    late, late_notes = _contradicting_tree(trusted, tree, roots, transforms, points, params)
    kept = {key: r for key, r in trusted.items() if key not in late}
    transforms, adjusted = _adjust_bent_groups(roots, transforms, kept, points)
    used = tree + tuple(key for key in kept if key not in tree and roots[key[0]] in adjusted)
    dropped = tuple(sorted(set(usable) - set(trusted))) + late
    groups = tuple(
        sorted(
            (tuple(k for k in range(count) if roots[k] == r) for r in sorted(set(roots))),
            key=lambda members: (-len(members), members[0]),
        )
    )
    metres = None
    if all(isinstance(g, OccupancyGrid) for g in grids):
        metres = tuple(
            np.asarray(cells_to_metres(t, grids[roots[k]], grids[k]), np.float64)  # type: ignore[arg-type]
            for k, t in enumerate(transforms)
        )
    notes += late_notes + _unlinked_notes(groups, given)
    return Linking(
        dict(given), tree, dropped, groups, roots, transforms, metres, tuple(notes), used, across
    )


def merge_all(
    grids: Sequence[OccupancyGrid | NDArray[Any]],
    *,
    method: str = DEFAULT_METHOD,
    rng: RngLike = None,
    linking: LinkingParams = DEFAULT_LINKING,
    **options: Any,
) -> MergeAllResult:
    """Estimate the transforms between N grids, link them and fuse the main group.

    1. Estimate a transform for every unordered pair ``i < j`` with
       :func:`~merging.api.estimate_transform` (one random stream per pair).
    2. Link the grids with :func:`link_maps`.
    3. Fuse the main group (:attr:`Linking.main`) in its root's frame with
       :func:`~merging.linking.fusion.fuse`.

    Parameters
    ----------
    grids : sequence of OccupancyGrid or (rows, cols) array
        At least one grid in the ROS coding; OccupancyGrids must share a resolution.
    method : str
        Passed to :func:`~merging.api.estimate_transform`.
    rng : numpy.random.Generator, int or None
        Seeds one independent stream per pair.
    linking : LinkingParams, optional
        Passed to :func:`link_maps` as its ``params``.
    **options
        Passed to ``estimate_transform``.

    Returns
    -------
    MergeAllResult
    """
    check_method(method)
    cells = _check_grids(grids)
    count = len(cells)
    keys = [(i, j) for i in range(count) for j in range(i + 1, count)]
    generator = as_generator(rng)
    try:
        streams = generator.spawn(len(keys))
    except TypeError:  # a generator whose seed cannot spawn (one made from a RandomState)
        seeds = generator.integers(2**63, size=len(keys))
        streams = [np.random.default_rng(int(seed)) for seed in seeds]
    pairs = {
        (i, j): estimate_transform(grids[i], grids[j], method=method, rng=stream, **options)
        for (i, j), stream in zip(keys, streams, strict=True)
    }
    linked = link_maps(grids, pairs, params=linking)
    return MergeAllResult(linked, fuse_group(grids, linked, linked.main))


def fuse_group(
    grids: Sequence[OccupancyGrid | NDArray[Any]], linking: Linking, root: int
) -> FusedMap:
    """Fuse the group whose root is ``root`` in the root's frame (the others left out)."""
    if linking.roots[root] != root:
        raise ValueError(f"grid {root} is not a root; its group's root is {linking.roots[root]}")
    matrices = [
        t if r == root else None for t, r in zip(linking.transforms, linking.roots, strict=True)
    ]
    home = grids[root]
    return fuse(grids, matrices, frame=home if isinstance(home, OccupancyGrid) else None)


def _check_grids(grids: Sequence[OccupancyGrid | NDArray[Any]]) -> list[NDArray[np.int8]]:
    """Validated cells of every grid; raises for an empty list or mixed resolutions."""
    if isinstance(grids, OccupancyGrid | np.ndarray) or not isinstance(grids, Sequence):
        raise TypeError(f"grids must be a sequence of grids, got {type(grids).__name__}")
    if len(grids) == 0:
        raise ValueError("grids is empty; give at least one grid")
    cells = [validate_cells(grid, name=f"grids[{k}]") for k, grid in enumerate(grids)]
    resolutions = {k: g.resolution for k, g in enumerate(grids) if isinstance(g, OccupancyGrid)}
    if resolutions and not np.allclose(list(resolutions.values()), min(resolutions.values())):
        listed = ", ".join(f"grids[{k}] {r} m" for k, r in resolutions.items())
        raise ValueError(
            f"resolutions differ ({listed}); bring them to one with "
            "merging.resample.common_resolution"
        )
    return cells


def _check_pairs(pairs: Mapping[Pair, MergeResult], count: int) -> dict[Pair, MergeResult]:
    """``pairs`` as a dict sorted by key, after checking keys and values."""
    if not isinstance(pairs, Mapping):
        raise TypeError(f"pairs must map (i, j) to MergeResult, got {type(pairs).__name__}")
    for key in pairs:
        if not (
            isinstance(key, tuple)
            and len(key) == 2
            and all(isinstance(k, numbers.Integral) and not isinstance(k, bool) for k in key)
        ):
            raise ValueError(
                f"pairs must be keyed by (i, j), two whole grid indices, got the key {key!r}"
            )
    checked = {}
    for key in sorted(pairs):
        i, j = key
        if not (0 <= i < j < count):
            raise ValueError(f"pair {key} must be (i, j) with 0 <= i < j < {count}")
        checked[(int(i), int(j))] = checked_result(pairs[key], f"pairs[{key}]")
    return checked


def _check_points(cells: NDArray[np.int8]) -> NDArray[np.float64]:
    """Up to :data:`MAX_CHECK_POINTS` occupied cells of a grid (its corners when it has none)."""
    points = occupied_cells(cells)
    if len(points) == 0:
        rows, cols = cells.shape
        return np.array([[0, 0], [cols - 1, 0], [0, rows - 1], [cols - 1, rows - 1]], float)
    stride = max(1, int(np.ceil(len(points) / MAX_CHECK_POINTS)))
    return np.asarray(points[::stride], dtype=np.float64)


def _disagreement(
    a: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64]
) -> float:
    """RMS distance, in cells, between where ``a`` and ``b`` put ``points``."""
    diff = apply_transform(a, points) - apply_transform(b, points)
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def consistent_pairs(
    pairs: Mapping[Pair, MergeResult],
    points: Sequence[NDArray[np.float64]],
    *,
    params: LinkingParams = DEFAULT_LINKING,
) -> tuple[dict[Pair, MergeResult], list[str]]:
    """Drop pairs that contradict the others around triangles of maps (step 2).

    For every triangle ``i < j < k`` of usable pairs, the chain ``(i, j) @ (j, k)``
    is compared with ``(i, k)`` over grid ``k``'s occupied cells: the triangle
    *closes* within ``params.contradiction_cells`` (``params.bent_contradiction_cells``
    when one of its pairs :func:`bends`), or it does not. A pair's score
    is the number of its triangles that do not close minus those that do.
    While some pair scores above zero, the one scoring highest (ties: the least
    confident, then the highest pair) is dropped and the scores recounted.

    Returns
    -------
    (dict, list of str)
        The pairs kept, and a line per pair dropped.
    """
    kept = dict(pairs)
    notes: list[str] = []
    while True:
        score: dict[Pair, int] = dict.fromkeys(kept, 0)
        worst: dict[Pair, tuple[float, int]] = {}
        nodes = sorted({n for key in kept for n in key})
        for a, i in enumerate(nodes):
            for b, j in enumerate(nodes[a + 1 :], start=a + 1):
                if (i, j) not in kept:
                    continue
                for k in nodes[b + 1 :]:
                    if (j, k) not in kept or (i, k) not in kept:
                        continue
                    chain = kept[(i, j)].matrix @ kept[(j, k)].matrix
                    off = _disagreement(chain, kept[(i, k)].matrix, points[k])
                    triangle = (kept[(i, j)], kept[(j, k)], kept[(i, k)])
                    vote = 1 if off > _tolerance(params, *triangle) else -1
                    for key, other in (((i, j), k), ((j, k), i), ((i, k), j)):
                        score[key] += vote
                        if vote > 0 and off > worst.get(key, (0.0, 0))[0]:
                            worst[key] = (off, other)
        bad = [key for key, s in score.items() if s > 0]
        if not bad:
            return kept, notes
        drop = max(bad, key=lambda key: (score[key], -kept[key].confidence, key))
        off, via = worst[drop]
        i, j = drop
        notes.append(
            f"pair {i}-{j} (accepted, confidence {kept[drop].confidence:.2f}) dropped: it "
            f"disagrees by {off:.1f} cells RMS with the chain through map {via}"
        )
        del kept[drop]


def bends(result: MergeResult) -> bool:
    """Whether ``result`` was vouched for as maps that bend against each other.

    The default method vouches for separate sessions of a floor by robust
    evidence (:mod:`merging.evidence.verdict`): its ``robust_confidence`` then exceeds
    its ``close_confidence``. Such a transform is right only to within the
    bending, up to half a metre. Results without that evidence (other
    methods) count as close fits.
    """
    evidence = result.evidence
    robust, close = evidence.get("robust_confidence"), evidence.get("close_confidence")
    return robust is not None and close is not None and robust > close


def _tolerance(params: LinkingParams, *results: MergeResult) -> float:
    """Cells RMS within which transforms chained from ``results`` must agree."""
    if any(bends(result) for result in results):
        return params.bent_contradiction_cells
    return params.contradiction_cells


def _adjust_bent_groups(
    roots: tuple[int, ...],
    transforms: tuple[NDArray[np.float64], ...],
    pairs: Mapping[Pair, MergeResult],
    points: Sequence[NDArray[np.float64]],
) -> tuple[tuple[NDArray[np.float64], ...], set[int]]:
    """Step 5's second half: each group with a bending pair and a cycle, placed by all
    of ``pairs`` in it (:func:`merging.linking.posegraph.adjust_poses`; pairs that contradict
    the tree are left out beforehand); the others as the tree has them.

    Returns the transforms and the roots of the groups so placed.
    """
    placed = list(transforms)
    adjusted: set[int] = set()
    for root in sorted(set(roots)):
        members = [k for k, r in enumerate(roots) if r == root]
        inside = {key: r for key, r in pairs.items() if roots[key[0]] == root}
        if len(inside) < len(members) or not any(bends(r) for r in inside.values()):
            continue  # a tree (no cycle to spread bending over) or maps that fit closely
        matrices = {key: r.matrix for key, r in inside.items()}
        placed = adjust_poses(placed, root, members, matrices, points)
        adjusted.add(root)
    return tuple(placed), adjusted


def _spanning_forest(count: int, pairs: Mapping[Pair, MergeResult]) -> tuple[Pair, ...]:
    """Maximum spanning forest over ``pairs`` by confidence, most confident first (step 3)."""
    if not pairs:
        return ()
    keys = sorted(pairs)
    weights = [
        TREE_WEIGHT_OFFSET - float(pairs[key].confidence) + TIE_BREAK * rank
        for rank, key in enumerate(keys)
    ]
    rows, cols = zip(*keys, strict=True)
    graph = coo_array((weights, (rows, cols)), shape=(count, count)).tocsr()
    forest = minimum_spanning_tree(graph).tocoo()
    edges = [(int(min(r, c)), int(max(r, c))) for r, c in zip(forest.row, forest.col, strict=True)]
    return tuple(sorted(edges, key=lambda key: (-pairs[key].confidence, key)))


def _compose(
    count: int, tree: tuple[Pair, ...], pairs: Mapping[Pair, MergeResult]
) -> tuple[tuple[int, ...], tuple[NDArray[np.float64], ...]]:
    """Each grid's root and its cells -> root cells, in one walk per group (step 4)."""
    rows = [i for i, _ in tree] + [j for _, j in tree]
    cols = [j for _, j in tree] + [i for i, _ in tree]
    graph = coo_array((np.ones(len(rows)), (rows, cols)), shape=(count, count)).tocsr()
    _, labels = connected_components(graph, directed=False)
    roots = [0] * count
    transforms: list[NDArray[np.float64]] = [np.eye(3)] * count
    for label in np.unique(labels):
        root = int(np.flatnonzero(labels == label)[0])
        order, predecessors = breadth_first_order(
            graph, root, directed=False, return_predecessors=True
        )
        for node in order:
            k, parent = int(node), int(predecessors[node])
            roots[k] = root
            if parent >= 0:  # the matrix takes the later grid's cells to the earlier one's
                step = (
                    pairs[(parent, k)].matrix
                    if parent < k
                    else np.linalg.inv(pairs[(k, parent)].matrix)
                )
                transforms[k] = np.asarray(transforms[parent] @ step, dtype=np.float64)
    return tuple(roots), tuple(transforms)


def _contradicting_tree(
    pairs: Mapping[Pair, MergeResult],
    tree: tuple[Pair, ...],
    roots: tuple[int, ...],
    transforms: tuple[NDArray[np.float64], ...],
    points: Sequence[NDArray[np.float64]],
    params: LinkingParams,
) -> tuple[tuple[Pair, ...], list[str]]:
    """Pairs off the forest whose estimate disagrees with the forest's (step 5)."""
    dropped: list[Pair] = []
    notes: list[str] = []
    for (i, j), result in pairs.items():
        if (i, j) in tree or roots[i] != roots[j]:
            continue
        implied = np.linalg.inv(transforms[i]) @ transforms[j]
        off = _disagreement(implied, result.matrix, points[j])
        group = [pairs[key] for key in tree if roots[key[0]] == roots[i]]
        if off > _tolerance(params, result, *group):
            dropped.append((i, j))
            turn = np.degrees(abs(float(wrap_angle(matrix_to_pose(implied)[2] - result.rotation))))
            notes.append(
                f"pair {i}-{j} (accepted, confidence {result.confidence:.2f}) disagrees with "
                f"the tree by {off:.1f} cells RMS and {turn:.1f} deg; not used"
            )
    return tuple(dropped), notes


def _unlinked_notes(
    groups: tuple[tuple[int, ...], ...], pairs: Mapping[Pair, MergeResult]
) -> list[str]:
    """A line per grid linked to nothing: its accepted pairs that were dropped, or else its
    best pair and why it was not accepted."""
    lines = []
    for (k,) in (g for g in groups if len(g) == 1):
        own = [(key, r) for key, r in pairs.items() if k in key]
        if not own:
            lines.append(f"map {k} has no estimate with another map")
            continue
        accepted = [f"{i}-{j}" for (i, j), r in own if r.accepted and np.all(np.isfinite(r.matrix))]
        if accepted:
            lines.append(
                f"map {k} not linked: its accepted pairs ({', '.join(accepted)}) were dropped "
                "as contradicting the others (above)"
            )
            continue
        (i, j), best = max(own, key=lambda item: item[1].confidence)
        why = f": {best.reason}" if best.reason else ""
        lines.append(
            f"map {k} not linked: no accepted pair (best {i}-{j}, "
            f"confidence {best.confidence:.2f}{why})"
        )
    return lines


def _inverse(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of a transform matrix, as float64."""
    return np.asarray(np.linalg.inv(matrix), dtype=np.float64)
