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

import numpy as np
from numpy.typing import NDArray
from scipy import fft, ndimage

ANGLE_STEP_DEG = 1.0
"""Angular sampling of the spectra, as in the paper's sinograms."""
MIN_FREQUENCY = 3
"""Lowest radial frequency used, in FFT bins: below it the spectrum describes the
map's overall extent, which differs between partial maps, not its walls."""
MAX_FREQUENCY_FRACTION = 0.75
"""Highest radial frequency used, as a fraction of Nyquist: above it the
spectrum is rasterisation noise."""
PEAK_SEPARATION_DEG = 4.0
"""Two rotation peaks closer than this are one peak."""


@dataclass(frozen=True, slots=True)
class AngularSpectrum:
    """Normalised ``|F_s S(·, α)|(k)`` for α in ``[0, 180)``.

    Attributes
    ----------
    values : (n_angles, n_frequencies) float ndarray
        Row ``a`` is the log spectrum magnitude of the sinogram column at
        ``α = a * ANGLE_STEP_DEG``, centred and scaled per frequency.
    """

    values: NDArray[np.float64]


def angular_spectrum(image: NDArray[np.floating], *, size: int) -> AngularSpectrum:
    """Angular spectrum of an occupancy image (rows = y, cols = x).

    Parameters
    ----------
    image : (rows, cols) float ndarray
        Occupied mass per cell; must fit in ``size x size``.
    size : int
        FFT size; both maps compared must use the same one so that a bin
        means the same spatial frequency.
    """
    rows, cols = image.shape
    if rows > size or cols > size:
        raise ValueError(f"image of shape {image.shape} does not fit an FFT of size {size}")
    padded = np.zeros((size, size), dtype=np.float32)
    padded[:rows, :cols] = image
    magnitude = np.abs(fft.fftshift(fft.fft2(padded)))
    n_angles = round(180.0 / ANGLE_STEP_DEG)
    alphas = np.deg2rad(np.arange(n_angles) * ANGLE_STEP_DEG)
    radii = np.arange(MIN_FREQUENCY, int(size // 2 * MAX_FREQUENCY_FRACTION), dtype=np.float64)
    centre = size // 2
    # Sample |F| at (kx, ky) = k (cos α, sin α); array axes are (ky, kx).
    kx = centre + np.outer(np.cos(alphas), radii)
    ky = centre + np.outer(np.sin(alphas), radii)
    samples = ndimage.map_coordinates(magnitude, [ky.ravel(), kx.ravel()], order=1)
    values = np.log1p(samples.reshape(n_angles, len(radii)))
    values -= values.mean(axis=0, keepdims=True)
    norms = np.linalg.norm(values, axis=0, keepdims=True)
    values /= np.where(norms > 0, norms, 1.0)
    return AngularSpectrum(values.astype(np.float64))


def rotation_correlation(first: AngularSpectrum, second: AngularSpectrum) -> NDArray[np.float64]:
    """Circular cross-correlation ``C(φ) = Σ_α Σ_k A1(α, k) A2(α + φ, k)``.

    Returns
    -------
    (n_angles,) float ndarray
        ``C`` at ``φ = a * ANGLE_STEP_DEG`` for ``a = 0..n_angles-1``; it peaks
        where map 2's structure is map 1's rotated counter-clockwise by φ.
    """
    spectrum1 = fft.rfft(first.values, axis=0)
    spectrum2 = fft.rfft(second.values, axis=0)
    per_frequency = fft.irfft(np.conj(spectrum1) * spectrum2, n=first.values.shape[0], axis=0)
    return np.asarray(per_frequency.sum(axis=1) / first.values.shape[1], dtype=np.float64)


def rotation_peaks(correlation: NDArray[np.float64], *, count: int) -> list[tuple[float, float]]:
    """The ``count`` strongest local maxima of a circular correlation.

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
    separation = PEAK_SEPARATION_DEG / ANGLE_STEP_DEG
    peaks: list[tuple[float, float]] = []
    for index in order:
        if any(min(abs(index - p), n - abs(index - p)) < separation for p, _ in _indices(peaks)):
            continue
        y0, y1, y2 = correlation[index - 1], correlation[index], correlation[(index + 1) % n]
        curvature = y0 - 2 * y1 + y2
        offset = 0.5 * (y0 - y2) / curvature if curvature < 0 else 0.0
        peaks.append(((index + offset) * ANGLE_STEP_DEG, float(y1)))
        if len(peaks) == count:
            break
    return peaks


def _indices(peaks: list[tuple[float, float]]) -> list[tuple[float, float]]:
    return [(angle / ANGLE_STEP_DEG, value) for angle, value in peaks]
