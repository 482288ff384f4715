"""Rotation hypotheses from translation-invariant angular profiles of sinograms.

The paper estimates the rotation from the single sinogram maximum (eq. 7),
which moves with translation and with whatever part of the building each map
happens to hold. Here the whole angular structure is compared instead.

Translating a map shifts each sinogram column ``S(·, α)`` along ``s``, so the
magnitude of its 1-D Fourier transform ``|F_s S(·, α)|(k)`` does not change;
rotating the map by φ moves it from angle α to α + φ. By the Fourier slice
theorem that magnitude is the 2-D spectrum ``|F M|`` of the map sampled along
the radial line at angle α, so a single 2-D FFT yields every column's spectrum
at once. The circular cross-correlation of two such *angular spectra* over α
peaks at the rotation between the maps; it is only defined modulo 180°
(``S(s, α + 180°) = S(-s, α)``), so every peak stands for two hypotheses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray
from scipy import fft

from merging.params import RotationParams

DEFAULT_ROTATION = RotationParams()
"""The default settings (sampling, frequency band, peak separation)."""


@dataclass(frozen=True, slots=True)
class AngularSpectrum:
    """Normalised ``|F_s S(·, α)|(k)`` for α in ``[0, 180)``.

    Attributes
    ----------
    values : (n_angles, n_frequencies) float ndarray
        Row ``a`` is the log spectrum magnitude of the sinogram column at
        ``α = a * angle_step_deg``, centred and scaled per frequency.
    angle_step_deg : float
        Degrees between rows.
    """

    values: NDArray[np.float64]
    angle_step_deg: float


def angular_spectrum(
    image: NDArray[np.floating], *, size: int, params: RotationParams = DEFAULT_ROTATION
) -> AngularSpectrum:
    """Angular spectrum of an occupancy image (rows = y, cols = x).

    Parameters
    ----------
    image : (rows, cols) float ndarray
        Occupied mass per cell; must fit in ``size x size``.
    size : int
        FFT size; both maps compared must use the same one so that a bin
        means the same spatial frequency.
    params : RotationParams
        Angular sampling and the band of radial frequencies used.
    """
    rows, cols = image.shape
    if rows > size or cols > size:
        raise ValueError(f"image of shape {image.shape} does not fit an FFT of size {size}")
    step = params.angle_step_deg
    n_angles = round(180.0 / step)
    alphas = np.deg2rad(np.arange(n_angles) * step)
    top = int(size // 2 * params.max_frequency_fraction)
    # The samples lie below row ``top`` (their radius is less), and the bilinear
    # interpolation reads at most one row further.
    magnitude = _upper_half_magnitude(np.asarray(image, dtype=np.float32), size, rows=top + 1)
    radii = np.arange(params.min_frequency, top, dtype=np.float64)
    centre = size // 2
    # Sample |F| at (kx, ky) = k (cos α, sin α), ky >= 0 for α in [0°, 180°); the
    # array's axes are (ky, kx + centre).
    kx = centre + np.outer(np.cos(alphas), radii)
    ky = np.outer(np.sin(alphas), radii)
    samples = _bilinear(magnitude, ky.ravel(), kx.ravel())
    values = np.log1p(samples.reshape(n_angles, len(radii)))
    values -= values.mean(axis=0, keepdims=True)
    norms = np.linalg.norm(values, axis=0, keepdims=True)
    values /= np.where(norms > 0, norms, 1.0)
    return AngularSpectrum(values.astype(np.float64), step)


def _upper_half_magnitude(
    image: NDArray[np.float32], size: int, *, rows: int | None = None
) -> NDArray[np.float32]:
    """``|F|`` of ``image`` zero-padded to ``size x size``, for ``ky >= 0`` only.

    Row ``ky`` holds vertical frequency ``ky`` (0 to ``size // 2``); column
    ``kx + size // 2`` holds horizontal frequency ``kx``. The spectrum of a
    real image is symmetric through the origin, so the half the angular
    spectrum samples (angles 0-180°) is all there is: the transform is real
    along the columns, which halves it, and only the image's columns are
    transformed there (the padding's columns transform to zeros). With
    ``rows``, only the first ``rows`` rows (``ky < rows``) are transformed
    and returned: the same values as those rows of the whole half.
    """
    columns = fft.rfft(image, n=size, axis=0)
    if rows is not None:
        columns = columns[:rows]
    frame = np.zeros((columns.shape[0], size), dtype=columns.dtype)
    frame[:, : image.shape[1]] = columns
    half = fft.fft(frame, axis=1, overwrite_x=True)
    # The magnitudes, then the shift: it moves half the bytes of the complex values.
    return fft.fftshift(np.abs(half), axes=1)


@numba.njit(cache=True, nogil=True)
def _bilinear(
    image: NDArray[np.float32], rows: NDArray[np.float64], cols: NDArray[np.float64]
) -> NDArray[np.float32]:
    """``image`` interpolated bilinearly at ``(rows, cols)``, points inside the image.

    The value :func:`scipy.ndimage.map_coordinates` gives with ``order=1``
    (the same weights, summed in the same order; tested against it), for the
    thousands of points of an angular spectrum at a tenth of the cost. A
    point on the last row or column takes its neighbour beyond as itself
    (its weight there is 0); points outside the image are 0.
    """
    n_rows, n_cols = image.shape
    out = np.zeros(rows.shape[0], dtype=np.float32)
    for k in range(rows.shape[0]):
        if not (0.0 <= rows[k] <= n_rows - 1 and 0.0 <= cols[k] <= n_cols - 1):
            continue
        row0, col0 = int(np.floor(rows[k])), int(np.floor(cols[k]))
        row1, col1 = min(row0 + 1, n_rows - 1), min(col0 + 1, n_cols - 1)
        t_row, t_col = rows[k] - row0, cols[k] - col0
        s_row, s_col = 1.0 - t_row, 1.0 - t_col
        value = np.float64(image[row0, col0]) * s_row * s_col
        value += np.float64(image[row0, col1]) * s_row * t_col
        value += np.float64(image[row1, col0]) * t_row * s_col
        value += np.float64(image[row1, col1]) * t_row * t_col
        out[k] = value
    return out


def rotation_correlation(first: AngularSpectrum, second: AngularSpectrum) -> NDArray[np.float64]:
    """Circular cross-correlation ``C(φ) = Σ_α Σ_k A1(α, k) A2(α + φ, k)``.

    Returns
    -------
    (n_angles,) float ndarray
        ``C`` at ``φ = a * angle_step_deg`` for ``a = 0..n_angles-1``; it peaks
        where map 2's structure is map 1's rotated counter-clockwise by φ; all
        zero when the spectra hold no frequency (maps too small to have one).
    """
    if first.values.shape[1] == 0:
        return np.zeros(first.values.shape[0])
    spectrum1 = fft.rfft(first.values, axis=0)
    spectrum2 = fft.rfft(second.values, axis=0)
    per_frequency = fft.irfft(np.conj(spectrum1) * spectrum2, n=first.values.shape[0], axis=0)
    return np.asarray(per_frequency.sum(axis=1) / first.values.shape[1], dtype=np.float64)


def rotation_peaks(
    correlation: NDArray[np.float64],
    *,
    count: int,
    angle_step_deg: float = DEFAULT_ROTATION.angle_step_deg,
    separation_deg: float = DEFAULT_ROTATION.peak_separation_deg,
) -> list[tuple[float, float]]:
    """The ``count`` strongest local maxima of a circular correlation.

    Samples are ``angle_step_deg`` apart; maxima closer than
    ``separation_deg`` to a stronger one are dropped.

    Returns
    -------
    list of (angle_deg, value)
        Peak angles refined to sub-degree by a parabola through the three
        samples around each maximum, strongest first.
    """
    n = len(correlation)
    left, right = np.roll(correlation, 1), np.roll(correlation, -1)
    maxima = np.flatnonzero((correlation >= left) & (correlation > right))
    order = maxima[np.argsort(correlation[maxima])[::-1]]
    separation = separation_deg / angle_step_deg
    kept: list[float] = []  # peak positions in samples, sub-sample refined
    peaks: list[tuple[float, float]] = []
    for index in order:
        if any(min(abs(index - p), n - abs(index - p)) < separation for p in kept):
            continue
        y0, y1, y2 = correlation[index - 1], correlation[index], correlation[(index + 1) % n]
        curvature = y0 - 2 * y1 + y2
        offset = 0.5 * (y0 - y2) / curvature if curvature < 0 else 0.0
        kept.append(index + offset)
        peaks.append(((index + offset) * angle_step_deg, float(y1)))
        if len(peaks) == count:
            break
    return peaks
