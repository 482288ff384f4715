"""The default merger: the paper's tomographic ideas, made robust and fast.

The steps mirror section 3 of the paper, each strengthened where the paper's
version is fragile:

1. Rotation (section 3.1.1). Instead of one sinogram maximum (eq. 7), the
   whole translation-invariant angular spectra of the two sinograms are
   correlated (:mod:`merging.angular`); the strongest peaks, each with its
   180° twin, are the rotation hypotheses.
2. Translation (section 3.1.2). Instead of two partial sinograms (eqs.
   11-17), the evidence of every projection angle is pooled through the 2-D
   correlation of the maps (:mod:`merging.correlate`), with a penalty for
   walls landing on free space; each rotation yields several translations.
3. Search and objective (sections 3.2-3.3). Instead of Monte-Carlo sampling
   of a sorted-projection objective (eqs. 27-30), every hypothesis is scored
   by carrying each map's walls into the other (:mod:`merging.verify`), and
   the best are refined by Gauss-Newton to sub-cell, sub-degree accuracy
   (:mod:`merging.refine`).
4. Confidence. The fit, the amount of agreeing wall and the margin over the
   best *different* hypothesis give a confidence; only confident results
   are accepted.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.angular import angular_spectrum, rotation_correlation, rotation_peaks
from merging.api import register_method
from merging.correlate import coarse_factor, coarsen, translation_peaks
from merging.refine import (
    ITERATIONS,
    REFINE_POINTS,
    SHARP_ITERATIONS,
    SIGMA_SCHEDULE,
    SmoothedMap,
    constraint_strength,
    refine_transform,
)
from merging.result import Hypothesis, MergeResult
from merging.transforms import apply_transform
from merging.verify import (
    ACCEPT_CONFIDENCE,
    PreparedMap,
    Verification,
    confidence,
    prepare_map,
    verify,
)

ROTATION_PEAKS = 3
"""Rotation peaks (modulo 180°) kept; with their twins, twice as many hypotheses.
In every real-map window pair examined the true rotation was among the three
strongest (rectilinear buildings put its 90° neighbours next)."""
TRANSLATION_PEAKS = 3
"""Translations kept per rotation hypothesis."""
REFINED = 3
"""Best-verified hypotheses that are refined before the final choice."""
CORRELATION_REFINED = 2
"""Hypotheses with the strongest correlation that are refined too."""
KEEP_REFINED_MARGIN = 0.02
"""Score by which a refined transform may verify worse than its start and still be
kept: about one wall cell in fifty landing one cell farther out."""
WIDE_POINTS = 600
"""Map 2 cells moved in the first, widest refinement round: enough to bring a
coarse hypothesis within the next field's reach."""
SHARPENED = 2
"""Refined hypotheses, best first, that are refined on to the one-cell field:
the others only need the widest field's first steps to be ranked below them,
and only the winner is taken to the finest field."""
SCREEN_STRIDE = 4
"""Hypotheses are screened with every fourth verification point (about 1000 per
map), enough to rank them; the refined ones are verified with all."""
DISTINCT_CELLS = 4.0
"""Two transforms moving map 2's cells further apart than this (RMS) are different
answers; closer ones are the same answer found twice."""


def rank(check: Verification) -> float:
    """The score hypotheses are ranked by (:attr:`Verification.score`)."""
    return check.score


def _refine_if_better(
    smoothed: SmoothedMap,
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    sigmas: tuple[float, ...],
    iterations: int = ITERATIONS,
    *,
    local: bool = False,
    start: Verification | None = None,
    max_points: int = REFINE_POINTS,
) -> tuple[Verification, NDArray[np.float64]]:
    """Refine ``matrix``; keep the start only when the refined one verifies clearly worse.

    ``start`` is the start's full verification when already known.
    Refinement may settle on a nearby optimum that explains the maps worse
    (two close parallel walls blurred into one by a wide field). Within
    :data:`KEEP_REFINED_MARGIN` the refined transform wins: verification
    tolerates a cell of misfit, so it cannot rank finer than that.
    """
    better = refine_transform(
        smoothed,
        second,
        matrix,
        sigmas=sigmas,
        iterations=iterations,
        local=local,
        max_points=max_points,
    )
    before = start if start is not None else verify(first, second, matrix, space=False)
    after = verify(first, second, better, space=False)
    if rank(after) >= rank(before) - KEEP_REFINED_MARGIN:
        return after, better
    return before, matrix


def _rms_between(a: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64]):
    diff = apply_transform(a, points) - apply_transform(b, points)
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def _rotation_hypotheses(
    first: PreparedMap, second: PreparedMap, factor: int
) -> tuple[list[float], Any, Any]:
    """Rotation hypotheses (radians, for map 2 -> map 1), from angular spectra."""
    coarse1, coarse2 = coarsen(first, factor), coarsen(second, factor)
    size = int(2 ** np.ceil(np.log2(max(*coarse1.walls.shape, *coarse2.walls.shape, 8))))
    spectrum1 = angular_spectrum(coarse1.walls, size=size)
    spectrum2 = angular_spectrum(coarse2.walls, size=size)
    peaks = rotation_peaks(rotation_correlation(spectrum1, spectrum2), count=ROTATION_PEAKS)
    thetas: list[float] = []
    for angle_deg, _ in peaks:
        # Map 2 shows map 1's structure turned by +angle; turning it back is -angle.
        theta = -np.deg2rad(angle_deg)
        thetas.extend([theta, theta + np.pi])
    return thetas, coarse1, coarse2


def tomographic_merge(
    cells1: NDArray[np.int8], cells2: NDArray[np.int8], *, rng: np.random.Generator, **options: Any
) -> MergeResult:
    """Estimate the map transformation matrix of map 2 onto map 1 (the default method).

    Deterministic: ``rng`` is accepted for the common signature and unused.
    See the module docstring for the steps.
    """
    if options:
        raise TypeError(f"the tomographic method takes no options, got {sorted(options)}")
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    first, second = prepare_map(cells1), prepare_map(cells2)
    factor = coarse_factor(cells1.shape, cells2.shape)
    timings["prepare"] = time.perf_counter() - clock

    clock = time.perf_counter()
    thetas, coarse1, coarse2 = _rotation_hypotheses(first, second, factor)
    timings["rotation"] = time.perf_counter() - clock

    clock = time.perf_counter()
    candidates: list[NDArray[np.float64]] = []
    correlation: list[float] = []
    for theta in thetas:
        for matrix, value in translation_peaks(coarse1, coarse2, theta, count=TRANSLATION_PEAKS):
            candidates.append(matrix)
            correlation.append(value)
    timings["translation"] = time.perf_counter() - clock

    clock = time.perf_counter()
    screened = [
        (verify(first, second, m, stride=SCREEN_STRIDE, space=False), m) for m in candidates
    ]
    # Refine the best by verification and the best by correlation: before
    # refinement a true but slightly misaligned transform can fit worse than
    # one that lays a single outer corner on a corner, which the correlation
    # (weighing how much overlaps) does not favour.
    by_correlation = [screened[i] for i in np.argsort(correlation)[::-1][:CORRELATION_REFINED]]
    by_score = sorted(screened, key=lambda vm: -rank(vm[0]))
    checked = by_correlation + [
        vm for vm in by_score if not any(vm[1] is c[1] for c in by_correlation)
    ]
    timings["verify"] = time.perf_counter() - clock

    clock = time.perf_counter()
    # Refinement in three rounds, each on fewer candidates and finer fields:
    # all on the widest field, the finalists on to one cell, the winner to the end.
    smoothed = SmoothedMap(first.walls, first.shape)
    widest, finest = SIGMA_SCHEDULE[:1], SIGMA_SCHEDULE[-1:]
    refined = [
        _refine_if_better(smoothed, first, second, m, widest, max_points=WIDE_POINTS)
        for _, m in checked[: REFINED + CORRELATION_REFINED]
    ]
    refined.sort(key=lambda vm: -rank(vm[0]))
    refined[:SHARPENED] = [
        _refine_if_better(
            smoothed,
            first,
            second,
            m,
            SIGMA_SCHEDULE[1:-1],
            SHARP_ITERATIONS,
            local=True,
            start=check,
        )
        for check, m in refined[:SHARPENED]
    ]
    rest = [
        (verify(first, second, m, space=False), m)
        for _, m in checked[REFINED + CORRELATION_REFINED : REFINED + CORRELATION_REFINED + 3]
    ]
    pool = sorted(refined + rest, key=lambda vm: -rank(vm[0]))
    pool[0] = _refine_if_better(
        smoothed, first, second, pool[0][1], finest, SHARP_ITERATIONS, local=True, start=pool[0][0]
    )
    timings["refine"] = time.perf_counter() - clock

    best = pool[0][1]
    best_check = verify(first, second, best)  # with the shared open space, for confidence
    runner_up = next(
        (v for v, m in pool[1:] if _rms_between(m, best, second.points) > DISTINCT_CELLS), None
    )
    strength = constraint_strength(smoothed, second, best, local=True)
    score = confidence(best_check, runner_up, strength=strength)
    hypotheses = tuple(
        Hypothesis(m, rank(v), v.agreement, v.conflict, int(v.overlap)) for v, m in pool
    )
    accepted = score >= ACCEPT_CONFIDENCE
    runner = "none" if runner_up is None else f"{runner_up.net:.0f}"
    reason = ""
    if not accepted:
        reason = (
            f"confidence {score:.2f} below {ACCEPT_CONFIDENCE}: agreement "
            f"{best_check.agreement:.2f}, conflict {best_check.conflict:.2f}, "
            f"{best_check.agreeing:.0f} matching wall cells, net {best_check.net:.0f} "
            f"against the runner-up's {runner}, constraint {strength:.1f}"
        )
    return MergeResult(
        matrix=best,
        confidence=score,
        accepted=accepted,
        method="tomographic",
        hypotheses=hypotheses,
        timings=timings,
        reason=reason,
    )


register_method("tomographic")(tomographic_merge)
