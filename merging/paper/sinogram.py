"""Sinograms of occupancy grids: the Radon transform of eqs. (2)-(6) of the paper.

The Radon transform integrates the occupied indicator of a grid along the
lines ``x cos(α) + y sin(α) = s`` (eq. 2, with ``(x, y) = (col, row)``
relative to the map centre). Rather than rotating the image once per angle,
each occupied cell is dropped into the bin of ``s`` its centre projects to: a
projection histogram. A cell carries unit area, so each column of the result
sums to the number of occupied cells, and along the axes (α = 0°, 90°) it
equals the line integral exactly; at other angles a cell's chord is spread
over neighbouring bins, which changes each bin by less than one cell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import occupied_cells, validate_cells

DEFAULT_ANGLES_DEG = np.arange(180.0)
"""Projection angles α of the paper's sinograms: 0°..179° in 1° steps (eqs. 4-5)."""
_CHUNK = 1 << 21
"""Cell-angle pairs projected at once: bounds the temporary memory to ~20 MB."""


@dataclass(frozen=True, slots=True)
class Sinogram:
    """A sinogram ``S(s, α)`` and its axes.

    Attributes
    ----------
    values : (2 * rho + 1, n_angles) float ndarray
        Occupied cells per unit of ``s`` at each angle; row ``i`` holds
        ``s = i - rho``.
    angles_deg : (n_angles,) float ndarray
        The projection angles α in degrees.
    rho : int
        The largest ``|s|`` represented (eq. 6).
    centre : (float, float)
        ``(x, y)`` cell coordinates of the origin of ``s``.
    """

    values: NDArray[np.float64]
    angles_deg: NDArray[np.float64]
    rho: int
    centre: tuple[float, float]

    @property
    def offsets(self) -> NDArray[np.float64]:
        """The ``s`` value of each row, ``-rho..rho``."""
        return np.arange(-self.rho, self.rho + 1, dtype=float)

    def column(self, angle_deg: float) -> NDArray[np.float64]:
        """The partial sinogram ``PS^α'`` of eq. (11): the column at ``angle_deg``."""
        index = int(np.argmin(np.abs(self.angles_deg - angle_deg)))
        if abs(self.angles_deg[index] - angle_deg) > 1e-9:
            raise ValueError(f"angle {angle_deg} deg is not one of the sinogram's angles")
        return self.values[:, index]


def map_centre(shape: tuple[int, int]) -> tuple[float, float]:
    """Centre ``(x, y)`` of a map of ``shape = (rows, cols)`` as eq. (6) defines it.

    The paper's centre ``(⌊(r+1)/2⌋, ⌊(c+1)/2⌋)`` counts from 1; counted from 0
    it is ``((c+1)//2 - 1, (r+1)//2 - 1)``.
    """
    rows, cols = shape
    return (float((cols + 1) // 2 - 1), float((rows + 1) // 2 - 1))


def sinogram_radius(shape: tuple[int, int], centre: tuple[float, float]) -> int:
    """``rho`` of eq. (6): the largest distance from ``centre`` to a cell, rounded up, plus one."""
    rows, cols = shape
    cx, cy = centre
    far_x = max(cx, cols - 1 - cx)
    far_y = max(cy, rows - 1 - cy)
    return int(np.ceil(np.hypot(far_x, far_y))) + 1


def project_points(
    points: ArrayLike,
    angles_deg: ArrayLike,
    rho: int,
    *,
    weights: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Projection histogram of points: the kernel behind :func:`sinogram`.

    Parameters
    ----------
    points : (N, 2) float array
        ``(x, y)`` relative to the origin of ``s``.
    angles_deg : (A,) float array
        Projection angles α in degrees.
    rho : int
        Bins cover ``s = -rho..rho``; points projecting outside are dropped.
    weights : (N,) float array, optional
        Mass of each point (default 1).

    Returns
    -------
    (2 * rho + 1, A) float ndarray
        ``S[i, a]`` is the mass whose ``s = x cos α_a + y sin α_a`` rounds to ``i - rho``.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    angles = np.deg2rad(np.asarray(angles_deg, dtype=np.float64).ravel())
    n_bins = 2 * rho + 1
    w = None if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    cos_sin = np.stack([np.cos(angles), np.sin(angles)])  # (2, A)
    flat = np.zeros(n_bins * len(angles), dtype=np.float64)
    column = np.arange(len(angles), dtype=np.int64)
    chunk = max(1, _CHUNK // max(len(angles), 1))
    for start in range(0, len(pts), chunk):
        block = pts[start : start + chunk]
        # Shift by rho + 0.5 so that truncation towards zero rounds to the nearest bin.
        s = block @ cos_sin + (rho + 0.5)
        bins = s.astype(np.int64)
        valid = (s >= 0) & (bins < n_bins)
        index = bins * len(angles) + column
        if w is None:
            flat += np.bincount(index[valid], minlength=flat.size)
        else:
            mass = np.broadcast_to(w[start : start + chunk, None], s.shape)
            flat += np.bincount(index[valid], weights=mass[valid], minlength=flat.size)
    return flat.reshape(n_bins, len(angles))


def sinogram(
    grid: ArrayLike,
    *,
    angles_deg: ArrayLike = DEFAULT_ANGLES_DEG,
    centre: tuple[float, float] | None = None,
) -> Sinogram:
    """The sinogram ``S_M = RT_M(s, α)`` of a grid's occupied cells (eqs. 3-6).

    Parameters
    ----------
    grid : (rows, cols) array in the ROS coding
        Occupied cells (``>= 65``) count 1, all others 0.
    angles_deg : (A,) float array
        Projection angles α in degrees (default 0..179, eqs. 4-5).
    centre : (float, float), optional
        Origin of ``s`` in ``(x, y)`` cells; default the map centre of eq. (6),
        see :func:`map_centre`.

    Returns
    -------
    Sinogram
        With ``rho`` from eq. (6).

    References
    ----------
    .. [1] H. Lee, "Tomographic Feature-Based Map Merging for Multi-Robot
       Systems", Electronics 2020, 9(1), 107. Eqs. (2)-(6).
    """
    cells = validate_cells(np.asarray(grid), name="grid")
    origin = map_centre(cells.shape) if centre is None else (float(centre[0]), float(centre[1]))
    rho = sinogram_radius(cells.shape, origin)
    angles = np.asarray(angles_deg, dtype=np.float64).ravel()
    points = occupied_cells(cells) - np.asarray(origin)
    values = project_points(points, angles, rho)
    return Sinogram(values=values, angles_deg=angles, rho=rho, centre=origin)
