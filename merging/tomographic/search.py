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
   (``_turned_rival``); a turn the curvature holds weakly counts as held when
   those restarts all come back. One the curvature holds loosely is refined
   the other way round too, map 1 onto map 2: the two answers straddle the
   truth, their distance costs confidence, and the result lies halfway
   (``_both_ways``).
6. Mirror check, for a placement step 5 would accept: steps 1-4 again for
   map 2's part of the overlap seen in a mirror, on map 1's cells around
   the overlap; if it explains the same overlap about as well,
   the overlap looks the same in a mirror and may be either of two mirror
   twins of a symmetric building, so the placement is refused
   (:mod:`merging.evidence.mirror`). It costs about one more search, for accepted
   placements only.

Every setting is in :class:`~merging.params.TomographicParams`, passed as
``merging.estimate_transform(..., params=...)``.
"""

from __future__ import annotations

import time
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import expit

from merging.api import MIN_OCCUPIED_CELLS, register_method
from merging.evaluation.metrics import as_matrix
from merging.evidence.mirror import MirrorCandidates, mirrored_part, twin_ground
from merging.evidence.pinning import meeting_walls, slides
from merging.evidence.refine import SmoothedMap, refine_transform
from merging.evidence.verdict import MirrorSearch, ambiguity_reason, judge, reverse_reason
from merging.evidence.verify import PreparedMap, Verification, prepare_map, verify
from merging.grid import OccupancyGrid, observed_part, occupied_mask, validate_cells
from merging.params import DEFAULT_PARAMS, RefineStage, TomographicParams
from merging.result import Hypothesis, MergeResult
from merging.tomographic.angular import (
    AngularSpectrum,
    angular_spectrum,
    rotation_correlation,
    rotation_peaks,
)
from merging.tomographic.correlate import (
    CoarseMap,
    Peak,
    coarse_factor,
    coarsen,
    translation_peaks,
)
from merging.transforms import (
    apply_transform,
    cells_to_metres,
    halfway,
    matrix_to_pose,
    rigid_matrix,
    translation_matrix,
    wrap_angle,
)

Candidate = tuple[Verification, NDArray[np.float64]]
"""A hypothesis and its verification."""


def _image_settings(params: TomographicParams) -> tuple[Any, ...]:
    """The settings map 1's fields, coarse images and angular spectra are made with."""
    translation = params.translation
    return (params.rotation, params.gauss_newton, translation.wall_blur, translation.free_penalty)


def rank(check: Verification) -> float:
    """The score hypotheses are ranked by (:attr:`Verification.score`)."""
    return check.score


class _Maps:
    """Both prepared maps, map 1's fields and the settings: what every stage needs."""

    __slots__ = ("coarse_first", "first", "params", "second", "smoothed", "spectra_first")

    smoothed: SmoothedMap
    coarse_first: dict[int, CoarseMap]
    spectra_first: dict[tuple[int, int], AngularSpectrum]

    def __init__(
        self,
        first: PreparedMap,
        second: PreparedMap,
        params: TomographicParams,
        begun: _Maps | None = None,
    ):
        """``begun``: another search of the same map 1, whose images of it are reused."""
        self.first, self.second, self.params = first, second, params
        if begun is not None:
            if begun.first is not first or _image_settings(begun.params) != _image_settings(params):
                raise ValueError(
                    "a search reuses another's images of map 1 only for the same map 1 "
                    "and the same rotation and gauss_newton settings, wall_blur and "
                    "free_penalty"
                )
            self.smoothed = begun.smoothed
            self.coarse_first = begun.coarse_first
            self.spectra_first = begun.spectra_first
            return
        gauss_newton = params.gauss_newton
        self.smoothed = SmoothedMap(
            first.walls,
            first.shape,
            downsample_from_sigma=gauss_newton.downsample_from_sigma,
            whole_field_share=gauss_newton.whole_field_share,
        )
        self.coarse_first = {}
        self.spectra_first = {}

    def first_coarse(self, factor: int) -> CoarseMap:
        """Map 1 in blocks of ``factor`` cells (kept for another search with that factor)."""
        if factor not in self.coarse_first:
            self.coarse_first[factor] = coarsen(self.first, factor, params=self.params.translation)
        return self.coarse_first[factor]

    def first_spectrum(self, factor: int, size: int) -> AngularSpectrum:
        """Map 1's angular spectrum in blocks of ``factor`` cells on an FFT of ``size``."""
        key = (factor, size)
        if key not in self.spectra_first:
            walls, rotation = self.first_coarse(factor).walls, self.params.rotation
            self.spectra_first[key] = angular_spectrum(walls, size=size, params=rotation)
        return self.spectra_first[key]

    def verify(self, matrix: NDArray[np.float64]) -> Verification:
        return verify(self.first, self.second, matrix, params=self.params.verify)

    def refine(self, candidate: Candidate, stage: RefineStage, *, keep: bool = True) -> Candidate:
        """Refine a candidate; keep the start only when the refined one verifies clearly worse.

        Refinement may settle on a nearby optimum that explains the maps
        worse (two close parallel walls blurred into one by a wide field).
        Within ``keep_refined_margin`` the refined transform wins:
        verification tolerates a cell of misfit, so it cannot rank finer.
        ``keep=False`` returns the refined one always: the optimum the start
        leads to.
        """
        before, matrix = candidate
        better = _refined_on(self.smoothed, self.second, matrix, stage, self.params)
        after = self.verify(better)
        if not keep or rank(after) >= rank(before) - self.params.keep_refined_margin:
            return after, better
        return before, matrix


def _refined_on(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    stage: RefineStage,
    params: TomographicParams,
) -> NDArray[np.float64]:
    """``matrix`` refined on ``smoothed``'s fields as ``stage`` says (one row of the schedule)."""
    return refine_transform(
        smoothed,
        second,
        matrix,
        sigmas=stage.sigmas,
        iterations=stage.iterations,
        local=stage.local,
        max_points=stage.points,
        params=params.gauss_newton,
    )


def _rms_between(a: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64]):
    diff = apply_transform(a, points) - apply_transform(b, points)
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def _rotation_hypotheses(maps: _Maps, factor: int) -> tuple[list[float], CoarseMap, CoarseMap]:
    """Rotation hypotheses (radians, for map 2 -> map 1), from angular spectra.

    Each stands for itself and its half-turn twin, which the angular spectra
    cannot tell apart (the translation search tries both).
    """
    params = maps.params
    coarse1 = maps.first_coarse(factor)
    coarse2 = coarsen(maps.second, factor, params=params.translation)
    size = int(2 ** np.ceil(np.log2(max(*coarse1.walls.shape, *coarse2.walls.shape, 8))))
    rotation = params.rotation
    spectrum1 = maps.first_spectrum(factor, size)
    spectrum2 = angular_spectrum(coarse2.walls, size=size, params=rotation)
    peaks = rotation_peaks(
        rotation_correlation(spectrum1, spectrum2),
        count=rotation.peaks,
        angle_step_deg=rotation.angle_step_deg,
        separation_deg=rotation.peak_separation_deg,
    )
    # Map 2 shows map 1's structure turned by +angle; turning it back is -angle.
    thetas = [-float(np.deg2rad(angle_deg)) for angle_deg, _ in peaks]
    return thetas, coarse1, coarse2


def _translation_hypotheses(
    coarse1: CoarseMap, coarse2: CoarseMap, thetas: list[float], params: TomographicParams
) -> list[Peak]:
    """For each rotation and its half-turn twin, the strongest and the most significant
    translations."""
    candidates: list[Peak] = []
    for theta in thetas:
        turns = translation_peaks(
            coarse1,
            coarse2,
            theta,
            count=params.translation.peaks,
            suppression=params.translation.peak_suppression,
            significant=params.translation.significant_peaks,
            reverse_penalty=params.translation.reverse_penalty,
        )
        for peaks in turns:
            candidates += peaks
    return candidates


def _screened(maps: _Maps, candidates: list[Peak]) -> list[NDArray[np.float64]]:
    """Every hypothesis, in the order the refinement admits them.

    First the ``correlation_refined`` strongest by collected mass and the
    ``significance_refined`` most significant of the others, then the rest
    by a quick verification on every ``screen_stride``-th wall cell: before
    refinement a true but slightly misaligned transform can fit worse than
    one that lays a single outer corner on a corner, which the correlation
    (weighing how much overlaps) does not favour.
    """
    params = maps.params
    stride = params.verify.screen_stride
    scores = [
        rank(verify(maps.first, maps.second, peak.matrix, stride=stride, params=params.verify))
        for peak in candidates
    ]
    masses = [peak.mass for peak in candidates]
    by_mass = [int(i) for i in np.argsort(masses)[::-1][: params.correlation_refined]]
    others = [i for i in range(len(candidates)) if i not in by_mass]
    others.sort(key=lambda i: -candidates[i].significance)
    by_significance = others[: params.significance_refined]
    first = by_mass + by_significance
    by_score = sorted(range(len(candidates)), key=lambda i: -scores[i])
    order = first + [i for i in by_score if i not in first]
    return [candidates[i].matrix for i in order]


def coarse_to_fine(stage: RefineStage, factor: int, params: TomographicParams) -> RefineStage:
    """``stage`` with wider fields put before its own, to catch hypotheses of a coarse grid.

    A hypothesis from a grid of ``factor``-cell blocks is off by up to half a
    block in translation, plus its rotation error times the map's radius,
    both growing with the map. Field widths double from the stage's widest
    while they stay within ``params.widest_per_block`` blocks, so that each
    width's answer lies within the next one's reach (a field catches about
    twice its width) and a 4000-cell map starts as close as a 400-cell one.
    """
    widths: list[float] = []
    width = 2.0 * max(stage.sigmas)
    while width <= params.widest_per_block * factor:
        widths.insert(0, width)
        width *= 2.0
    return replace(stage, sigmas=(*widths, *stage.sigmas)) if widths else stage


def _refined(maps: _Maps, screened: list[NDArray[np.float64]], factor: int) -> list[Candidate]:
    """Walk the refinement schedule; returns the pool, the winner first.

    Each stage admits the next screened candidates (verified in full), ranks
    the pool and refines its best few; the last stage's first is the winner.
    The first stage starts from fields as wide as the coarse grid needs
    (:func:`coarse_to_fine`).
    """
    pool: list[Candidate] = []
    admitted = 0
    stages = maps.params.stages
    stages = (coarse_to_fine(stages[0], factor, maps.params), *stages[1:])
    for stage in stages:
        newcomers = screened[admitted : admitted + stage.admit]
        admitted += len(newcomers)
        pool += [(maps.verify(m), m) for m in newcomers]
        pool.sort(key=lambda candidate: -rank(candidate[0]))
        pool[: stage.refine] = [maps.refine(c, stage) for c in pool[: stage.refine]]
    return pool


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
    maps = _Maps(first, second, params)
    factor = coarse_factor(cells1.shape, cells2.shape, coarse_cells=params.translation.coarse_cells)
    timings["prepare"] = time.perf_counter() - clock

    pool = _search(maps, factor, timings)
    if not pool:
        return MergeResult(
            matrix=np.eye(3),
            confidence=0.0,
            accepted=False,
            method="tomographic",
            timings=timings,
            reason="no placement to weigh: the maps are too small to hold a wall direction",
        )
    hypotheses = tuple(
        Hypothesis(m, rank(v), v.agreement, v.conflict, int(v.overlap)) for v, m in pool
    )
    result = _judged_first(maps, pool, hypotheses, timings)
    if result.accepted:
        return result
    bent = _bent_compromise(maps, pool, hypotheses, timings, result.evidence)
    if bent is not None and bent.accepted:
        return bent
    if bent is not None:
        result = replace(
            result,
            reason=f"{result.reason}; taken for one answer on maps that bend, the compromise "
            f"between the two is refused too: {bent.reason}",
            evidence={**result.evidence, "bent_compromise_confidence": bent.confidence},
        )
    # The best by score is refused: a placement whose walls meet exactly may explain a
    # small overlap that the score, preferring much shared space, ranked below a loose
    # large one. Such a placement is judged too, against all the others.
    close = _close_alternative(maps, pool)
    if close is None:
        return result
    pool = [_finished(maps, pool[close]), *pool[:close], *pool[close + 1 :]]
    alternative = _judged_first(maps, pool, hypotheses, timings, by_net=True)
    return alternative if alternative.accepted else result


def _bent_compromise(
    maps: _Maps,
    pool: list[Candidate],
    hypotheses: tuple[Hypothesis, ...],
    timings: dict[str, float],
    evidence: dict[str, float],
) -> MergeResult | None:
    """The verdict on the rigid compromise between the pool's first placement and a near
    rival of maps that bend; None when the rival is not near (``evidence`` is the first
    placement's).

    Two sessions of one floor bend against each other: one part of the
    overlap fits one rigid placement, another part a placement a metre or
    two away turned a degree or two, and each explains about as much, so
    the robust evidence refuses the first as ambiguous. When that rival
    lies within ``RobustParams.bent_rival_cells`` and ``bent_rival_deg``,
    the two are taken for one answer: the placement halfway between them,
    refined on fields as wide as the bending (``TomographicParams.compromise``)
    to the best rigid compromise over the whole overlap, is judged against
    the placements farther than that. Asked only of a placement with the
    walls meeting that the robust evidence asks (its ``agreeing`` factor
    passing): for any other the compromise could not be vouched for either.
    """
    robust = maps.params.robust
    distance = evidence.get("tolerant_runner_up_distance_cells", np.inf)
    turn = evidence.get("tolerant_runner_up_turn_deg", np.inf)
    if (
        evidence.get("robust_margin", 1.0) >= 0.5
        or evidence.get("robust_agreeing", 0.0) < 0.5
        or distance > robust.bent_rival_cells
        or turn > robust.bent_rival_deg
    ):
        return None
    points = maps.second.points
    best = pool[0][1]
    rival = next(c for c in pool[1:] if _rms_between(c[1], best, points) > robust.distinct_cells)
    start = halfway(best, rival[1], points)
    compromise = _refined_on(_compromise_field(maps), maps.second, start, maps.params.compromise,
                             maps.params)  # fmt: skip
    farther = [
        candidate
        for candidate in pool
        if _rms_between(candidate[1], compromise, points) > robust.bent_rival_cells
    ]
    runners_up = _runners_up(
        [(maps.verify(compromise), compromise), *farther],
        points,
        (maps.params.distinct_cells, robust.distinct_cells),
    )
    result = _judged(maps, compromise, runners_up, hypotheses, timings)
    measures = {"bent_rival_distance_cells": distance, "bent_rival_turn_deg": turn}
    return replace(result, evidence={**result.evidence, **measures})


def _judged_first(
    maps: _Maps,
    pool: list[Candidate],
    hypotheses: tuple[Hypothesis, ...],
    timings: dict[str, float],
    *,
    by_net: bool = False,
) -> MergeResult:
    """The verdict on the pool's first placement, held against the rest.

    When the close fit's runner-up is why it is refused (its distinctiveness
    factor below one half), the runner-ups that only lacked the narrow
    refinement are dropped (:func:`_rivals_that_stay`) and the placement is
    judged again against the rest. ``by_net``: see :func:`_runners_up`.
    """
    params = maps.params
    distances = (params.distinct_cells, params.robust.distinct_cells)
    runners_up = _runners_up(pool, maps.second.points, distances, by_net=by_net)
    result = _judged(maps, pool[0][1], runners_up, hypotheses, timings, compromise=True)
    if result.accepted or result.evidence.get("close_distinct", 1.0) >= 0.5:
        return result
    staying = _rivals_that_stay(maps, pool)
    if len(staying) == len(pool):
        return result
    runners_up = _runners_up(staying, maps.second.points, distances, by_net=by_net)
    again = _judged(maps, staying[0][1], runners_up, hypotheses, timings, compromise=True)
    return again if again.accepted else result


def _rivals_that_stay(maps: _Maps, pool: list[Candidate]) -> list[Candidate]:
    """The pool without the runner-ups that, refined as the winner was, land on it.

    The schedule refines only its best few on its narrow fields
    (:data:`merging.params.DEFAULT_STAGES`); a placement left on the wide
    fields can lie 4-30 cells along a corridor from the winner, whose door or
    cross wall the wide fields barely see, and explain about as much. Refined
    on the narrow fields (:func:`_finished`), such a runner-up comes back to
    within ``TomographicParams.distinct_cells`` of the winner: the same answer
    unfinished, not a rival. Runner-ups are taken best first, and the first
    that stays apart ends the walk (those after it are kept unrefined).
    """
    distinct = maps.params.distinct_cells
    points = maps.second.points
    best = pool[0][1]
    kept = [pool[0]]
    rest = pool[1:]
    for k, candidate in enumerate(rest):
        if _rms_between(candidate[1], best, points) > distinct:
            finished = _finished(maps, candidate)
            if _rms_between(finished[1], best, points) > distinct:
                return kept + rest[k:]
            continue
        kept.append(candidate)
    return kept


def _close_alternative(maps: _Maps, pool: list[Candidate]) -> int | None:
    """Index of the pool's placement (after the first) that explains the most net wall
    cells among those whose walls meet within a cell (``TomographicParams.close_alternative``
    of the fit) and that lie farther than ``distinct_cells`` from the first; None if none."""
    params = maps.params
    best = pool[0][1]
    chosen, most = None, 0.0
    for k, (check, matrix) in enumerate(pool[1:], start=1):
        if check.quality < params.close_alternative or check.net <= most:
            continue
        if _rms_between(matrix, best, maps.second.points) > params.distinct_cells:
            chosen, most = k, check.net
    return chosen


def _finished(maps: _Maps, candidate: Candidate) -> Candidate:
    """``candidate`` refined on the narrow fields the winner of the schedule was refined on.

    The schedule refines only its best few on its narrow fields
    (:data:`merging.params.DEFAULT_STAGES`); a placement of the pool judged
    after the winner may have seen only the widest field's first steps, a
    cell or two from its optimum, and over a small overlap that becomes two
    cells or more at map 2's far walls.
    """
    for stage in maps.params.stages[1:]:
        candidate = maps.refine(candidate, stage)
    return candidate


def _runners_up(
    pool: list[Candidate],
    points: NDArray[np.float64],
    distances: tuple[float, float],
    *,
    by_net: bool = False,
) -> tuple[Candidate | None, Candidate | None]:
    """The best candidates after the first that move ``points`` farther from where it
    puts them than each of ``distances`` (cells RMS); None where there is none.

    With ``by_net``, the close fit's rival (the first) is the one of those farther than
    ``distances[0]`` that explains the most net wall cells, wherever the ranking put it:
    for a placement chosen by that measure (:func:`_close_alternative`), which the
    ranking did not prefer, the rival that explains about as much is what makes it
    ambiguous (a corridor whose doors repeat holds two exact fits of a small overlap,
    which the ranking may put far apart).
    """
    best = pool[0][1]
    found: list[Candidate | None] = [None, None]
    for candidate in pool[1:]:
        apart = _rms_between(candidate[1], best, points)
        for k, distance in enumerate(distances):
            if apart <= distance:
                continue
            current = found[k]
            if current is None or (k == 0 and by_net and candidate[0].net > current[0].net):
                found[k] = candidate
        if not by_net and all(entry is not None for entry in found):
            break
    return found[0], found[1]


def _search(maps: _Maps, factor: int, timings: dict[str, float]) -> list[Candidate]:
    """Steps 1-4: rotation and translation hypotheses, screened and refined; the winner first.

    Adds the seconds of each step to ``timings``.
    """
    params = maps.params
    clock = time.perf_counter()

    def lap(step: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[step] = now - clock
        clock = now

    thetas, coarse1, coarse2 = _rotation_hypotheses(maps, factor)
    lap("rotation")
    candidates = _translation_hypotheses(coarse1, coarse2, thetas, params)
    lap("translation")
    screened = _screened(maps, candidates)
    lap("verify")
    pool = _refined(maps, screened, factor)
    lap("refine")
    return pool


def _mirror_search(
    maps: _Maps, best: NDArray[np.float64], timings: dict[str, float]
) -> MirrorSearch:
    """A search for the mirror image of the evidence for ``best`` (:mod:`merging.evidence.mirror`).

    Run when called: steps 1-4 for the part of map 2 that ``best`` lays on
    map 1, seen in a mirror, on map 1's cells around the overlap
    (:func:`merging.evidence.mirror.twin_ground`; the whole map 1, whose fields the
    first search began, when that is nearly all of it).
    Its seconds go to ``timings["mirror"]``.
    """

    def search() -> MirrorCandidates:
        clock = time.perf_counter()
        params = maps.params
        # Keep every wall and clear cell the evidence inside the overlap is counted
        # against, at the widest tolerance a way of vouching uses.
        widest = max(
            params.verify.near_radius, params.confidence.fit_tolerance, params.robust.tolerance
        )
        margin = params.verify.conflict_clearance + widest
        part = mirrored_part(maps.first, maps.second, best, margin=margin, params=params.verify)
        lighter = replace(
            params,
            stages=params.mirror_stages,
            translation=replace(
                params.translation, significant_peaks=params.mirror_significant_peaks
            ),
        )
        ground = twin_ground(maps.first, part, params=params.verify)
        if ground is None:
            twin_maps = _Maps(maps.first, part.mirrored, lighter, begun=maps)
            into_first = np.eye(3)
        else:
            twin_maps = _Maps(ground[0], part.mirrored, lighter)
            into_first = translation_matrix(ground[1])
        factor = coarse_factor(
            twin_maps.first.shape, part.mirrored.shape, coarse_cells=params.translation.coarse_cells
        )
        pool = _search(twin_maps, factor, {})
        found = MirrorCandidates(part, tuple(into_first @ m for _, m in pool))
        timings["mirror"] = time.perf_counter() - clock
        return found

    return search


def _judged(
    maps: _Maps,
    best: NDArray[np.float64],
    runners_up: tuple[Candidate | None, Candidate | None],
    hypotheses: tuple[Hypothesis, ...],
    timings: dict[str, float],
    *,
    mirror_check: bool = True,
    compromise: bool = False,
) -> MergeResult:
    """The result for ``best``: its confidence, the verdict and, when refused, why.

    ``runners_up`` are the best placements different from ``best`` for the
    close fit and for the robust evidence (:func:`merging.evidence.verdict.judge`).
    With ``mirror_check``, the verdict searches for the mirror image of the
    evidence, for a placement it would otherwise accept. With
    ``compromise``, an accepted placement of maps that bend against each
    other is moved to the best rigid compromise over the whole overlap
    (:func:`_compromise`).
    """
    clock = time.perf_counter()
    mirror = _mirror_search(maps, best, timings) if mirror_check else None
    restarts = _TurnedRestarts(maps, best)
    runner_up, far_runner_up = runners_up
    verdict = judge(
        maps.first,
        maps.second,
        maps.smoothed,
        best,
        runner_up,
        maps.params,
        mirror,
        far_runner_up=far_runner_up,
        turn_returns=restarts.farthest,
        slide_returns=partial(_slide_return, maps, best),
    )
    evidence = verdict.evidence
    confidence, accepted, reason = verdict.confidence, verdict.accepted, verdict.reason
    if verdict.accepted and verdict.loose:
        # Held loosely: the rasterised walls may pull it aside.
        between, factor, gap = _both_ways(maps, best)
        evidence = {**evidence, "reverse_gap_cells": gap, "close_reverse": factor}
        confidence *= factor
        accepted = confidence >= maps.params.confidence.accept
        if accepted:
            best = between
        else:
            reason = reverse_reason(gap, confidence, maps.params.confidence)
    if compromise and accepted and verdict.bent:
        best, moved = _compromise(maps, best)
        evidence = {**evidence, "compromise_moved_cells": moved}
    elif compromise and accepted:
        rival = _turned_rival(maps, restarts.best, restarts)
        if rival is not None:
            factor, measures = _rival_factor(maps, restarts.best, rival)
            evidence = {**evidence, **measures}
            confidence *= factor
            accepted = confidence >= maps.params.confidence.accept
            if not accepted:
                reason = ambiguity_reason(
                    measures["near_rival_distance_cells"], measures["near_rival_turn_deg"]
                )
    timings["judge"] = time.perf_counter() - clock - timings.get("mirror", 0.0)
    return MergeResult(
        matrix=best,
        confidence=confidence,
        accepted=accepted,
        method="tomographic",
        hypotheses=hypotheses,
        timings=timings,
        reason=reason,
        evidence=evidence,
    )


class _TurnedRestarts:
    """The narrow refinement restarted from a placement turned a little about its overlap.

    A small overlap holds map 2's far walls by a lever: a turn moving them
    two cells moves the overlap's walls by a fraction of one, which counting
    walls cell by cell cannot see. Whether the overlap holds the turn is
    asked of the refinement itself: ``best`` is turned about the centroid
    of map 2's walls that meet map 1's, by the angles moving all of map 2's
    walls ``TomographicParams.near_rival_turns`` cells RMS either way, and
    each start is refined on the narrow fields to the optimum it leads to.
    Run once, when first asked, for both uses: the turn is held when every
    start comes back (:meth:`farthest`, :func:`merging.evidence.verdict.judge`),
    and an optimum of its own elsewhere is a rival (:func:`_turned_rival`).
    """

    __slots__ = ("_found", "_maps", "best")

    def __init__(self, maps: _Maps, best: NDArray[np.float64]):
        self._maps, self.best = maps, best
        self._found: list[Candidate] | None = None

    def found(self) -> list[Candidate]:
        """The optimum each turned start led to (none when no walls meet)."""
        if self._found is None:
            self._found = self._restart()
        return self._found

    def farthest(self) -> float:
        """How far (cells RMS over map 2's walls) the farthest restart ended from ``best``;
        ``inf`` when no walls meet to turn about."""
        found = self.found()
        if not found:
            return float("inf")
        points = self._maps.second.points
        return max(_rms_between(matrix, self.best, points) for _, matrix in found)

    def _restart(self) -> list[Candidate]:
        maps, best = self._maps, self.best
        params = maps.params
        landed = apply_transform(best, maps.second.points)
        meeting = meeting_walls(maps.first, landed)
        if not meeting.any():
            return []
        pivot = landed[meeting].mean(axis=0)
        radius = float(np.sqrt(np.mean(np.sum((landed - pivot) ** 2, axis=1))))
        if radius <= 0.0:
            return []
        found: list[Candidate] = []
        for moved in params.near_rival_turns:
            for sign in (-1.0, 1.0):
                turn = (
                    translation_matrix(pivot)
                    @ rigid_matrix(0.0, 0.0, sign * moved / radius)
                    @ translation_matrix(-pivot)
                )
                start = (maps.verify(turn @ best), turn @ best)
                for stage in params.stages[1:]:
                    start = maps.refine(start, stage, keep=False)
                found.append(start)
        return found


def _slide_return(maps: _Maps, best: NDArray[np.float64], within: float) -> float:
    """How far (cells RMS over map 2's walls) the narrow refinement ends from ``best`` when
    restarted from ``best`` slid by each small move :func:`merging.evidence.pinning.pinning`
    tries, the farthest moves first; stops at the first end farther than ``within``.

    A restart that ends farther, where the maps still explain more than
    they contradict but at least ``ConfidenceParams.slide_settled_share``
    less than at ``best`` (net wall cells), fell into a worse optimum: it is
    left out, as one that came back. One that ends in conflict (net at most
    zero) stayed out of the narrow field's reach and still counts.
    """
    points = maps.second.points
    held = maps.verify(best).net
    worse = held - maps.params.confidence.slide_settled_share * abs(held)
    farthest = 0.0
    for move in reversed(slides(maps.params.confidence)):
        start = (maps.verify(move @ best), move @ best)
        for stage in maps.params.stages[1:]:
            start = maps.refine(start, stage, keep=False)
        distance = _rms_between(start[1], best, points)
        if distance > within and 0.0 < start[0].net <= worse:
            continue
        farthest = max(farthest, distance)
        if farthest > within:
            break
    return farthest


def _turned_rival(
    maps: _Maps, best: NDArray[np.float64], restarts: _TurnedRestarts | None = None
) -> Candidate | None:
    """The placement explaining the most that refining ``best`` turned about the overlap
    finds farther than ``TomographicParams.near_rival_cells`` from it; None if none.

    Two optima of the narrow fields, one of them the truth, may lie a couple
    of cells apart at map 2's far walls and explain about as much
    (:class:`_TurnedRestarts`, whose runs ``restarts`` may already hold): an
    optimum a turned start leads to farther than ``near_rival_cells``, not
    the start kept, is a rival.
    """
    if restarts is None:
        restarts = _TurnedRestarts(maps, best)
    points = maps.second.points
    rival: Candidate | None = None
    for found in restarts.found():
        if _rms_between(found[1], best, points) <= maps.params.near_rival_cells:
            continue
        if rival is None or found[0].net > rival[0].net:
            rival = found
    return rival


def _both_ways(maps: _Maps, best: NDArray[np.float64]) -> tuple[NDArray[np.float64], float, float]:
    """``best`` checked by refining the other way round: the placement halfway between the
    two, the factor the confidence takes, and how far apart they were (cells RMS).

    The refinement carries one map's walls down the other's smoothed walls,
    so where the overlap is small a turned map's rasterised walls (a
    staircase along a slanted wall) can pull it a cell or two aside, the
    farther the longer map 2's lever. Refining map 1 onto map 2 from the
    inverse of ``best`` on the same narrow fields meets the other map's
    staircase instead: the two answers straddle the truth, and how far
    apart they land map 2's walls says how well the overlap holds the
    placement. The factor is the logistic of ``ConfidenceParams.reverse_gap_cells``
    (the accuracy a merge is asked for) minus that distance, ``reverse_gap_width``
    wide; the placement reported lays map 2's walls halfway between.
    """
    params = maps.params
    reverse = _Maps(maps.second, maps.first, params)
    start = np.asarray(np.linalg.inv(best), dtype=np.float64)
    found = (reverse.verify(start), start)
    for stage in params.stages[1:]:
        found = reverse.refine(found, stage, keep=False)
    other = np.asarray(np.linalg.inv(found[1]), dtype=np.float64)
    points = maps.second.points
    gap = _rms_between(other, best, points)
    confidence = params.confidence
    factor = float(expit((confidence.reverse_gap_cells - gap) / confidence.reverse_gap_width))
    return halfway(best, other, points), factor, gap


def _rival_factor(
    maps: _Maps, best: NDArray[np.float64], rival: Candidate
) -> tuple[float, dict[str, float]]:
    """The distinctiveness factor of ``best`` against a near ``rival`` (the close fit's,
    :func:`merging.evidence.verify.confidence_factors`) and the measures behind it."""
    confidence = maps.params.confidence
    check = maps.verify(best)
    share = max(rival[0].net, 0.0) / check.net if check.net > 0 else 1.0
    factor = float(expit(((1.0 - share) - confidence.distinct_margin) / confidence.distinct_width))
    turn = matrix_to_pose(best)[2] - matrix_to_pose(rival[1])[2]
    measures = {
        "near_rival_share": share,
        "near_rival_distance_cells": _rms_between(rival[1], best, maps.second.points),
        "near_rival_turn_deg": float(np.degrees(abs(wrap_angle(turn)))),
        "close_near_distinct": factor,
    }
    return factor, measures


def _compromise(maps: _Maps, best: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """The best rigid compromise over the whole overlap of maps that bend, and how far it
    moved map 2's walls (cells RMS).

    The refinement's last fields, a cell wide or less, hold map 2 where one
    part of the overlap fits exactly, and the parts that bend away pull on
    nothing. Fields as wide as the bending (``TomographicParams.compromise``)
    let every part of the overlap pull, and the placement settles where the
    whole overlap fits best: the rigid transform a least-squares fit of
    corresponding points over the whole floor would give. A compromise
    farther than the bending (``RobustParams.distinct_cells``) is another
    answer, not the same one bent; then ``best`` is kept.
    """
    moved = _refined_on(_compromise_field(maps), maps.second, best, maps.params.compromise,
                        maps.params)  # fmt: skip
    distance = _rms_between(moved, best, maps.second.points)
    if distance > maps.params.robust.distinct_cells:
        return best, 0.0
    return moved, distance


def _compromise_field(maps: _Maps) -> SmoothedMap:
    """Map 1's fields for the compromise's widths (``TomographicParams.compromise``).

    At full resolution: a field computed on the half-resolution grid is off
    by up to a few cells at these widths, which the search's finer fields
    correct afterwards and the compromise, the last refinement, would not.
    """
    return SmoothedMap(
        maps.first.walls,
        maps.first.shape,
        downsample_from_sigma=2.0 * max(maps.params.compromise.sigmas),
        whole_field_share=maps.params.gauss_newton.whole_field_share,
    )


def refine_from(
    map1: OccupancyGrid | NDArray[Any],
    map2: OccupancyGrid | NDArray[Any],
    matrix: NDArray[np.float64],
    *,
    params: TomographicParams = DEFAULT_PARAMS,
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

    Parameters
    ----------
    map1, map2 : OccupancyGrid or (rows, cols) array
        Grids in the ROS coding, of one resolution (cells are matched as
        they are).
    matrix : (3, 3) float ndarray
        The starting transform, map 2 cells -> map 1 cells.
    params : TomographicParams
        Settings; ``from_start`` is the refinement run.

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
    matrix = as_matrix(matrix)
    if abs(np.linalg.det(matrix[:2, :2])) < 1e-9:
        raise ValueError(
            "matrix is singular (it folds map 2 onto a line); give a rigid transform, "
            "map 2 cells -> map 1 cells"
        )
    if not isinstance(params, TomographicParams):
        raise TypeError(f"params must be a TomographicParams, got {type(params).__name__}")
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
    maps = _Maps(first, second, params)
    into1, out_of2 = translation_matrix(offset1), translation_matrix(-offset2)
    start = np.linalg.inv(into1) @ np.asarray(matrix, dtype=float) @ np.linalg.inv(out_of2)
    refined = maps.refine((maps.verify(start), start), params.from_start)
    timings = {"refine": time.perf_counter() - clock}
    check, best = refined[0], into1 @ refined[1] @ out_of2
    hypotheses = (
        Hypothesis(best, rank(check), check.agreement, check.conflict, int(check.overlap)),
    )
    result = _judged(maps, refined[1], (None, None), hypotheses, timings, mirror_check=False)
    timings["total"] = time.perf_counter() - clock
    return _with_metres(replace(result, matrix=best), map1, map2)


def _with_metres(result: MergeResult, map1: Any, map2: Any) -> MergeResult:
    """``result`` with its matrix in metres too, when both maps are OccupancyGrids."""
    if not (isinstance(map1, OccupancyGrid) and isinstance(map2, OccupancyGrid)):
        return result
    return replace(result, matrix_metres=cells_to_metres(result.matrix, map1, map2))


register_method("tomographic", params_type=TomographicParams)(tomographic_merge)
