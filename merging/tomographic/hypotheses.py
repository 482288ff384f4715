"""Steps 1-4 of the default method: hypotheses, screened and refined into a ranked pool.

1. Rotation: the strongest peaks of the angular spectra's correlation
   (:mod:`merging.tomographic.angular`), each with its half-turn twin
   (:func:`rotation_hypotheses`).
2. Translation: for each rotation, the strongest and the most significant
   shifts of the pooled projection correlation
   (:mod:`merging.tomographic.correlate`, :func:`translation_hypotheses`).
3. Screening: the order in which the refinement admits the hypotheses
   (:func:`admission_order`).
4. Refinement: the schedule of :class:`~merging.params.RefineStage` rows,
   each refining fewer candidates on finer fields (:func:`refined_pool`).

:func:`search_pool` runs the four and returns the pool, the winner first
(:func:`search_hypotheses` steps 1-2, :func:`ranked_pool` steps 3-4); the
verdict on it is :mod:`merging.tomographic.judging`'s.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from merging.evidence.verify import verify
from merging.params import RefineStage, TomographicParams
from merging.tomographic.angular import angular_spectrum, rotation_correlation, rotation_peaks
from merging.tomographic.candidates import Candidate, SearchMaps, rank
from merging.tomographic.correlate import CoarseMap, Peak, coarsen, translation_peaks


def rotation_hypotheses(maps: SearchMaps, factor: int) -> tuple[list[float], CoarseMap, CoarseMap]:
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


def translation_hypotheses(
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


def admission_order(maps: SearchMaps, candidates: list[Peak]) -> list[NDArray[np.float64]]:
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


def refined_pool(
    maps: SearchMaps, screened: list[NDArray[np.float64]], factor: int
) -> list[Candidate]:
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


def search_hypotheses(maps: SearchMaps, factor: int, timings: dict[str, float]) -> list[Peak]:
    """Steps 1-2: the rotation hypotheses and, for each, the translation hypotheses.

    They depend on the maps, the coarse grid and the rotation and translation
    settings only, not on how the pool is ranked: a second ranking of the
    same maps (:func:`ranked_pool`) starts from them again. Adds the seconds
    of each step to ``timings``.
    """
    clock = time.perf_counter()
    thetas, coarse1, coarse2 = rotation_hypotheses(maps, factor)
    timings["rotation"] = time.perf_counter() - clock
    clock = time.perf_counter()
    candidates = translation_hypotheses(coarse1, coarse2, thetas, maps.params)
    timings["translation"] = time.perf_counter() - clock
    return candidates


def ranked_pool(
    maps: SearchMaps, candidates: list[Peak], factor: int, timings: dict[str, float]
) -> list[Candidate]:
    """Steps 3-4: ``candidates`` screened and refined, ranked by ``maps.params``; the winner
    first. Adds the seconds of each step to ``timings``."""
    clock = time.perf_counter()
    screened = admission_order(maps, candidates)
    timings["verify"] = time.perf_counter() - clock
    clock = time.perf_counter()
    pool = refined_pool(maps, screened, factor)
    timings["refine"] = time.perf_counter() - clock
    return pool


def search_pool(maps: SearchMaps, factor: int, timings: dict[str, float]) -> list[Candidate]:
    """Steps 1-4: rotation and translation hypotheses, screened and refined; the winner first.

    Adds the seconds of each step to ``timings``.
    """
    return ranked_pool(maps, search_hypotheses(maps, factor, timings), factor, timings)
