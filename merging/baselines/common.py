"""What every baseline shares: the grid rendered as an image, and the common verdict.

None of the original baselines (Carpin's spectral merger, SURF / Harris /
minimum-eigenvalue feature matching, image registration) says whether its
answer can be trusted. So that ``accepted`` means the same for every method
in :func:`merging.estimate_transform`, each baseline hands its transform to
:func:`verdict`, which applies the verification the tomographic and paper
methods use (:mod:`merging.evidence.verify`): fit, support and constraint strength
(:func:`merging.evidence.refine.constraint_strength`). As for the paper's method, no
distinctiveness factor is used, because a baseline has no runner-up of its
own to compare with.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from merging.evidence.refine import SmoothedMap, constraint_strength
from merging.evidence.verdict import CLOSE_FACTORS, refusal_reason
from merging.evidence.verify import ACCEPT_CONFIDENCE, confidence_factors, prepare_map, verify
from merging.grid import free_mask, occupied_mask
from merging.result import Hypothesis, MergeResult

OCCUPIED_GREY = 0.0
"""Image intensity of an occupied cell: walls are dark, as a map is drawn."""
FREE_GREY = 1.0
"""Image intensity of a free cell."""
UNKNOWN_GREY = 0.5
"""Image intensity of an unknown cell: half-way, so the edge between known and
unknown space is weaker than a wall against free space."""
RENDER_BLUR = 1.0
"""Gaussian blur of the rendered image, in cells: one-cell walls rasterised
after a rotation are ragged; the blur makes their gradients smooth enough for
corner and blob detectors."""


def render(cells: NDArray[np.int8], *, blur: float = RENDER_BLUR) -> NDArray[np.float64]:
    """The grid as a grey-level image in ``[0, 1]``, indexed ``[row, col]`` like ``cells``.

    Occupied cells are :data:`OCCUPIED_GREY`, free ones :data:`FREE_GREY`,
    unknown ones :data:`UNKNOWN_GREY` (cells between the ROS thresholds count
    as unknown); then a Gaussian blur of ``blur`` cells (0 for none).
    """
    image = np.full(cells.shape, UNKNOWN_GREY, dtype=np.float64)
    image[free_mask(cells)] = FREE_GREY
    image[occupied_mask(cells)] = OCCUPIED_GREY
    if blur > 0:
        image = ndimage.gaussian_filter(image, blur, mode="nearest")
    return image


def check_no_options(method: str, options: dict[str, Any]) -> None:
    """Raise ``TypeError`` naming any option a method does not take."""
    if options:
        raise TypeError(f"the {method} method got unknown options {sorted(options)}")


def check_positive(name: str, value: float, *, integer: bool = False) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is a positive (integer) number."""
    ok = isinstance(value, int | float | np.integer | np.floating) and np.isfinite(value)
    ok = ok and value > 0 and (not integer or float(value) == int(value))
    if not ok:
        kind = "a positive integer" if integer else "a positive number"
        raise ValueError(f"{name} must be {kind}, got {value!r}")


def refusal(method: str, reason: str, timings: dict[str, float]) -> MergeResult:
    """The result of a baseline that found no transform at all (identity, not accepted)."""
    return MergeResult(
        matrix=np.eye(3),
        confidence=0.0,
        accepted=False,
        method=method,
        timings=timings,
        reason=reason,
    )


def verdict(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    matrix: NDArray[np.float64],
    *,
    method: str,
    timings: dict[str, float],
    hypotheses: tuple[Hypothesis, ...] = (),
    score: float | None = None,
) -> MergeResult:
    """Verify a baseline's transform with the shared check and build its result.

    Parameters
    ----------
    cells1, cells2 : int8 ndarrays
        The validated grids.
    matrix : (3, 3) float ndarray
        The baseline's transform, map 2 cells -> map 1 cells.
    method : str
        The baseline's registered name.
    timings : dict
        Seconds per stage so far; a ``"verify"`` entry is added.
    hypotheses : tuple of Hypothesis
        The candidates the baseline ranked, best first; by default the
        transform alone, scored by ``score``.
    score : float, optional
        The baseline's own ranking value of ``matrix`` (default: the fit
        quality of the verification).
    """
    clock = time.perf_counter()
    first, second = prepare_map(cells1), prepare_map(cells2)
    check = verify(first, second, matrix)
    strength = constraint_strength(SmoothedMap(first.walls, first.shape), second, matrix)
    factors = confidence_factors(check, None, strength=strength)
    value = float(np.prod(factors))
    timings = {**timings, "verify": time.perf_counter() - clock}
    accepted = value >= ACCEPT_CONFIDENCE
    evidence = {
        "agreement": check.agreement,
        "conflict": check.conflict,
        "matching_wall_cells": check.agreeing,
        "shared_open_cells": check.shared_space,
        "strength": strength,
    }
    evidence.update({f"close_{name}": f for name, f in zip(CLOSE_FACTORS, factors, strict=True)})
    reason = "" if accepted else refusal_reason(factors, {}, evidence)
    if not hypotheses:
        own = check.quality if score is None else float(score)
        hypotheses = (Hypothesis(matrix, own, check.agreement, check.conflict, int(check.overlap)),)
    return MergeResult(
        matrix=np.asarray(matrix, dtype=float),
        confidence=value,
        accepted=accepted,
        method=method,
        hypotheses=hypotheses,
        timings=timings,
        reason=reason,
        evidence=evidence,
    )
