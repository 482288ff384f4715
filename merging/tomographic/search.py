"""The default merger: the paper's tomographic ideas, made robust and fast.

Where the Radon transform went
------------------------------
The paper (section 3.1) computes the sinogram ``S(s, α)`` of each map, the
Radon transform of its occupied cells (eqs. 2-6), and reads the rotation off
its maximum (eq. 7) and the translation off the cross-correlations of two of
its columns (eqs. 11-17). This method uses the same transform, but through
the **Fourier slice theorem**, without building a sinogram: the 1-D Fourier
transform of the column ``S(·, α)`` along ``s`` is the 2-D Fourier transform
of the map along the radial line at angle α. So

* every column's spectrum comes from one 2-D FFT of the map; its magnitude
  does not change when the map is translated, and rotating the map moves it
  from α to α + φ. Correlating these *angular spectra* of the two maps over
  α finds the rotation φ from all columns at once (:mod:`merging.tomographic.angular`);
* correlating the column of map 1 at α with the rotated map 2's column at α
  peaks at ``s = Δx cos α + Δy sin α`` (the paper's eqs. 14-17 do this for
  α = 180° and 90°). The projection of a 2-D correlation is the correlation
  of the projections, so the 1-D correlations of *all* columns pooled are
  the Radon transform of the maps' 2-D correlation: its peak is where every
  projection agrees, and one FFT correlation finds it
  (:mod:`merging.tomographic.correlate`).

Where each equation of the paper went
-------------------------------------
=========================  ===============================================
paper                      here
=========================  ===============================================
eq. (1) transform          :func:`merging.transforms.rigid_matrix`
eqs. (2)-(6) sinogram      angular spectra by the Fourier slice theorem
                           (:func:`merging.tomographic.angular.angular_spectrum`)
eq. (7) rotation           the peaks of the circular correlation of the
                           angular spectra
                           (:func:`~merging.tomographic.angular.rotation_correlation`),
                           each with its 180° twin
eq. (8) rotate map 2       in :func:`~merging.tomographic.correlate.translation_peaks`
eqs. (9)-(17) translation  the pooled correlation of all projections, as a
                           2-D FFT correlation on a coarse grid
eqs. (18)-(26) search      the few strongest rotation and translation peaks
space (GMMs)               replace the Gaussian mixtures' means
eqs. (27)-(30) Monte       each hypothesis is verified (:mod:`merging.evidence.verify`)
Carlo objective            and the best refined by Gauss-Newton
                           (:mod:`merging.evidence.refine`), the stages of
                           :data:`merging.params.DEFAULT_STAGES`; the winner
                           is held against map 2's mirror image
                           (:mod:`merging.evidence.mirror`)
eq. (31) matching index    :func:`merging.evaluation.metrics.matching_index` (scoring only)
=========================  ===============================================

The paper's pipeline as written is ``method="paper"`` (:mod:`merging.paper`).

Steps
-----
Steps 1-4 are :mod:`merging.tomographic.hypotheses`, steps 5-6
:mod:`merging.tomographic.judging` with the second looks of
:mod:`merging.tomographic.restarts`; what they share is
:mod:`merging.tomographic.candidates`. This module runs them and step 7
(:func:`tomographic_merge`), and refines a given transform without a search
(:func:`refine_from`).

1. Rotation: angular spectra, the strongest correlation peaks and their
   180° twins.
2. Translation: for each rotation, the strongest peaks of the pooled
   projection correlation, with map 1's open space counted against map 2's
   walls, and the most significant: with map 1's walls counted against map
   2's clear space too.
3. Screening: every hypothesis carries each map's walls into the other.
4. Refinement: the schedule of :class:`~merging.params.RefineStage` rows,
   each refining fewer candidates on finer fields.
5. Verdict: a close fit (five factors: fit, support, distinctiveness
   against the best *different* hypothesis, constraint strength, shared
   open space) or, for maps that bend against each other, robust evidence
   (a large overlap whose walls meet within a few cells and whose open space
   lies on open space), see :mod:`merging.evidence.verdict`; only confident results
   are accepted, and a refusal says why. A close fit about to be accepted is
   turned about the overlap and refined again: an optimum of its own more
   than 2 cells away that explains about as much makes it ambiguous
   (:func:`~merging.tomographic.restarts.turned_rival`); a turn the curvature
   holds weakly counts as held when those restarts all come back. One the
   curvature holds loosely is refined
   the other way round too, map 1 onto map 2: the two answers straddle the
   truth, their distance costs confidence, and the result lies halfway
   (:func:`~merging.tomographic.restarts.both_ways`).
6. Mirror check, for a placement step 5 would accept: steps 1-4 again for
   map 2's part of the overlap seen in a mirror, on map 1's cells around
   the overlap; if it explains the same overlap about as well,
   the overlap looks the same in a mirror and may be either of two mirror
   twins of a symmetric building, so the placement is refused
   (:mod:`merging.evidence.mirror`). It costs about one more search, for accepted
   placements only.
7. A second look, for a placement steps 5-6 refuse: the ranking's score
   prefers much shared open space, which maps of separate sessions need
   and which ranks a loose large overlap above the exact small one of maps
   that share little; steps 3-6 run again on the same hypotheses ranked by
   fit alone, the rivals held to the open space they share too, unless one
   lays more walls on walls than the placement (:func:`ranked_by_fit`).
   What step 5-6 accept stays as it was.

Every setting is in :class:`~merging.params.TomographicParams`, passed as
``merging.estimate_transform(..., params=...)``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.api import MIN_OCCUPIED_CELLS, register_method
from merging.evidence.verify import prepare_map
from merging.grid import OccupancyGrid, observed_part, occupied_mask, validate_cells
from merging.params import DEFAULT_PARAMS, TomographicParams
from merging.result import Hypothesis, MergeResult
from merging.tomographic.candidates import Candidate, SearchMaps, rank, rms_between
from merging.tomographic.correlate import Peak, coarse_factor
from merging.tomographic.hypotheses import ranked_pool, search_hypotheses
from merging.tomographic.judging import judged, verdict_on_pool
from merging.transforms import cells_to_metres, checked_transform, translation_matrix
from merging.validators import boolean


def tomographic_merge(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    *,
    rng: np.random.Generator,
    params: TomographicParams = DEFAULT_PARAMS,
    **options: Any,
) -> MergeResult:
    """Estimate the map transformation matrix of map 2 onto map 1 (the default method).

    Deterministic: ``rng`` is accepted for the common signature and unused.
    See the module docstring for the steps; ``params`` holds every setting.
    """
    if options:
        raise TypeError(
            f"the tomographic method takes no options, got {sorted(options)}; "
            "pass its settings as params=TomographicParams(...)"
        )
    # Only the observed part of each grid matters: searching within it makes the
    # time follow the mapped building, not the canvas it was drawn on.
    (crop1, offset1), (crop2, offset2) = observed_part(cells1), observed_part(cells2)
    result = _merge_observed(crop1, crop2, params)
    into1, out_of2 = translation_matrix(offset1), translation_matrix(-offset2)
    return replace(
        result,
        matrix=into1 @ result.matrix @ out_of2,
        hypotheses=tuple(replace(h, matrix=into1 @ h.matrix @ out_of2) for h in result.hypotheses),
    )


def _merge_observed(
    cells1: NDArray[np.int8], cells2: NDArray[np.int8], params: TomographicParams
) -> MergeResult:
    """:func:`tomographic_merge` on grids cropped to their observed parts."""
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    first = prepare_map(cells1, params=params.verify)
    second = prepare_map(cells2, params=params.verify)
    maps = SearchMaps(first, second, params)
    factor = coarse_factor(cells1.shape, cells2.shape, coarse_cells=params.translation.coarse_cells)
    timings["prepare"] = time.perf_counter() - clock

    candidates = search_hypotheses(maps, factor, timings)
    pool = ranked_pool(maps, candidates, factor, timings)
    if not pool:
        return MergeResult(
            matrix=np.eye(3),
            confidence=0.0,
            accepted=False,
            method="tomographic",
            timings=timings,
            reason="no placement to weigh: the maps are too small to hold a wall direction "
            "in the band of frequencies the rotation search reads (rotation.min_frequency "
            f"{params.rotation.min_frequency} bins to rotation.max_frequency_fraction "
            f"{params.rotation.max_frequency_fraction:g} of the highest)",
        )
    result = verdict_on_pool(maps, pool, _hypotheses(pool), timings)
    if result.accepted or not params.fit_ranked:
        return result
    return ranked_by_fit(maps, result, partial(_judged_pool, candidates=candidates, factor=factor))


def _hypotheses(pool: list[Candidate]) -> tuple[Hypothesis, ...]:
    return tuple(Hypothesis(m, rank(v), v.agreement, v.conflict, int(v.overlap)) for v, m in pool)


def _judged_pool(maps: SearchMaps, candidates: list[Peak], factor: int) -> MergeResult | None:
    """Steps 3-6 on ``candidates``, ranked by ``maps.params``; None when none is left."""
    timings: dict[str, float] = {}
    pool = ranked_pool(maps, candidates, factor, timings)
    return verdict_on_pool(maps, pool, _hypotheses(pool), timings) if pool else None


def fit_ranking(params: TomographicParams) -> TomographicParams:
    """``params`` ranking by fit alone: no preference for shared open space, and a rival
    about as good only when it shares about as much of it
    (``ConfidenceParams.distinct_by_space``)."""
    return replace(
        params,
        verify=replace(params.verify, space_preference=0.0),
        confidence=replace(params.confidence, distinct_by_space=True),
    )


def ranked_by_fit(
    maps: SearchMaps, refused: MergeResult, look: Callable[[SearchMaps], MergeResult | None]
) -> MergeResult:
    """Step 7: the verdict ``look`` gives with the pool ranked by fit alone.

    ``refused`` is the verdict on the default ranking's pool. Its score
    prefers much shared open space, which maps of separate sessions need:
    they bend against each other, so a right placement meets the other
    map's walls only within a few cells and fits no better than a wrong one
    laying a corner on a corner, but lays open space on open space. Maps
    sharing 3-15 % of their area need the opposite: a loose large overlap
    shares more open space than the exact small one. ``look`` screens,
    refines and judges the same hypotheses again (steps 3-6) with
    ``maps`` ranking by fit alone (:func:`fit_ranking`), the rivals held to
    the open space they share too; None when no placement is left. The
    answer is that look's when it is accepted (``ranked_by_fit`` among its
    evidence), else ``refused`` with the other look's confidence
    (``fit_ranked_confidence``); its seconds are ``timings["fit_ranked"]``.

    Holding a rival to the open space it shares sets aside a rival that lays
    about as many walls on walls but little floor on floor. One that lays
    *more* walls on walls than the placement, by the close score or by the
    robust way's tolerant one (a negative ``margin`` or ``tolerant_margin``),
    or as many to the finest the score ranks (a margin below
    ``TomographicParams.keep_refined_margin``), is not set aside for sharing
    less space: the truth of two maps that barely overlap is such a rival,
    and on generated floors, whose rooms repeat, the second look accepted
    the room half a turn from it, or a copy of a room beside it. Such a look
    is refused (``fit_ranked_outexplained`` 1.0 in the evidence;
    :func:`outexplained_by_rival`).
    """
    params = fit_ranking(maps.params)
    if params == maps.params:
        return refused
    clock = time.perf_counter()
    looked = look(SearchMaps(maps.first, maps.second, params, begun=maps))
    timings = {**refused.timings, "fit_ranked": time.perf_counter() - clock}
    outexplained = (
        looked is not None
        and looked.accepted
        and outexplained_by_rival(looked.evidence, tie=params.keep_refined_margin)
    )
    if looked is not None and looked.accepted and not outexplained:
        evidence = {**looked.evidence, "ranked_by_fit": 1.0}
        return replace(looked, timings=timings, evidence=evidence)
    confidence = 0.0 if looked is None else looked.confidence
    evidence = {**refused.evidence, "fit_ranked_confidence": confidence}
    if outexplained:
        evidence["fit_ranked_outexplained"] = 1.0
    return replace(refused, timings=timings, evidence=evidence)


def outexplained_by_rival(evidence: dict[str, float], *, tie: float = 0.0) -> bool:
    """Whether a rival lays as many walls on walls as the placement judged, or more: a
    ``margin`` (the close fit's runner-up) or ``tolerant_margin`` (the robust way's,
    whose walls meet within a few cells) among the verdict's ``evidence`` below
    ``tie``.

    The second look passes ``TomographicParams.keep_refined_margin``, the finest
    difference the score ranks (a cell of misfit is tolerated): a rival within it
    ties the placement by the walls, and only the open space it shares set it
    aside. On generated floors, whose rooms repeat, such a tie was a room's copy
    18 m away (``floor1``, seed 44, 4 robots: robots 0 and 3 placed half a turn
    from the truth, margin 0.002, confirmed by the next round).
    """
    return min(evidence.get("margin", tie), evidence.get("tolerant_margin", tie)) < tie


def refine_from(
    map1: OccupancyGrid | NDArray[Any],
    map2: OccupancyGrid | NDArray[Any],
    matrix: NDArray[np.float64],
    *,
    params: TomographicParams = DEFAULT_PARAMS,
    held_against_search: bool = False,
) -> MergeResult:
    """Refine a given transform (map 2 cells -> map 1 cells) and verify it, without a search.

    For a transform known to be within a few cells and a degree or so of the
    answer, such as the previous round's between two growing maps: the
    refinement of ``params.from_start`` and the confidence of the default
    method, except distinctiveness: against the best different placement
    and against map 2's mirror image (step 6 of the module docstring), as
    both need a search. The start must come from a search that held it
    against both (as a tracked transform does: :mod:`merging.tomographic.tracking`).
    Much cheaper than :func:`tomographic_merge`.

    With ``held_against_search`` the search runs too, and the refined
    transform is judged in the place of its winner: first in its pool,
    against the best different placements and map 2's mirror image, by the
    full verdict (steps 5-6, :func:`~merging.tomographic.judging.verdict_on_pool`,
    which may also settle on the rigid compromise or another placement of
    the pool, as it does for the search's winner). Started at the truth, that is what a search
    that always found the truth would give under today's verdict: a bound
    that tells the search's misses from the verdict's refusals
    (``scripts/bench_real_maps.py --from-truth``). It costs a search.

    Parameters
    ----------
    map1, map2 : OccupancyGrid or (rows, cols) array
        Grids in the ROS coding, of one resolution (cells are matched as
        they are).
    matrix : (3, 3) float ndarray
        The starting transform, map 2 cells -> map 1 cells.
    params : TomographicParams
        Settings; ``from_start`` is the refinement run.
    held_against_search : bool
        Judge the refined transform against the search's pool and map 2's
        mirror image too (see above).

    Raises
    ------
    TypeError, ValueError
        For grids not in the ROS coding, two OccupancyGrids of different
        resolutions, a matrix that is not a finite, invertible 3x3 one, or
        ``params`` that is not a TomographicParams.

    Returns
    -------
    MergeResult
        As :func:`merging.estimate_transform`'s (``matrix_metres`` when both
        maps are OccupancyGrids); not accepted, with the start as its
        matrix, when either map holds fewer than
        :data:`~merging.api.MIN_OCCUPIED_CELLS` occupied cells.
    """
    cells1 = validate_cells(map1, name="map1")
    cells2 = validate_cells(map2, name="map2")
    matrix = checked_transform(matrix)
    if not isinstance(params, TomographicParams):
        raise TypeError(f"params must be a TomographicParams, got {type(params).__name__}")
    held_against_search = boolean(held_against_search, "held_against_search")
    if (
        isinstance(map1, OccupancyGrid)
        and isinstance(map2, OccupancyGrid)
        and not np.isclose(map1.resolution, map2.resolution)
    ):
        raise ValueError(
            f"map resolutions differ ({map1.resolution} m vs {map2.resolution} m): cells are "
            "matched as they are; resample one map first, or search with estimate_transform"
        )
    clock = time.perf_counter()
    counts = (int(occupied_mask(cells1).sum()), int(occupied_mask(cells2).sum()))
    if min(counts) < MIN_OCCUPIED_CELLS:
        refused = MergeResult(
            matrix=matrix,
            confidence=0.0,
            accepted=False,
            method="tomographic",
            timings={"total": time.perf_counter() - clock},
            reason=f"too few occupied cells to match (map1 {counts[0]}, map2 {counts[1]}; "
            f"need {MIN_OCCUPIED_CELLS})",
        )
        return _with_metres(refused, map1, map2)
    (crop1, offset1), (crop2, offset2) = observed_part(cells1), observed_part(cells2)
    first = prepare_map(crop1, params=params.verify)
    second = prepare_map(crop2, params=params.verify)
    maps = SearchMaps(first, second, params)
    into1, out_of2 = translation_matrix(offset1), translation_matrix(-offset2)
    start = np.linalg.inv(into1) @ np.asarray(matrix, dtype=float) @ np.linalg.inv(out_of2)
    refined = maps.refine((maps.verify(start), start), params.from_start)
    timings = {"refine": time.perf_counter() - clock}
    check, best = refined[0], into1 @ refined[1] @ out_of2
    hypotheses = (
        Hypothesis(best, rank(check), check.agreement, check.conflict, int(check.overlap)),
    )
    if held_against_search:
        coarse_cells = params.translation.coarse_cells
        factor = coarse_factor(crop1.shape, crop2.shape, coarse_cells=coarse_cells)
        candidates = search_hypotheses(maps, factor, timings)
        held = partial(
            _held_first, start=refined[1], candidates=candidates, factor=factor,
            hypotheses=hypotheses, timings=timings,
        )  # fmt: skip
        result = held(maps)
        if not result.accepted and params.fit_ranked:
            result = ranked_by_fit(maps, result, held)
        # The verdict may move it (halfway between both ways round, or the compromise).
        best = into1 @ result.matrix @ out_of2
    else:
        result = judged(maps, refined[1], (None, None), hypotheses, timings, mirror_check=False)
    timings["total"] = time.perf_counter() - clock
    return _with_metres(replace(result, matrix=best), map1, map2)


def _held_first(
    maps: SearchMaps,
    start: NDArray[np.float64],
    candidates: list[Peak],
    factor: int,
    hypotheses: tuple[Hypothesis, ...],
    timings: dict[str, float],
) -> MergeResult:
    """Steps 3-6 with the placement ``start`` first in the pool, ranked by ``maps.params``:
    the search's placements, but those that are ``start`` found again, are its rivals."""
    distinct, points = maps.params.distinct_cells, maps.second.points
    rivals = [
        candidate
        for candidate in ranked_pool(maps, candidates, factor, timings)
        if rms_between(candidate[1], start, points) > distinct
    ]
    return verdict_on_pool(maps, [(maps.verify(start), start), *rivals], hypotheses, timings)


def _with_metres(result: MergeResult, map1: Any, map2: Any) -> MergeResult:
    """``result`` with its matrix in metres too, when both maps are OccupancyGrids."""
    if not (isinstance(map1, OccupancyGrid) and isinstance(map2, OccupancyGrid)):
        return result
    return replace(result, matrix_metres=cells_to_metres(result.matrix, map1, map2))


register_method("tomographic", params_type=TomographicParams)(tomographic_merge)
