"""The paper's pipeline as written (sections 3.1-3.3), selectable as ``method="paper"``.

Each step is one function citing its equations; :func:`paper_merge` runs them
top to bottom. Where the paper leaves a choice open, the choice made here is
stated in the step's docstring. The search space (eqs. 18-26) and the
Monte-Carlo optimisation (eqs. 27-30) live in :mod:`merging.paper.monte_carlo`.

Sign convention. Our cells are ``(x, y) = (col, row)`` with counter-clockwise
angles and ``s = x cos α + y sin α`` (eq. 2). If map 2 shows map 1 turned by
φ, then ``α_2,max = α_1,max + φ`` and eq. (7) returns φ; the map
transformation matrix, which carries map 2 back onto map 1, rotates by -φ.
(The paper's images have rows growing downwards, which flips the sense of
rotation, so there eq. (8) applies +Δθ.)
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.api import register_method
from merging.evidence.refine import SmoothedMap, constraint_strength
from merging.evidence.verdict import CLOSE_FACTORS, refusal_reason
from merging.evidence.verify import ACCEPT_CONFIDENCE, confidence_factors, prepare_map, verify
from merging.grid import occupied_cells
from merging.paper.monte_carlo import monte_carlo_optimise, search_space
from merging.paper.sinogram import Sinogram, map_centre, sinogram
from merging.result import Hypothesis, MergeResult
from merging.transforms import rigid_matrix, translation_matrix
from merging.validators import boolean, whole_number

PAPER_ANGLES_DEG = np.arange(181.0)
"""0° <= α <= 180° (eqs. 4-5, 9), inclusive: eqs. (12) and (16) use α' = 180°."""


def sinogram_maximum(sino: Sinogram) -> tuple[float, float]:
    """``(s_max, α_max)``: location of the largest value of a sinogram (section 3.1.1)."""
    row, column = np.unravel_index(int(np.argmax(sino.values)), sino.values.shape)
    return float(row - sino.rho), float(sino.angles_deg[column])


def rotation_from_maxima(first: Sinogram, second: Sinogram) -> float:
    """Eq. (7): ``Δθ = α_2,max - α_1,max`` in degrees, in ``(-180, 180)``."""
    return sinogram_maximum(second)[1] - sinogram_maximum(first)[1]


def rotate_occupied(
    cells: NDArray[np.int8], theta: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eq. (8): rotate map 2's occupied cells by ``theta`` about its centre (eq. 6).

    The paper rotates the "alternative form" (the 3 x N_occ matrix of occupied
    cells); the centre is our choice, so that a small change of rotation
    moves the translation little, which section 3.3 relies on when it pairs
    every rotation sample with every translation sample.

    Returns
    -------
    rotated : (N, 2) float ndarray
        Rotated ``(x, y)``, shifted to start at 0 (the grid of ``M~_2``).
    to_rotated : (3, 3) float ndarray
        Matrix taking map 2's cells to ``M~_2``'s.
    """
    centre = np.asarray(map_centre(cells.shape))
    about = rigid_matrix(0.0, 0.0, theta) @ translation_matrix(-centre)
    points = occupied_cells(cells) @ about[:2, :2].T + about[:2, 2]
    low = np.floor(points.min(axis=0))
    return points - low, translation_matrix(-low) @ about


def axis_projections(points: NDArray[np.float64], shape: tuple[int, int]):
    """Partial sinograms at α' = 180° and 90° (eqs. 11-13) as x and y histograms.

    At α' = 180° the projection coordinate is ``s = -x`` and at 90° it is
    ``s = y``; read along increasing ``x`` and ``y`` they are the column and
    row histograms of the occupied cells, zero-padded to ``shape`` (the common
    size ``r_m x c_m`` of eqs. 12-13).
    """
    rows, cols = shape
    x = np.clip(np.rint(points[:, 0]).astype(np.intp), 0, cols - 1)
    y = np.clip(np.rint(points[:, 1]).astype(np.intp), 0, rows - 1)
    return (
        np.bincount(x, minlength=cols).astype(float),
        np.bincount(y, minlength=rows).astype(float),
    )


def cross_correlation(first: NDArray[np.float64], second: NDArray[np.float64]):
    """Eqs. (14)-(15): ``CC(τ) = Σ_k PS_1(k + τ) PS_2(k)`` for every lag.

    Returns
    -------
    lags : (L,) int ndarray
    values : (L,) float ndarray
        Normalised by the norms of both projections, so 1 is a perfect match.
    """
    values = np.correlate(first, second, mode="full")
    lags = np.arange(-(len(second) - 1), len(first))
    norm = np.linalg.norm(first) * np.linalg.norm(second)
    return lags, values / norm if norm > 0 else values


def coarse_translation(cells1: NDArray[np.int8], cells2: NDArray[np.int8], theta: float):
    """Eqs. (8)-(17): rotate map 2 by ``theta``, then ``Δx``, ``Δy`` by correlation.

    Returns
    -------
    matrix : (3, 3) float ndarray
        The coarse map transformation matrix, map 2 cells -> map 1 cells.
    correlations : ((lags, CCX), (lags, CCY))
        For the search space of eqs. (22)-(25).
    peak : float
        ``max CCX * max CCY``, used to choose between the two rotations that
        the 180° ambiguity leaves.
    """
    rotated, to_rotated = rotate_occupied(cells2, theta)
    points1 = occupied_cells(cells1)
    rows = int(max(cells1.shape[0], np.ceil(rotated[:, 1].max()) + 1))
    cols = int(max(cells1.shape[1], np.ceil(rotated[:, 0].max()) + 1))
    x1, y1 = axis_projections(points1, (rows, cols))
    x2, y2 = axis_projections(rotated, (rows, cols))
    lags_x, ccx = cross_correlation(x1, x2)
    lags_y, ccy = cross_correlation(y1, y2)
    dx = float(lags_x[int(np.argmax(ccx))])  # eq. (16)
    dy = float(lags_y[int(np.argmax(ccy))])  # eq. (17)
    matrix = rigid_matrix(dx, dy, 0.0) @ to_rotated
    return matrix, ((lags_x, ccx), (lags_y, ccy)), float(ccx.max() * ccy.max())


def paper_merge(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    *,
    rng: np.random.Generator,
    rotation_samples: int = 20,
    translation_samples: int = 50,
    saliency_points: int = 100,
    optimise: bool = True,
    **options: Any,
) -> MergeResult:
    """The tomographic merger of the paper, sections 3.1-3.3.

    Parameters
    ----------
    rotation_samples, translation_samples : int
        ``N_s,θ`` and ``N_s,xy`` of eqs. (27)-(28); the paper leaves them to
        the user. Every pair is evaluated, ``N_s`` in all.
    saliency_points : int
        ``K_d`` of eq. (29).
    optimise : bool
        Run the Monte-Carlo optimisation (section 3.3); without it the coarse
        MTM of section 3.1 is returned ("Proposed w/o MCO" of Table 3).

    The 180° ambiguity: a 0-180° sinogram cannot tell Δθ from Δθ ± 180°
    (``S(s, α + 180°) = S(-s, α)``), although the paper says it avoids it.
    Both are tried and the one whose partial sinograms correlate better
    (``max CCX * max CCY``) is kept. The paper gives no confidence: the
    common verification of :mod:`merging.evidence.verify` is attached, so its
    ``accepted`` means what it means for every method.
    """
    if options:
        raise TypeError(f"the paper method got unknown options {sorted(options)}")
    for name, value in (
        ("rotation_samples", rotation_samples),
        ("translation_samples", translation_samples),
        ("saliency_points", saliency_points),
    ):
        whole_number(value, name, minimum=1)
    boolean(optimise, "optimise")
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    sino1 = sinogram(cells1, angles_deg=PAPER_ANGLES_DEG)
    sino2 = sinogram(cells2, angles_deg=PAPER_ANGLES_DEG)
    delta_deg = rotation_from_maxima(sino1, sino2)
    timings["sinograms"] = time.perf_counter() - clock

    clock = time.perf_counter()
    options_180 = [
        coarse_translation(cells1, cells2, -np.deg2rad(delta_deg + turn)) for turn in (0.0, 180.0)
    ]
    coarse, correlations, _ = max(options_180, key=lambda option: option[2])
    timings["translation"] = time.perf_counter() - clock

    best = coarse
    if optimise:
        clock = time.perf_counter()
        space = search_space(sino1, sino2, correlations, coarse)
        best = monte_carlo_optimise(
            cells1,
            cells2,
            coarse,
            space,
            rng=rng,
            rotation_samples=rotation_samples,
            translation_samples=translation_samples,
            saliency_points=saliency_points,
        )
        timings["optimisation"] = time.perf_counter() - clock

    clock = time.perf_counter()
    first, second = prepare_map(cells1), prepare_map(cells2)
    check = verify(first, second, best)
    strength = constraint_strength(SmoothedMap(first.walls, first.shape), second, best)
    factors = confidence_factors(check, None, strength=strength)
    score = float(np.prod(factors))
    timings["verify"] = time.perf_counter() - clock
    accepted = score >= ACCEPT_CONFIDENCE
    evidence = {"agreement": check.agreement, "conflict": check.conflict, "strength": strength}
    evidence.update({f"close_{name}": f for name, f in zip(CLOSE_FACTORS, factors, strict=True)})
    reason = "" if accepted else refusal_reason(factors, {}, evidence)
    return MergeResult(
        matrix=best,
        confidence=score,
        accepted=accepted,
        method="paper",
        hypotheses=(
            Hypothesis(best, check.quality, check.agreement, check.conflict, int(check.overlap)),
        ),
        timings=timings,
        reason=reason,
        evidence=evidence,
    )


register_method("paper")(paper_merge)
