"""Steps 5-6 of the default method: the verdict on the search's pool.

The pool's first placement is judged (:func:`judged`, by
:func:`merging.evidence.verdict.judge`) against the best different ones
(:func:`runners_up_of`), with the second looks of
:mod:`merging.tomographic.restarts` and, for a placement about to be
accepted, the mirror check (:func:`mirror_search`). When it is refused, the
pool is asked again: without the runner-ups that only lacked the narrow
refinement (:func:`judged_first`, :func:`rivals_that_stay`), as the rigid
compromise between two placements of maps that bend (:func:`bent_compromise`),
and for a placement whose walls meet exactly that the ranking put lower
(:func:`close_alternative`). :func:`verdict_on_pool` walks that sequence.
"""

from __future__ import annotations

import time
from dataclasses import replace
from functools import partial

import numpy as np
from numpy.typing import NDArray

from merging.evidence.mirror import MirrorCandidates, mirrored_part, twin_ground
from merging.evidence.verdict import MirrorSearch, ambiguity_reason, judge, reverse_reason
from merging.params import TomographicParams
from merging.result import Hypothesis, MergeResult
from merging.tomographic.candidates import Candidate, SearchMaps, finished, refined_on, rms_between
from merging.tomographic.correlate import coarse_factor
from merging.tomographic.hypotheses import search_pool
from merging.tomographic.restarts import (
    TurnedRestarts,
    both_ways,
    compromise_field,
    rigid_compromise,
    rival_factor,
    slide_return,
    turned_rival,
)
from merging.transforms import halfway, translation_matrix


def bent_compromise(
    maps: SearchMaps,
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
    the placements farther than that, its constraint strength measured on
    those fields too (:func:`with_compromise_curvature`). Asked only of a
    placement with the walls meeting that the robust evidence asks (its
    ``agreeing`` factor passing), which low-overlap window pairs and the
    small maps of exploration do not reach: for any other the compromise
    could not be vouched for either.
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
    rival = next(c for c in pool[1:] if rms_between(c[1], best, points) > robust.distinct_cells)
    start = halfway(best, rival[1], points)
    compromise = refined_on(compromise_field(maps), maps.second, start, maps.params.compromise,
                             maps.params)  # fmt: skip
    farther = [
        candidate
        for candidate in pool
        if rms_between(candidate[1], compromise, points) > robust.bent_rival_cells
    ]
    runners_up = runners_up_of(
        [(maps.verify(compromise), compromise), *farther],
        points,
        (maps.params.distinct_cells, robust.distinct_cells),
    )
    judging = SearchMaps(maps.first, maps.second, with_compromise_curvature(maps.params), maps)
    result = judged(judging, compromise, runners_up, hypotheses, timings)
    measures = {"bent_rival_distance_cells": distance, "bent_rival_turn_deg": turn}
    return replace(result, evidence={**result.evidence, **measures})


def with_compromise_curvature(params: TomographicParams) -> TomographicParams:
    """``params`` with the constraint strength of the robust evidence also measured on the
    fields the rigid compromise of maps that bend is refined on.

    The compromise is refined on fields as wide as the bending
    (``TomographicParams.compromise``, 8 and 4 cells), between two
    placements that each fit one part of the overlap. On fields of 1, 2 and
    4 cells each part pulls its own way and no curvature is left at the
    compromise, so it was refused as a slide; its strength is measured on
    its widest field too (``RobustParams.strength_widths`` widened). A
    corridor that lets the maps slide stays weak at every width.

    The walls must still meet within ``RobustParams.tolerance``. Allowed
    the compromise's widest field instead, the Halmstad F5 sessions
    (``scripts/bench_cycles.py``) gained two more pairs, but an E5 pair
    without an annotated transform (``E5_08|E5_12``) was accepted 33-48
    cells from the chains of annotated ones, and linking all E5 sessions at
    once (``scripts/bench_linking.py``) then placed one pair 35 cells off
    (with the robust tolerance: none).
    """
    robust, sigmas = params.robust, params.compromise.sigmas
    widths = tuple(sorted({*robust.strength_widths, *sigmas}))
    return replace(params, robust=replace(robust, strength_widths=widths))


def judged_first(
    maps: SearchMaps,
    pool: list[Candidate],
    hypotheses: tuple[Hypothesis, ...],
    timings: dict[str, float],
    *,
    by_net: bool = False,
) -> MergeResult:
    """The verdict on the pool's first placement, held against the rest.

    When the close fit's runner-up is why it is refused (its distinctiveness
    factor below one half), the runner-ups that only lacked the narrow
    refinement are dropped (:func:`rivals_that_stay`) and the placement is
    judged again against the rest. ``by_net``: see :func:`runners_up_of`.
    """
    params = maps.params
    distances = (params.distinct_cells, params.robust.distinct_cells)
    runners_up = runners_up_of(pool, maps.second.points, distances, by_net=by_net)
    result = judged(maps, pool[0][1], runners_up, hypotheses, timings, compromise=True)
    if result.accepted or result.evidence.get("close_distinct", 1.0) >= 0.5:
        return result
    staying = rivals_that_stay(maps, pool)
    if len(staying) == len(pool):
        return result
    runners_up = runners_up_of(staying, maps.second.points, distances, by_net=by_net)
    again = judged(maps, staying[0][1], runners_up, hypotheses, timings, compromise=True)
    return again if again.accepted else result


def rivals_that_stay(maps: SearchMaps, pool: list[Candidate]) -> list[Candidate]:
    """The pool without the runner-ups that, refined as the winner was, land on it.

    The schedule refines only its best few on its narrow fields
    (:data:`merging.params.DEFAULT_STAGES`); a placement left on the wide
    fields can lie 4-30 cells along a corridor from the winner, whose door or
    cross wall the wide fields barely see, and explain about as much. Refined
    on the narrow fields (:func:`finished`), such a runner-up comes back to
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
        if rms_between(candidate[1], best, points) > distinct:
            refined = finished(maps, candidate)
            if rms_between(refined[1], best, points) > distinct:
                return kept + rest[k:]
            continue
        kept.append(candidate)
    return kept


def close_alternative(maps: SearchMaps, pool: list[Candidate]) -> int | None:
    """Index of the pool's placement (after the first) that explains the most net wall
    cells among those whose walls meet within a cell (``TomographicParams.close_alternative``
    of the fit) and that lie farther than ``distinct_cells`` from the first; None if none."""
    params = maps.params
    best = pool[0][1]
    chosen, most = None, 0.0
    for k, (check, matrix) in enumerate(pool[1:], start=1):
        if check.quality < params.close_alternative or check.net <= most:
            continue
        if rms_between(matrix, best, maps.second.points) > params.distinct_cells:
            chosen, most = k, check.net
    return chosen


def runners_up_of(
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
    for a placement chosen by that measure (:func:`close_alternative`), which the
    ranking did not prefer, the rival that explains about as much is what makes it
    ambiguous (a corridor whose doors repeat holds two exact fits of a small overlap,
    which the ranking may put far apart).
    """
    best = pool[0][1]
    found: list[Candidate | None] = [None, None]
    for candidate in pool[1:]:
        apart = rms_between(candidate[1], best, points)
        for k, distance in enumerate(distances):
            if apart <= distance:
                continue
            current = found[k]
            if current is None or (k == 0 and by_net and candidate[0].net > current[0].net):
                found[k] = candidate
        if not by_net and all(entry is not None for entry in found):
            break
    return found[0], found[1]


def mirror_search(
    maps: SearchMaps, best: NDArray[np.float64], timings: dict[str, float]
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
            twin_maps = SearchMaps(maps.first, part.mirrored, lighter, begun=maps)
            into_first = np.eye(3)
        else:
            twin_maps = SearchMaps(ground[0], part.mirrored, lighter)
            into_first = translation_matrix(ground[1])
        factor = coarse_factor(
            twin_maps.first.shape, part.mirrored.shape, coarse_cells=params.translation.coarse_cells
        )
        pool = search_pool(twin_maps, factor, {})
        found = MirrorCandidates(part, tuple(into_first @ m for _, m in pool))
        timings["mirror"] = time.perf_counter() - clock
        return found

    return search


def judged(
    maps: SearchMaps,
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
    (:func:`rigid_compromise`).
    """
    clock = time.perf_counter()
    mirror = mirror_search(maps, best, timings) if mirror_check else None
    restarts = TurnedRestarts(maps, best)
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
        slide_returns=partial(slide_return, maps, best),
    )
    evidence = verdict.evidence
    confidence, accepted, reason = verdict.confidence, verdict.accepted, verdict.reason
    if verdict.accepted and verdict.loose:
        # Held loosely: the rasterised walls may pull it aside.
        between, factor, gap = both_ways(maps, best)
        evidence = {**evidence, "reverse_gap_cells": gap, "close_reverse": factor}
        confidence *= factor
        accepted = confidence >= maps.params.confidence.accept
        if accepted:
            best = between
        else:
            reason = reverse_reason(gap, confidence, maps.params.confidence)
    if compromise and accepted and verdict.bent:
        best, moved = rigid_compromise(maps, best)
        evidence = {**evidence, "compromise_moved_cells": moved}
    elif compromise and accepted:
        rival = turned_rival(maps, restarts.best, restarts)
        if rival is not None:
            factor, measures = rival_factor(maps, restarts.best, rival)
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


def verdict_on_pool(
    maps: SearchMaps,
    pool: list[Candidate],
    hypotheses: tuple[Hypothesis, ...],
    timings: dict[str, float],
) -> MergeResult:
    """Steps 5-6 on a pool, its first placement the one to judge: the default's verdict.

    The first placement is judged against the rest (:func:`judged_first`);
    refused, as the rigid compromise with a near rival of maps that bend
    (:func:`bent_compromise`); and still refused, the placement whose walls
    meet exactly that the ranking put lower (:func:`close_alternative`) is
    judged against all the others. The first accepted is the answer, else the
    first placement's refusal.
    """
    result = judged_first(maps, pool, hypotheses, timings)
    if result.accepted:
        return result
    bent = bent_compromise(maps, pool, hypotheses, timings, result.evidence)
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
    close = close_alternative(maps, pool)
    if close is None:
        return result
    pool = [finished(maps, pool[close]), *pool[:close], *pool[close + 1 :]]
    alternative = judged_first(maps, pool, hypotheses, timings, by_net=True)
    return alternative if alternative.accepted else result
