"""Translation hypotheses from the correlation of every projection at once.

The paper finds ``Δx`` and ``Δy`` by correlating only two partial sinograms,
those at α = 180° and 90° (eqs. 11-17). Each projection angle gives the same
kind of evidence: the 1-D cross-correlation of ``S_M1(·, α)`` with the
rotated map's ``S(·, α)`` peaks at ``s = Δx cos α + Δy sin α``. The 1-D
correlations of all angles are the Radon transform of the 2-D
cross-correlation of the maps (the projection of a correlation is the
correlation of the projections), so pooling all angles means finding the
peaks of the 2-D correlation, which an FFT computes directly.

To be cheap the correlation runs on a coarse grid (blocks of ``factor`` x
``factor`` cells). Map 1 enters as a signed *target*: its walls, blurred to
tolerate the residual rotation error, minus a penalty on its clear free
space, so a shift that lays map 2's walls across map 1's open rooms loses.

The target mass a shift collects grows with how many of map 2's walls land
on map 1's observed part, so a shift laying a large part of map 2 loosely on
map 1 collects more than one laying a small part exactly, and maps that
share 3-15 % of their area lose their true shift among the loose ones. The
target only holds map 1's side of the evidence: a loose large overlap also
lays map 1's walls in map 2's clear free space, where map 2's lidar saw
through. So besides the shifts collecting the most mass, the search keeps
those most *significant*: the mass less ``TranslationParams.reverse_penalty``
for each of map 1's wall blocks landing on a block of map 2 that is clear
free space throughout (:func:`clear_blocks`). Both terms are correlations
with the shift, so their spectra are summed and one inverse transform gives
the surface; the check costs one more forward transform per rotation, of map
2's clear blocks. On maps that share most of their area the strongest shifts
by mass stay first: sessions of one floor drawn months apart disagree on
furniture, doors and a bend of the corridors, which the reverse count, as
the only ranking, held against their true shift.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy import fft

from merging.evidence.blur import blur_walls
from merging.evidence.verify import PreparedMap
from merging.params import TranslationParams
from merging.transforms import rigid_matrix

DEFAULT_TRANSLATION = TranslationParams()
"""The default settings (coarse grid size, blur, free-space penalty, peaks)."""


@dataclass(frozen=True, slots=True)
class CoarseMap:
    """A map reduced to blocks of ``factor`` x ``factor`` cells.

    Attributes
    ----------
    factor : int
        Cells per block side.
    target : (rows, cols) float32 ndarray
        Correlation target: blurred walls minus ``free_penalty`` times the
        fraction of the block that is clear free space.
    walls : (rows, cols) float32 ndarray
        1 where a block holds an occupied cell.
    points : (M, 2) float ndarray
        ``(x, y)`` block indices of the blocks holding walls.
    clear_points : (K, 2) float ndarray
        ``(x, y)`` block indices of the blocks clear free space throughout
        (:func:`clear_blocks`).
    """

    factor: int
    target: NDArray[np.float32]
    walls: NDArray[np.float32]
    points: NDArray[np.float64]
    clear_points: NDArray[np.float64]
    _spectra: dict[tuple[str, tuple[int, int]], NDArray[np.complex64]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def target_spectrum(self, size: tuple[int, int]) -> NDArray[np.complex64]:
        """``rfft2`` of ``target`` zero-padded to ``size``, kept for the next rotation."""
        return self._spectrum("target", self.target, size)

    def walls_spectrum(self, size: tuple[int, int]) -> NDArray[np.complex64]:
        """``rfft2`` of ``walls`` zero-padded to ``size``, kept for the next rotation."""
        return self._spectrum("walls", self.walls, size)

    def _spectrum(
        self, name: str, image: NDArray[np.float32], size: tuple[int, int]
    ) -> NDArray[np.complex64]:
        key = (name, size)
        if key not in self._spectra:
            spectrum = padded_rfft2(image, size)
            spectrum.setflags(write=False)  # shared by every rotation
            self._spectra[key] = spectrum
        return self._spectra[key]


def padded_rfft2(image: NDArray[np.float32], size: tuple[int, int]) -> NDArray[np.complex64]:
    """``scipy.fft.rfft2(image, s=size)`` for an image no larger than ``size``, to the bit.

    The same two passes, rows first, but only the image's rows are
    transformed along x: the rows of zeros below it (half of a correlation's
    frame) transform to zeros, which ``rfft2`` computes anyway. Two and a
    half times faster on the coarse grids of small maps.
    """
    rows = fft.rfft(image, n=size[1], axis=1)
    frame = np.zeros((size[0], rows.shape[1]), dtype=rows.dtype)
    frame[: image.shape[0]] = rows
    return fft.fft(frame, axis=0, overwrite_x=True)


def coarse_factor(
    *shapes: tuple[int, int], coarse_cells: int = DEFAULT_TRANSLATION.coarse_cells
) -> int:
    """Block size making the largest map at most ``coarse_cells`` blocks a side."""
    largest = max(max(shape) for shape in shapes)
    return max(1, int(np.ceil(largest / coarse_cells)))


def coarsen(
    prepared: PreparedMap, factor: int, *, params: TranslationParams = DEFAULT_TRANSLATION
) -> CoarseMap:
    """Reduce a prepared map to its coarse correlation images.

    A block is a wall block when any of its cells is occupied (walls are
    thin, so they must not be averaged away); its clear free space is
    sampled at the block's centre cell, which costs nothing and, after the
    blur, is as good a penalty as the block's exact fraction.
    """
    rows, cols = prepared.shape
    shape = (-(-rows // factor), -(-cols // factor))
    # Wall cells are whole and not negative: integer division is exact and ten times
    # faster than a float one.
    blocks = prepared.walls.astype(np.intp) // factor
    walls = np.zeros(shape, dtype=np.float32)
    walls[blocks[:, 1], blocks[:, 0]] = 1.0
    clear = np.zeros(shape, dtype=np.float32)
    centre = factor // 2
    sampled = prepared.clear_free[centre::factor, centre::factor]
    clear[: sampled.shape[0], : sampled.shape[1]] = sampled
    # np.nonzero of a 2-D array is several times slower than this, in the same order.
    wall_rows, wall_cols = np.divmod(np.flatnonzero(walls), shape[1])
    blurred = blur_walls(wall_rows, wall_cols, shape, params.wall_blur)
    blurred /= max(float(blurred.max()), 1e-9)
    target = (blurred - params.free_penalty * clear).astype(np.float32)
    points = np.column_stack([wall_cols, wall_rows]).astype(np.float64)
    clear_rows, clear_cols = np.divmod(np.flatnonzero(clear_blocks(prepared, factor)), shape[1])
    clear_points = np.column_stack([clear_cols, clear_rows]).astype(np.float64)
    for image in (target, walls, points, clear_points):
        image.setflags(write=False)  # map 1's are shared with a second search
    return CoarseMap(factor, target, walls, points, clear_points)


def clear_blocks(prepared: PreparedMap, factor: int) -> NDArray[np.bool_]:
    """Blocks of ``factor`` x ``factor`` cells that are clear free space throughout.

    Judged at the block's four corner cells and its centre cell: a long
    wall's band of cells that are not clear (the wall, the cells near it and
    the clearance beyond, :attr:`merging.evidence.verify.PreparedMap.clear_free`;
    seven cells wide with the default verification settings) is wider than
    half a block up to blocks of 12 cells, those of a whole floor, so it
    cannot pass between them. On such blocks the centre cell alone calls a
    block clear that holds a wall.
    """
    rows, cols = prepared.shape
    shape = (-(-rows // factor), -(-cols // factor))
    last, centre = factor - 1, factor // 2
    clear = np.ones(shape, dtype=bool)
    for row, col in ((0, 0), (0, last), (last, 0), (last, last), (centre, centre)):
        sampled = np.zeros(shape, dtype=bool)
        cells = prepared.clear_free[row::factor, col::factor]
        sampled[: cells.shape[0], : cells.shape[1]] = cells
        clear &= sampled
    return clear


def translation_peaks(
    first: CoarseMap,
    second: CoarseMap,
    theta: float,
    *,
    count: int,
    suppression: int = DEFAULT_TRANSLATION.peak_suppression,
    significant: int = 0,
    reverse_penalty: float = DEFAULT_TRANSLATION.reverse_penalty,
) -> tuple[list[Peak], list[Peak]]:
    """Best translations of ``second``, rotated by ``theta`` and by ``theta + π``, onto ``first``.

    The rotation's angular spectra cannot tell a turn from its half-turn
    twin (:mod:`merging.tomographic.angular`), so both are searched, from one transform
    of the rotated map: turned by a further half turn it is the same image
    mirrored through its centre, whose correlation with map 1 is the
    *convolution* of map 1's target with the unmirrored image, shifted by the
    image's extent. Both surfaces come from one forward transform of map 2's
    walls (and one of its clear blocks for the significant shifts).

    Parameters
    ----------
    first, second : CoarseMap
        Map 1 and map 2, coarsened with the same factor.
    theta : float
        Rotation (radians, counter-clockwise) applied to map 2's cells.
    count : int
        Peaks of the collected mass to return per rotation.
    suppression : int
        Coarse cells around a peak within which weaker peaks are dropped.
    significant : int
        Further peaks per rotation, of the collected mass less
        ``reverse_penalty`` per wall block of map 1 landing on a clear block
        of map 2, away from the first ``count`` (see the module docstring).
        Clear blocks outside the turned image of map 2's walls (open space
        past its last wall) are left out.
    reverse_penalty : float
        See ``significant``.

    Returns
    -------
    (list of Peak, list of Peak)
        For ``theta`` and for ``theta + π``: the ``count`` best by collected
        mass first, then the ``significant`` ones.
    """
    rotated = second.points @ rigid_matrix(0.0, 0.0, theta)[:2, :2].T
    low = np.floor(rotated.min(axis=0))
    cells = np.rint(rotated - low).astype(np.intp)
    extent = cells.max(axis=0)  # (x, y) of the image's last column and row
    shape_b = (int(extent[1]) + 1, int(extent[0]) + 1)
    moving = np.zeros(shape_b, dtype=np.float32)
    moving[cells[:, 1], cells[:, 0]] = 1.0
    rows_a, cols_a = first.target.shape
    # Sizes with no prime factor above 5: pocketfft's real transforms are slow on
    # factors of 7 and 11 (which next_fast_len allows by default), so a size of
    # 240 x 270 transforms faster than 240 x 264.
    size = (
        fft.next_fast_len(rows_a + shape_b[0], real=True),
        fft.next_fast_len(cols_a + shape_b[1], real=True),
    )
    target = first.target_spectrum(size)
    forward = padded_rfft2(moving, size)
    mass = float(moving.sum())
    correlated = target * np.conj(forward)
    convolved = target * forward
    surfaces = [fft.irfft2(correlated, s=size), fft.irfft2(convolved, s=size)]
    if significant > 0:
        # Map 1's walls on map 2's clear blocks, laid as the walls are (the correlation)
        # and half-turned (the convolution, below), less than the mass collected.
        clear = padded_rfft2(_clear_image(second, theta, low, extent), size)
        clear *= np.float32(reverse_penalty)
        walls = first.walls_spectrum(size)
        correlated -= walls * np.conj(clear)
        convolved -= walls * clear
        surfaces.append(fft.irfft2(correlated, s=size))
        surfaces.append(fft.irfft2(convolved, s=size))
    # Turned a further half turn, a point in cell c of this image lies at -rotated,
    # in cell -rotated - low_twin = extent - c of the twin's image: correlating with
    # that mirrored image at shift s is convolving with this one at s + extent.
    roll = (-int(extent[1]), -int(extent[0]))
    lows = (low, -(low + extent))
    turns = []
    for k, turn in enumerate((theta, theta + np.pi)):
        mass_surface = surfaces[k] if k == 0 else np.roll(surfaces[k], roll, axis=(0, 1))
        frame = _Frame((rows_a, cols_a), shape_b, mass, lows[k], turn, first.factor, suppression)
        ranked = None
        if significant > 0:
            ranked = surfaces[k + 2] if k == 0 else np.roll(surfaces[k + 2], roll, axis=(0, 1))
        found = _peaks(mass_surface, frame, count, significance=ranked)
        if ranked is not None:
            # The mass surface is suppressed only around its own peaks, which the
            # significant ones keep away from: it still holds their masses.
            found += _peaks(ranked, frame, significant, taken=found, scores=mass_surface)
        turns.append([peak for peak, _ in found])
    return turns[0], turns[1]


def _clear_image(
    second: CoarseMap, theta: float, low: NDArray[np.float64], extent: NDArray[np.intp]
) -> NDArray[np.float32]:
    """Map 2's clear blocks turned by ``theta``, in the frame of its turned walls' image
    (corner ``low``, last ``(x, y)`` at ``extent``); those outside it are left out."""
    turned = second.clear_points @ rigid_matrix(0.0, 0.0, theta)[:2, :2].T
    cells = np.rint(turned - low).astype(np.intp)
    cols, rows = cells[:, 0], cells[:, 1]
    # Column by column: an ``all`` along the short axis of an (n, 2) array costs
    # several times more.
    inside = (cols >= 0) & (cols <= extent[0]) & (rows >= 0) & (rows <= extent[1])
    image = np.zeros((int(extent[1]) + 1, int(extent[0]) + 1), dtype=np.float32)
    image[rows[inside], cols[inside]] = 1.0
    return image


class Peak(NamedTuple):
    """A translation hypothesis: where a correlation surface peaks.

    Attributes
    ----------
    matrix : (3, 3) float ndarray
        Takes map 2's full-resolution cells to map 1's.
    mass : float
        Target mass collected per wall block of map 2.
    significance : float
        That mass less ``reverse_penalty`` per wall block of map 1 landing
        on a clear block of map 2, per wall block of map 2
        (:func:`translation_peaks`; the mass when not computed).
    """

    matrix: NDArray[np.float64]
    mass: float
    significance: float


@dataclass(frozen=True, slots=True)
class _Frame:
    """Where a correlation surface's shifts lie: map 1's coarse shape, map 2's image's
    shape, wall mass and corner ``low`` in the rotated coarse frame, the turn, the block
    size and the peak suppression."""

    shape_a: tuple[int, int]
    shape_b: tuple[int, int]
    mass: float
    low: NDArray[np.float64]
    theta: float
    factor: int
    suppression: int


def _peaks(
    surface: NDArray[np.floating],
    frame: _Frame,
    count: int,
    *,
    taken: list[tuple[Peak, tuple[int, int]]] | None = None,
    scores: NDArray[np.floating] | None = None,
    significance: NDArray[np.floating] | None = None,
) -> list[tuple[Peak, tuple[int, int]]]:
    """The ``count`` strongest shifts of a correlation ``surface`` (changed in place).

    ``surface[i, j]`` ranks map 2's image (of ``frame.shape_b``, holding
    ``frame.mass`` wall blocks, its cell ``(0, 0)`` at ``frame.low`` of the
    rotated coarse frame) shifted by ``(j, i)`` blocks onto map 1's (of
    ``frame.shape_a``); indices past map 1 stand for negative shifts. Each
    peak's mass is ``scores`` there (default ``surface``) and its
    significance ``significance`` there (default ``surface``), per wall
    block. Peaks within the suppression of those ``taken`` are not taken
    again. Returns each peak with its ``(row, col)`` on the surface.
    """
    size = surface.shape
    rows_a, cols_a = frame.shape_a
    # Index i means shift i (i < rows_a) or i - size (a negative shift); the rows and
    # columns between are shifts that lay the maps apart.
    surface[rows_a : size[0] - frame.shape_b[0] + 1, :] = -np.inf
    surface[:, cols_a : size[1] - frame.shape_b[1] + 1] = -np.inf
    for _, (row, col) in taken or ():
        _suppress(surface, row, col, frame.suppression)
    scale, to_coarse = _block_frames(frame.factor)
    masses = surface if scores is None else scores
    significances = surface if significance is None else significance
    peaks: list[tuple[Peak, tuple[int, int]]] = []
    for _ in range(count):
        flat = int(np.argmax(surface))
        row, col = divmod(flat, size[1])
        if not np.isfinite(surface[row, col]):
            break
        shift_y = row if row < rows_a else row - size[0]
        shift_x = col if col < cols_a else col - size[1]
        coarse = rigid_matrix(shift_x - frame.low[0], shift_y - frame.low[1], frame.theta)
        peak = Peak(
            scale @ coarse @ to_coarse,
            float(masses[row, col]) / frame.mass,
            float(significances[row, col]) / frame.mass,
        )
        peaks.append((peak, (row, col)))
        _suppress(surface, row, col, frame.suppression)
    return peaks


@functools.cache
def _block_frames(factor: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The matrix taking block coordinates to cell coordinates (a block's centre to
    its middle cell) and its inverse, for blocks of ``factor`` cells."""
    offset = (factor - 1) / 2
    scale = np.array([[factor, 0, offset], [0, factor, offset], [0, 0, 1]])
    inverse = np.linalg.inv(scale)
    for frame in (scale, inverse):
        frame.setflags(write=False)  # shared by every later search
    return scale, inverse


def _suppress(surface: NDArray[np.floating], row: int, col: int, reach: int) -> None:
    """Set ``surface`` to -inf within ``reach`` of ``(row, col)``, wrapping around its edges
    (the surface is circular)."""
    rows, cols = surface.shape
    if reach <= row < rows - reach and reach <= col < cols - reach:
        surface[row - reach : row + reach + 1, col - reach : col + reach + 1] = -np.inf
        return
    rows_idx = np.arange(row - reach, row + reach + 1) % rows
    cols_idx = np.arange(col - reach, col + reach + 1) % cols
    surface[np.ix_(rows_idx, cols_idx)] = -np.inf
