"""The paper's search space (eqs. 18-26) and Monte-Carlo optimisation (eqs. 27-30).

Candidates are parametrised as ``T = Tr(t) R(θ) Tr(-c_2)``: map 2 is turned
by θ about its centre ``c_2`` (eq. 6) and its centre placed at ``t`` in map
1. In this form a translation sample stays meaningful for every rotation
sample, which section 3.3 needs when it pairs each with each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from merging.grid import occupied_cells
from merging.paper.sinogram import Sinogram, map_centre
from merging.transforms import matrix_to_pose, rigid_matrix, translation_matrix

HISTOGRAM_BINS = 256
"""Bins of the intensity histograms whose entropy sizes the mixtures (eqs. 18-19,
22-25): the grey-level histogram of an 8-bit image, as an image entropy uses."""
MCO_POINTS = 5000
"""Occupied cells of map 2 moved per candidate; their projections are scaled up."""


def entropy(values: NDArray[np.float64]) -> float:
    """``-Σ p log2 p`` of the 256-bin histogram of ``values`` scaled to ``[0, 1]``.

    The paper calls ``p`` "the histogram" of a sinogram or correlation
    without saying of what; we read it, as image entropy does, as the
    normalised histogram of the values' grey levels.
    """
    v = np.asarray(values, dtype=float).ravel()
    span = v.max() - v.min()
    if span <= 0:
        return 0.0
    counts = np.bincount(
        np.minimum(((v - v.min()) / span * HISTOGRAM_BINS).astype(np.intp), HISTOGRAM_BINS - 1),
        minlength=HISTOGRAM_BINS,
    )
    p = counts[counts > 0] / v.size
    return float(-(p * np.log2(p)).sum())


def _peaks(lags: NDArray[np.int64], values: NDArray[np.float64], count: int) -> NDArray[np.int64]:
    """Lags of the ``count`` highest local maxima of a correlation, highest first."""
    inner = (values[1:-1] >= values[:-2]) & (values[1:-1] > values[2:])
    index = np.flatnonzero(inner) + 1
    if len(index) == 0:
        index = np.array([int(np.argmax(values))])
    order = index[np.argsort(values[index])[::-1]][:count]
    return lags[order]


@dataclass(frozen=True, slots=True)
class SearchSpace:
    """The Gaussian mixtures of section 3.2, in the parametrisation of this module.

    Attributes
    ----------
    rotation_means : (N_UGMM,) float ndarray
        Means of the univariate mixture (eq. 20), radians, as rotations of T.
    rotation_sigma : float
        Its standard deviation (eq. 21), radians.
    translation_means : (N_MGMM, 2) float ndarray
        Means of the bivariate mixture (eqs. 22-23), as the position ``t``.
    translation_sigma : (2,) float ndarray
        Standard deviations along x and y (eqs. 24-26), cells.
    """

    rotation_means: NDArray[np.float64]
    rotation_sigma: float
    translation_means: NDArray[np.float64]
    translation_sigma: NDArray[np.float64]


def search_space(
    first: Sinogram,
    second: Sinogram,
    correlations: tuple[tuple[NDArray[np.int64], NDArray[np.float64]], ...],
    coarse: NDArray[np.float64],
) -> SearchSpace:
    """Eqs. (18)-(26): mixtures centred on the sinograms' and correlations' peaks.

    * ``N_θn = ⌈H(S_Mn)⌉`` (eqs. 18-19); the ``N_UGMM = min(N_θ1, N_θ2)``
      strongest cells of each sinogram, paired by rank, give the rotation
      means ``α_2,n - α_1,n`` (eq. 20), offset so that the first equals the
      coarse rotation (which settled the 180° ambiguity).
    * ``σ_θ = sqrt(H_1 H_2)`` (eq. 21), read as degrees.
    * ``N_MGMM = max(⌈H(CCX)⌉, ⌈H(CCY)⌉)`` highest peaks of each correlation
      give the translation means (eqs. 22-23), paired by rank.
    * ``σ_x = σ_y = sqrt(H_x H_y)`` (eqs. 24-25), read as cells. Eq. (26)
      puts the σ's on the diagonal of a covariance; we use them as standard
      deviations, so that the search width has the units of the means.
    """
    h1, h2 = entropy(first.values), entropy(second.values)
    n_ugmm = max(1, min(int(np.ceil(h1)), int(np.ceil(h2))))
    top1 = np.argsort(first.values, axis=None)[::-1][:n_ugmm]
    top2 = np.argsort(second.values, axis=None)[::-1][:n_ugmm]
    alpha1 = first.angles_deg[np.unravel_index(top1, first.values.shape)[1]]
    alpha2 = second.angles_deg[np.unravel_index(top2, second.values.shape)[1]]
    omega = alpha2 - alpha1  # eq. (20), degrees
    coarse_theta = matrix_to_pose(coarse)[2]
    rotation_means = coarse_theta - np.deg2rad(omega - omega[0])
    rotation_sigma = float(np.deg2rad(np.sqrt(h1 * h2)))  # eq. (21)

    (lags_x, ccx), (lags_y, ccy) = correlations
    hx, hy = entropy(ccx), entropy(ccy)
    n_mgmm = max(1, int(np.ceil(hx)), int(np.ceil(hy)))
    peaks_x = _peaks(lags_x, ccx, n_mgmm)
    peaks_y = _peaks(lags_y, ccy, n_mgmm)
    n = min(len(peaks_x), len(peaks_y))
    # The coarse translation is the first peak of each; others move t by the lag difference.
    origin = coarse[:2, 2] + coarse[:2, :2] @ np.asarray(second.centre)
    shifts = np.column_stack([peaks_x[:n] - peaks_x[0], peaks_y[:n] - peaks_y[0]])
    sigma_xy = float(np.sqrt(hx * hy))
    return SearchSpace(
        rotation_means=rotation_means,
        rotation_sigma=rotation_sigma,
        translation_means=origin + shifts.astype(float),
        translation_sigma=np.array([sigma_xy, sigma_xy]),
    )


def _projections(
    points: NDArray[np.float64], shape: tuple[int, int], weight: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Partial sinograms at α' = 180° and 90° of the points inside ``shape`` (x, y histograms)."""
    rows, cols = shape
    x = np.rint(points[:, 0]).astype(np.intp)
    y = np.rint(points[:, 1]).astype(np.intp)
    inside = (x >= 0) & (x < cols) & (y >= 0) & (y < rows)
    px = np.bincount(x[inside], minlength=cols).astype(np.float64) * weight
    py = np.bincount(y[inside], minlength=rows).astype(np.float64) * weight
    return px, py


def monte_carlo_optimise(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    coarse: NDArray[np.float64],
    space: SearchSpace,
    *,
    rng: np.random.Generator,
    rotation_samples: int,
    translation_samples: int,
    saliency_points: int,
) -> NDArray[np.float64]:
    """Table 1 of the paper: sample, evaluate eq. (29) on every pair, keep eq. (30)'s argmax.

    Two readings of eq. (29) are ours:

    * The sign. As printed, ``Σ_k [PŜ_M1(k) - PŜ_TM2(k)]`` grows as map 2 is
      moved off map 1, so its maximum would be the worst merge; we maximise
      ``-Σ_k |PŜ_M1(k) - PŜ_TM2(k)|``.
    * The "saliency check points". Sorting each partial sinogram by its own
      values would discard where the walls are and leave the objective blind
      to translation (tried: it moved correct coarse estimates hundreds of
      cells away). We read the ``K_d`` check points as the positions of map
      1's ``K_d`` largest projection values, in descending order, and
      compare both maps there.

    The sum runs over α' = 180° and 90°.

    As in Table 1, the answer is the best *sample*: the coarse estimate the
    mixtures are centred on is not itself a candidate (it is returned only
    when no sample scores at all), so a coarse estimate that is already
    exact, as for two identical maps, can give way to a sample a few cells
    off. This is the published method, kept as written.
    """
    centre2 = np.asarray(map_centre(cells2.shape))
    points2 = occupied_cells(cells2)
    stride = max(1, int(np.ceil(len(points2) / MCO_POINTS)))
    points2 = points2[::stride]
    reference = _projections(occupied_cells(cells1), cells1.shape, 1.0)
    check_x = np.argsort(reference[0])[::-1][:saliency_points]
    check_y = np.argsort(reference[1])[::-1][:saliency_points]
    salient_x, salient_y = reference[0][check_x], reference[1][check_y]
    # Eq. (27): rotations from the univariate mixture, components equally likely.
    comp = rng.integers(0, len(space.rotation_means), size=rotation_samples)
    thetas = rng.normal(space.rotation_means[comp], space.rotation_sigma)
    # Eq. (28): translations from the bivariate mixture.
    comp_xy = rng.integers(0, len(space.translation_means), size=translation_samples)
    shifts = rng.normal(space.translation_means[comp_xy], space.translation_sigma)
    best_value, best = -np.inf, coarse
    centred = points2 - centre2
    for theta in thetas:
        c, s = np.cos(theta), np.sin(theta)
        turned = centred @ np.array([[c, s], [-s, c]])
        for t in shifts:
            px, py = _projections(turned + t, cells1.shape, float(stride))
            value = -float(
                np.abs(salient_x - px[check_x]).sum() + np.abs(salient_y - py[check_y]).sum()
            )
            if value > best_value:
                best_value = value
                best = rigid_matrix(t[0], t[1], theta) @ translation_matrix(-centre2)
    return best
