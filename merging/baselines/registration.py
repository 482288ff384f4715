"""Intensity-based image registration of the two grids, selectable as ``method="registration"``.

The paper's "REG" treats each map as an image and registers one to the other.
Here the registration is Fourier-based, as scikit-image provides it:

1. Both grids are rendered (:func:`merging.baselines.common.render`, walls
   dark, unknown grey), centred on the unknown grey, so that unobserved
   space carries no weight, and cropped to their observed cells.
2. Rotation. The magnitude of an image's Fourier transform does not change
   when the image is shifted and turns with it. Both magnitudes (of a
   band of radial frequencies, see :data:`LOW_FREQUENCY` and
   :data:`HIGH_FREQUENCY`) are resampled on a log-polar grid
   (:func:`skimage.transform.warp_polar`), where a turn is a shift along the
   angle axis, found by phase correlation
   (:func:`skimage.registration.phase_cross_correlation`). The magnitude
   is symmetric under a half turn, so the angle is known modulo 180°.
3. Translation. Map 2's grid is turned by the angle and by the angle plus
   a half turn (:func:`merging.warp.warp_cells`), rendered, and each is
   phase-correlated with map 1's image, both zero-padded to a canvas larger
   than their summed sizes so that no shift wraps around; the candidate
   whose normalised correlation at its shift is the higher wins.

It needs no starting guess; like every rotation-from-magnitude method, it
cannot tell the quarter turns of a rectilinear building apart when the
walls of both directions are equally strong.

The acceptance verdict comes from :func:`merging.baselines.common.verdict`.

References
----------
B. S. Reddy and B. N. Chatterji, "An FFT-based technique for translation,
rotation, and scale-invariant image registration", IEEE TIP 5(8), 1996.
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import fft
from skimage.registration import phase_cross_correlation
from skimage.transform import warp_polar

from merging.api import register_method
from merging.baselines.common import UNKNOWN_GREY, check_no_options, render, verdict
from merging.result import Hypothesis, MergeResult
from merging.transforms import rigid_matrix, translation_matrix
from merging.warp import warp_cells

EMPTY_IMAGE_WARNING = "Could not determine RMS error"
"""The start of the warning :func:`skimage.registration.phase_cross_correlation` gives
when an image is empty (a map of walls only has no band magnitude): the shift it
returns is still defined, and the error it could not compute is not used here."""


def _phase_shift(reference: NDArray[Any], moving: NDArray[Any], **options: Any) -> NDArray[Any]:
    """The shift of :func:`~skimage.registration.phase_cross_correlation`, without its
    warning about an error metric this module does not use (:data:`EMPTY_IMAGE_WARNING`)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=EMPTY_IMAGE_WARNING, category=UserWarning)
        shift, _, _ = phase_cross_correlation(reference, moving, **options)
    return np.asarray(shift)


ANGLE_ROWS = 720
"""Rows of the log-polar image over 360°: half a degree per row before the
sub-row up-sampling of the phase correlation."""
UPSAMPLE = 10
"""Phase-correlation up-sampling factor: a tenth of a row (0.05°) or cell."""
LOW_FREQUENCY = 0.02
"""Lowest radial frequency used for the rotation, in cycles per cell: below it
the spectrum describes the extent of the observed area, which differs
between partial maps, not its walls."""
HIGH_FREQUENCY = 0.35
"""Highest radial frequency used, in cycles per cell (Nyquist is 0.5): above
it the spectrum is rasterisation noise of the blurred walls."""


def _centred_image(cells: NDArray[np.int8]) -> tuple[NDArray[np.float32], NDArray[np.float64]]:
    """The rendered grid minus the unknown grey, cropped to the observed cells.

    Returns the image (zero where nothing was observed, single precision to
    halve the cost of the Fourier transforms) and the ``(x, y)`` cell of its
    first pixel.
    """
    rows, cols = np.nonzero(cells >= 0)
    if len(rows) == 0:
        return np.zeros((1, 1), dtype=np.float32), np.zeros(2)
    r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    image = render(cells[r0:r1, c0:c1]) - UNKNOWN_GREY
    return image.astype(np.float32), np.array([c0, r0], dtype=float)


def _pad(image: NDArray[np.float32], shape: tuple[int, int]) -> NDArray[np.float32]:
    out = np.zeros(shape, dtype=np.float32)
    out[: image.shape[0], : image.shape[1]] = image
    return out


def _band_magnitude(image: NDArray[np.floating], size: int) -> NDArray[np.float64]:
    """``|F image|`` on a ``size`` x ``size`` grid, centred, outside the frequency band zeroed."""
    magnitude = np.abs(fft.fftshift(fft.fft2(image, s=(size, size))))
    freq = fft.fftshift(fft.fftfreq(size))
    radius = np.hypot(*np.meshgrid(freq, freq, indexing="ij"))
    magnitude[(radius < LOW_FREQUENCY) | (radius > HIGH_FREQUENCY)] = 0.0
    return np.log1p(magnitude)


def rotation_modulo_half_turn(image1: NDArray[np.float32], image2: NDArray[np.float32]) -> float:
    """Angle φ (radians) by which image 2's content is turned counter-clockwise from image 1's.

    Found modulo π from the log-polar magnitude spectra (step 2 of the module
    docstring); counter-clockwise in the ``(x, y) = (col, row)`` frame.
    """
    size = int(fft.next_fast_len(max(*image1.shape, *image2.shape)))
    radius = size // 2
    polar1, polar2 = (
        warp_polar(
            _band_magnitude(image, size),
            radius=radius,
            output_shape=(ANGLE_ROWS, radius),
            scaling="log",
        )
        for image in (image1, image2)
    )
    shift = _phase_shift(polar1, polar2, upsample_factor=UPSAMPLE, normalization=None)
    # Row k of warp_polar's output is the ray at angle 2πk / ANGLE_ROWS,
    # counter-clockwise in the (x, y) = (col, row) frame. Shifting polar2 by
    # +k rows lays it on polar1, so image 2 is image 1 turned by -k rows.
    return float(-shift[0] * 2 * np.pi / ANGLE_ROWS)


def _unwrap(shift: float, size: int, low: int, high: int) -> float:
    """The representative of ``shift`` modulo ``size`` inside ``[low, high]`` (or ``shift``)."""
    candidates = shift + size * np.array([-1.0, 0.0, 1.0])
    inside = (candidates >= low) & (candidates <= high)
    return float(candidates[inside][0]) if inside.any() else float(shift)


def _turn(cells: NDArray[np.int8], theta: float) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
    """``cells`` turned by ``theta`` about the cell at (or just before) its centre onto a
    square canvas that holds all of it.

    Returns the canvas and the matrix taking the grid's cells to the canvas's.
    """
    rows, cols = cells.shape
    # The diagonal holds the grid turned about its exact centre; turned about a cell up
    # to half a cell from it, each corner moves by as much, so a cell more a side, and
    # a cell more for the canvas's centre being a whole cell too.
    side = int(np.ceil(np.hypot(rows, cols))) + 4
    # Turned about a whole cell onto a whole cell: a quarter turn then moves every cell
    # onto a cell, as the nearest-neighbour warp does, and the matrix says so. About
    # the exact centre, a side whose parity differs from the grid's would leave the
    # matrix half a cell from where the warp put the cells.
    centre = np.floor([(cols - 1) / 2, (rows - 1) / 2])
    to_canvas = (
        translation_matrix([(side - 1) // 2, (side - 1) // 2])
        @ rigid_matrix(0.0, 0.0, theta)
        @ translation_matrix(-centre)
    )
    return warp_cells(cells, to_canvas, (side, side)), to_canvas


def translation_candidates(
    cells1: NDArray[np.int8], cells2: NDArray[np.int8], theta: float
) -> list[tuple[NDArray[np.float64], float]]:
    """Turn map 2 by ``theta`` and by ``theta + π``; find each one's shift by phase correlation.

    Both images are padded to a canvas larger than the sum of their sizes, so
    that every relative shift has one representative (no wrap-around).

    Returns
    -------
    list of (matrix, peak)
        The transform (map 2 cells -> map 1 cells) of each candidate and its
        normalised correlation at the found shift.
    """
    image1, origin1 = _centred_image(cells1)
    turned, to_canvas = _turn(cells2, theta)
    side = turned.shape[0]
    # A half turn about the canvas centre is an exact flip of both axes.
    half_turn = rigid_matrix(side - 1.0, side - 1.0, np.pi)
    fixed: dict[tuple[int, int], NDArray[np.complex64]] = {}
    out = []
    for grid, matrix in ((turned, to_canvas), (turned[::-1, ::-1], half_turn @ to_canvas)):
        image2, origin2 = _centred_image(grid)
        shape = (
            int(fft.next_fast_len(image1.shape[0] + image2.shape[0])),
            int(fft.next_fast_len(image1.shape[1] + image2.shape[1])),
        )
        if shape not in fixed:
            fixed[shape] = fft.fft2(_pad(image1, shape))
        moving = _pad(image2, shape)
        shift = _phase_shift(
            fixed[shape], fft.fft2(moving), upsample_factor=UPSAMPLE, space="fourier"
        )
        dy = _unwrap(float(shift[0]), shape[0], 1 - image2.shape[0], image1.shape[0] - 1)
        dx = _unwrap(float(shift[1]), shape[1], 1 - image2.shape[1], image1.shape[1] - 1)
        offset = np.array([dx, dy]) + origin1 - origin2
        moved = np.roll(moving, (round(dy), round(dx)), axis=(0, 1))
        padded1 = _pad(image1, shape)
        norm = float(np.linalg.norm(padded1) * np.linalg.norm(moving))
        peak = float(np.sum(padded1 * moved)) / norm if norm > 0 else 0.0
        out.append((translation_matrix(offset) @ matrix, peak))
    return out


def registration_merge(
    cells1: NDArray[np.int8], cells2: NDArray[np.int8], *, rng: np.random.Generator, **options: Any
) -> MergeResult:
    """Register map 2's image to map 1's (see the module docstring).

    Deterministic: ``rng`` is accepted for the common signature and unused.
    """
    check_no_options("registration", options)
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    phi = rotation_modulo_half_turn(_centred_image(cells1)[0], _centred_image(cells2)[0])
    timings["rotation"] = time.perf_counter() - clock

    clock = time.perf_counter()
    candidates = translation_candidates(cells1, cells2, -phi)
    timings["translation"] = time.perf_counter() - clock
    ranked = tuple(
        Hypothesis(matrix, peak) for matrix, peak in sorted(candidates, key=lambda c: -c[1])
    )
    return verdict(
        cells1, cells2, ranked[0].matrix, method="registration", timings=timings, hypotheses=ranked
    )


register_method("registration")(registration_merge)
