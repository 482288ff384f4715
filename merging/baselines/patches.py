"""Rotation-aware patch descriptors for corner keypoints (Harris, Shi-Tomasi).

A corner detector gives positions only. To match corners between two maps
turned against each other, each corner gets:

1. one or more *orientations*: the strong directions of a histogram of
   image gradient directions around it, weighted by gradient magnitude and
   a Gaussian of the distance (as SIFT orients its keypoints), each refined
   by a parabola through its bin and the neighbours;
2. a *patch* per orientation: the image sampled on a square grid turned to it
   (bilinear interpolation), made zero-mean and unit-norm so that it is
   compared by shape, not by brightness.

Turning a map turns every gradient with it, so the same corner yields the
same patch in both maps up to interpolation.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

ORIENTATION_RADIUS = 8
"""Cells around a corner whose gradients vote for its orientation: a room
corner's two walls dominate within this distance."""
ORIENTATION_BINS = 36
"""Bins of the gradient-direction histogram (10° each)."""
SECONDARY_PEAK = 0.8
"""A histogram peak this close to the strongest gives the corner a further
orientation (the value SIFT uses)."""
PATCH_SAMPLES = 16
"""Samples per side of a descriptor patch."""
PATCH_SPACING = 1.0
"""Cells between patch samples: a 16-cell (0.8 m at 0.05 m) neighbourhood."""
FLAT_NORM = 1e-6
"""A patch whose values vary less than this (root-sum-square) has no shape;
its descriptor is left zero and so matches nothing well."""


def _disc(radius: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    dy, dx = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    inside = dx**2 + dy**2 <= radius**2
    return dx[inside], dy[inside]


def orientations(
    image: NDArray[np.float64], points: NDArray[np.float64]
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Gradient directions, in radians, around each ``(x, y)`` of ``points``.

    Every local maximum of a point's histogram that reaches
    :data:`SECONDARY_PEAK` of its strongest bin gives an orientation, as in
    SIFT: at a corner of two thin walls four directions are about equally
    strong, and which one wins flips with the rasterisation. Directions are
    counter-clockwise from the +x (column) axis of the ``(x, y) = (col, row)``
    frame.

    Returns
    -------
    index : (M,) int ndarray
        The point each orientation belongs to (``M >= len(points)``).
    angles : (M,) float ndarray
    """
    if len(points) == 0:
        return np.zeros(0, dtype=np.intp), np.zeros(0)
    grad_y = ndimage.sobel(image, axis=0)
    grad_x = ndimage.sobel(image, axis=1)
    dx, dy = _disc(ORIENTATION_RADIUS)
    cols = np.clip(np.rint(points[:, 0]).astype(np.intp)[:, None] + dx, 0, image.shape[1] - 1)
    rows = np.clip(np.rint(points[:, 1]).astype(np.intp)[:, None] + dy, 0, image.shape[0] - 1)
    gx, gy = grad_x[rows, cols], grad_y[rows, cols]
    weight = np.hypot(gx, gy) * np.exp(-(dx**2 + dy**2) / (2 * (ORIENTATION_RADIUS / 2) ** 2))
    bins = np.floor((np.arctan2(gy, gx) + np.pi) / (2 * np.pi) * ORIENTATION_BINS).astype(np.intp)
    bins %= ORIENTATION_BINS
    histogram = np.zeros((len(points), ORIENTATION_BINS))
    np.add.at(histogram, (np.arange(len(points))[:, None], bins), weight)
    # Smooth circularly so that a direction on a bin edge is not split in two.
    histogram = ndimage.uniform_filter1d(histogram, 3, axis=1, mode="wrap")
    left = np.roll(histogram, 1, axis=1)
    right = np.roll(histogram, -1, axis=1)
    strongest = histogram.max(axis=1, keepdims=True)
    peaks = (histogram > left) & (histogram >= right) & (histogram >= SECONDARY_PEAK * strongest)
    peaks &= strongest > 0
    index, peak = np.nonzero(peaks)
    a, b, c = left[index, peak], histogram[index, peak], right[index, peak]
    bend = a - 2 * b + c
    offset = np.where(bend < 0, 0.5 * (a - c) / np.where(bend < 0, bend, -1.0), 0.0)
    return index, (peak + 0.5 + offset) / ORIENTATION_BINS * 2 * np.pi - np.pi


def oriented_patches(
    image: NDArray[np.float64], points: NDArray[np.float64], angles: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Zero-mean, unit-norm patches of ``image`` at ``points``, turned by ``angles``.

    Parameters
    ----------
    image : (rows, cols) float ndarray
    points : (N, 2) float ndarray
        ``(x, y) = (col, row)`` patch centres.
    angles : (N,) float ndarray
        Patch orientations, radians counter-clockwise in the ``(x, y)`` frame.

    Returns
    -------
    (N, PATCH_SAMPLES ** 2) float ndarray
    """
    half = (PATCH_SAMPLES - 1) / 2
    v, u = np.mgrid[0:PATCH_SAMPLES, 0:PATCH_SAMPLES]
    u = (u.ravel() - half) * PATCH_SPACING
    v = (v.ravel() - half) * PATCH_SPACING
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    xs = points[:, 0:1] + c * u - s * v
    ys = points[:, 1:2] + s * u + c * v
    samples = ndimage.map_coordinates(image, [ys.ravel(), xs.ravel()], order=1, mode="nearest")
    patches = samples.reshape(len(points), -1)
    patches = patches - patches.mean(axis=1, keepdims=True)
    norms = np.linalg.norm(patches, axis=1, keepdims=True)
    return np.where(norms > FLAT_NORM, patches / np.maximum(norms, FLAT_NORM), 0.0)
