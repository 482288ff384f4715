"""Spectral map merging (Carpin 2008), selectable as ``method="spectral"`` ("SMM" in the paper).

The steps, each a function below:

1. Hough transform ``H(ρ, θ)`` of each map's occupied cells, and its *Hough
   spectrum* ``HS(θ) = Σ_ρ H(ρ, θ)²``, which a translation leaves unchanged
   (it only moves mass along ρ) and a rotation by φ shifts by φ.
2. The circular cross-correlation of the two spectra; its strongest local
   maxima are the rotation hypotheses. The spectrum has period 180°, so each
   maximum stands for two rotations, 180° apart.
3. For each rotation, map 2's cells are turned and the translation is read
   from the cross-correlation of the two maps' *x* and *y spectra*
   (projection histograms of the occupied cells).
4. The hypotheses are ranked by Birk and Carpin's acceptance index
   (:func:`merging.evaluation.metrics.acceptance_index`) and the best is returned.

Choices not fixed by the original, and why:

* θ is sampled every :data:`ANGLE_STEP_DEG` degrees and peaks are located to
  a fraction of a step by a parabola through the peak and its neighbours;
  the original's one-degree bins turn a map 400 cells wide by up to 3.5
  cells at its edge, more than the 2-cell success bound of the benchmarks.
* The *x* and *y* spectra are taken along map 1's dominant direction (the
  maximum of its Hough spectrum) and its normal, so that walls project onto
  sharp peaks even when the building is not aligned with the grid; for an
  axis-aligned building these are the original's *x* and *y* spectra.

The acceptance verdict comes from :func:`merging.baselines.common.verdict`.

References
----------
S. Carpin, "Fast and accurate map merging for multi-robot systems",
Autonomous Robots 25(3), 2008.
A. Birk and S. Carpin, "Merging occupancy grid maps from multiple robots",
Proc. IEEE 94(7), 2006.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import fft

from merging.api import register_method
from merging.baselines.common import check_no_options, check_positive, verdict
from merging.evaluation.metrics import acceptance_index
from merging.grid import occupied_cells
from merging.paper.sinogram import map_centre, project_points, sinogram_radius
from merging.result import Hypothesis, MergeResult
from merging.transforms import rigid_matrix

ANGLE_STEP_DEG = 0.25
"""Sampling of θ over [0°, 180°) for the Hough spectra."""
ROTATION_PEAKS = 4
"""Local maxima of the spectra's correlation kept as rotation hypotheses, each
with its 180° twin: Carpin's method ranks a handful of hypotheses."""
MAX_HOUGH_POINTS = 8000
"""Occupied cells entering the Hough transform, spread evenly over all: the
spectrum's shape is set long before every cell is counted."""


def hough_spectrum(points: NDArray[np.float64], shape: tuple[int, int]) -> NDArray[np.float64]:
    """``HS(θ) = Σ_ρ H(ρ, θ)²`` for θ = 0, :data:`ANGLE_STEP_DEG`, ..., scaled to a maximum of 1.

    ``H`` is the Hough transform of ``points`` (``(N, 2)`` ``(x, y)`` cells of a
    map of ``shape``) about the map centre, ρ in one-cell bins; it is the
    same line integral as the paper's sinogram (:func:`merging.paper.sinogram.project_points`).
    """
    angles = np.arange(0.0, 180.0, ANGLE_STEP_DEG)
    centre = map_centre(shape)
    stride = max(1, int(np.ceil(len(points) / MAX_HOUGH_POINTS)))
    hough = project_points(
        points[::stride] - np.asarray(centre), angles, sinogram_radius(shape, centre)
    )
    spectrum = np.sum(hough**2, axis=0)
    peak = spectrum.max()
    return spectrum / peak if peak > 0 else spectrum


def circular_correlation(first: NDArray[np.float64], second: NDArray[np.float64]):
    """``CC(k) = Σ_j HS_1(j) HS_2(j + k)``, indices modulo the length, scaled to [0, 1].

    If map 2 shows map 1 turned counter-clockwise by φ, ``HS_2(θ + φ) =
    HS_1(θ)`` and ``CC`` peaks at ``k = φ / ANGLE_STEP_DEG``.
    """
    values = np.real(fft.ifft(np.conj(fft.fft(first)) * fft.fft(second)))
    low, high = values.min(), values.max()
    return (values - low) / (high - low) if high > low else np.zeros_like(values)


def rotation_peaks(correlation: NDArray[np.float64], *, count: int) -> list[float]:
    """Angles φ in degrees of the ``count`` strongest circular local maxima, strongest first.

    Each is refined by the vertex of the parabola through the peak and its two
    neighbours.
    """
    left, right = np.roll(correlation, 1), np.roll(correlation, -1)
    index = np.flatnonzero((correlation > left) & (correlation >= right))
    if len(index) == 0:
        index = np.array([int(np.argmax(correlation))])
    index = index[np.argsort(correlation[index])[::-1][:count]]
    angles = []
    for k in index:
        a, b, c = left[k], correlation[k], right[k]
        bend = a - 2 * b + c
        offset = 0.5 * (a - c) / bend if bend < 0 else 0.0
        angles.append(float((k + offset) * ANGLE_STEP_DEG))
    return angles


def spectrum_shift(
    first: NDArray[np.float64], second: NDArray[np.float64], normal: NDArray[np.float64]
) -> float:
    """Shift ``d`` along ``normal`` that best lays ``second``'s points on ``first``'s.

    Both point sets are projected on ``normal`` (``s = p · normal``) into
    one-cell histograms, the *x* or *y spectra* of the original along an axis;
    ``d`` maximises their cross-correlation, so ``s_2 + d ≈ s_1``.
    """
    # Imported here, not by `import merging`, which registers this method: scipy.signal
    # brings scipy.stats, a good part of the 0.4 s the features' imports cost too.
    from scipy import signal

    s1 = np.rint(first @ normal).astype(np.int64)
    s2 = np.rint(second @ normal).astype(np.int64)
    low1, low2 = int(s1.min()), int(s2.min())
    h1 = np.bincount(s1 - low1).astype(float)
    h2 = np.bincount(s2 - low2).astype(float)
    values = signal.correlate(h1, h2, mode="full", method="auto")
    lag = int(np.argmax(values)) - (len(h2) - 1)
    return float(low1 - low2 + lag)


def translation_for(
    points1: NDArray[np.float64], points2: NDArray[np.float64], theta: float, dominant_deg: float
) -> NDArray[np.float64]:
    """The transform turning map 2 by ``theta`` (radians) and shifting it by the spectra's peaks."""
    rotation = rigid_matrix(0.0, 0.0, theta)
    turned = points2 @ rotation[:2, :2].T
    alpha = np.deg2rad(dominant_deg)
    along = np.array([np.cos(alpha), np.sin(alpha)])
    across = np.array([-np.sin(alpha), np.cos(alpha)])
    shift = spectrum_shift(points1, turned, along) * along
    shift += spectrum_shift(points1, turned, across) * across
    return rigid_matrix(float(shift[0]), float(shift[1]), theta)


def spectral_merge(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    *,
    rng: np.random.Generator,
    hypotheses: int = ROTATION_PEAKS,
    **options: Any,
) -> MergeResult:
    """Carpin's spectral merger of map 2 onto map 1 (see the module docstring).

    Deterministic: ``rng`` is accepted for the common signature and unused.

    Parameters
    ----------
    hypotheses : int
        Rotation peaks kept (each tried with its 180° twin).
    """
    check_no_options("spectral", options)
    check_positive("hypotheses", hypotheses, integer=True)
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    points1, points2 = occupied_cells(cells1), occupied_cells(cells2)
    spectrum1 = hough_spectrum(points1, cells1.shape)
    spectrum2 = hough_spectrum(points2, cells2.shape)
    phis = rotation_peaks(circular_correlation(spectrum1, spectrum2), count=int(hypotheses))
    dominant = float(np.argmax(spectrum1) * ANGLE_STEP_DEG)
    timings["rotation"] = time.perf_counter() - clock

    clock = time.perf_counter()
    candidates = []
    for phi in phis:
        # Map 2 shows map 1 turned by +phi; turning it back is -phi (or -phi + 180°).
        for theta in (-np.deg2rad(phi), np.pi - np.deg2rad(phi)):
            candidates.append(translation_for(points1, points2, theta, dominant))
    timings["translation"] = time.perf_counter() - clock

    clock = time.perf_counter()
    omegas = [acceptance_index(cells1, cells2, matrix) for matrix in candidates]
    order = np.argsort(omegas)[::-1]
    ranked = tuple(Hypothesis(candidates[i], float(omegas[i])) for i in order)
    timings["rank"] = time.perf_counter() - clock
    return verdict(
        cells1, cells2, ranked[0].matrix, method="spectral", timings=timings, hypotheses=ranked
    )


register_method("spectral")(spectral_merge)
