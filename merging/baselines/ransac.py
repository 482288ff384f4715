"""Rigid (rotation + translation, no scale) fits of point correspondences, with RANSAC.

Shared by every method that matches local features: keypoints of map 2 and
map 1 paired by their descriptors are mostly wrong pairs on occupancy grids,
so the transform is the one that the largest set of pairs agrees on.

Conventions: points are ``(N, 2)`` float arrays of ``(x, y) = (col, row)``
cells; the fitted matrix ``T`` takes ``source`` (map 2) onto ``target``
(map 1), ``target ≈ T [source, 1]`` (eq. 1 of the paper).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

MIN_SAMPLE_SPREAD = 4.0
"""Cells two sampled points must lie apart (in both maps) for a well-posed fit:
closer pairs leave the rotation at the mercy of a one-cell keypoint error."""
SUCCESS_PROBABILITY = 0.999
"""Probability of drawing at least one all-inlier sample before the adaptive
stopping rule ends the search."""


@dataclass(frozen=True, slots=True)
class RansacFit:
    """The consensus of a RANSAC search.

    Attributes
    ----------
    matrix : (3, 3) float ndarray
        Least-squares rigid fit to all inliers, source -> target.
    inliers : (N,) bool ndarray
        Correspondences within the threshold of ``matrix``.
    iterations : int
        Samples drawn.
    """

    matrix: NDArray[np.float64]
    inliers: NDArray[np.bool_]
    iterations: int

    @property
    def count(self) -> int:
        """Number of inliers."""
        return int(np.count_nonzero(self.inliers))


def _check_pairs(source: ArrayLike, target: ArrayLike) -> tuple[NDArray[np.float64], ...]:
    src = np.asarray(source, dtype=float)
    dst = np.asarray(target, dtype=float)
    if src.ndim != 2 or src.shape[1:] != (2,):
        raise ValueError(f"source must be an (N, 2) array of (x, y), got shape {src.shape}")
    if dst.shape != src.shape:
        raise ValueError(f"target must have the shape of source {src.shape}, got shape {dst.shape}")
    if not (np.all(np.isfinite(src)) and np.all(np.isfinite(dst))):
        raise ValueError("source and target must be finite; drop NaN or infinite points")
    return src, dst


def fit_rigid(
    source: ArrayLike, target: ArrayLike, *, weights: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Least-squares rotation and translation taking ``source`` onto ``target``.

    The Kabsch/Umeyama solution without scale: with centroids removed, the
    rotation is ``V diag(1, det(V U^T)) U^T`` from the SVD ``U S V^T`` of the
    weighted cross-covariance, so a reflection is never returned.

    Parameters
    ----------
    source, target : (N, 2) float arrays
        Corresponding ``(x, y)`` points, ``N >= 2``.
    weights : (N,) float array, optional
        Non-negative weight of each pair (default equal).

    Returns
    -------
    (3, 3) float ndarray
        ``T`` with ``target ≈ T [source, 1]``.

    Raises
    ------
    ValueError
        For mismatched shapes, fewer than two pairs, non-finite values or
        negative / all-zero weights.

    References
    ----------
    S. Umeyama, "Least-squares estimation of transformation parameters
    between two point patterns", IEEE TPAMI 13(4), 1991.
    """
    src, dst = _check_pairs(source, target)
    if len(src) < 2:
        raise ValueError(f"a rigid fit needs at least 2 point pairs, got {len(src)}")
    w = np.ones(len(src)) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != (len(src),) or np.any(w < 0) or not np.isfinite(w).all() or w.sum() <= 0:
        raise ValueError(f"weights must be {len(src)} finite non-negative numbers, not all zero")
    w = w / w.sum()
    mean_src = w @ src
    mean_dst = w @ dst
    covariance = (dst - mean_dst).T @ ((src - mean_src) * w[:, None])
    u, _, vt = np.linalg.svd(covariance)
    flip = np.diag([1.0, float(np.sign(np.linalg.det(u @ vt)) or 1.0)])
    rotation = u @ flip @ vt
    matrix = np.eye(3)
    matrix[:2, :2] = rotation
    matrix[:2, 2] = mean_dst - rotation @ mean_src
    return matrix


def _residuals(matrix: NDArray[np.float64], src: NDArray[np.float64], dst: NDArray[np.float64]):
    moved = src @ matrix[:2, :2].T + matrix[:2, 2]
    return np.hypot(*(moved - dst).T)


def _two_point_fit(src: NDArray[np.float64], dst: NDArray[np.float64]) -> NDArray[np.float64]:
    """The exact rigid fit of two pairs: the rotation turns one segment onto the other."""
    d_src, d_dst = src[1] - src[0], dst[1] - dst[0]
    theta = np.arctan2(d_dst[1], d_dst[0]) - np.arctan2(d_src[1], d_src[0])
    c, s = np.cos(theta), np.sin(theta)
    rotation = np.array([[c, -s], [s, c]])
    matrix = np.eye(3)
    matrix[:2, :2] = rotation
    matrix[:2, 2] = 0.5 * (dst[0] + dst[1]) - rotation @ (0.5 * (src[0] + src[1]))
    return matrix


def ransac_rigid(
    source: ArrayLike,
    target: ArrayLike,
    *,
    threshold: float,
    rng: np.random.Generator | int | None = None,
    max_iterations: int = 2000,
    min_inliers: int = 3,
) -> RansacFit | None:
    """RANSAC over two-point samples for the rigid transform most pairs agree on.

    1. Draw two pairs (without replacement), skipping samples whose points
       lie within :data:`MIN_SAMPLE_SPREAD` cells or whose two segments
       differ in length by more than ``2 * threshold`` (no rigid motion
       explains them).
    2. Fit them exactly and count the pairs within ``threshold`` cells.
    3. Keep the largest consensus; stop once ``max_iterations`` samples are
       drawn or, adaptively, when a larger consensus is unlikely
       (:data:`SUCCESS_PROBABILITY`).
    4. Refit all inliers by least squares (:func:`fit_rigid`) and recount.

    Parameters
    ----------
    source, target : (N, 2) float arrays
        Putative correspondences, map 2 and map 1 ``(x, y)`` cells.
    threshold : float
        Largest residual, in cells, of an inlier.
    rng : Generator, int or None
        Randomness for the samples; a seed makes the search repeatable.
    max_iterations : int
        Most samples drawn.
    min_inliers : int
        Smallest consensus accepted (at least 2).

    Returns
    -------
    RansacFit or None
        None when fewer than ``min_inliers`` pairs agree on any transform.
    """
    src, dst = _check_pairs(source, target)
    if not (np.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold must be a positive number of cells, got {threshold}")
    if int(max_iterations) < 1:
        raise ValueError(f"max_iterations must be a positive integer, got {max_iterations}")
    if int(min_inliers) < 2:
        raise ValueError(f"min_inliers must be at least 2, got {min_inliers}")
    generator = np.random.default_rng(rng)
    n = len(src)
    if n < max(2, min_inliers):
        return None
    best_inliers = np.zeros(n, dtype=bool)
    best_count = 0
    needed = int(max_iterations)
    drawn = 0
    while drawn < min(needed, int(max_iterations)):
        drawn += 1
        i, j = generator.choice(n, size=2, replace=False)
        span_src = float(np.hypot(*(src[j] - src[i])))
        span_dst = float(np.hypot(*(dst[j] - dst[i])))
        if min(span_src, span_dst) < MIN_SAMPLE_SPREAD or abs(span_src - span_dst) > 2 * threshold:
            continue
        inliers = _residuals(_two_point_fit(src[[i, j]], dst[[i, j]]), src, dst) <= threshold
        count = int(np.count_nonzero(inliers))
        if count > best_count:
            best_count, best_inliers = count, inliers
            ratio = count / n
            miss = 1.0 - ratio**2
            if miss <= 0:
                break
            needed = int(np.ceil(np.log(1 - SUCCESS_PROBABILITY) / np.log(miss)))
    if best_count < min_inliers:
        return None
    matrix = fit_rigid(src[best_inliers], dst[best_inliers])
    inliers = _residuals(matrix, src, dst) <= threshold
    if np.count_nonzero(inliers) < min_inliers:
        inliers = best_inliers
    else:
        matrix = fit_rigid(src[inliers], dst[inliers])
    return RansacFit(matrix=matrix, inliers=inliers, iterations=drawn)
