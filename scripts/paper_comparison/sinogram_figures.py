"""Figures 3-5 of the paper for one pair: its sinograms and partial-sinogram correlations.

They show the steps of the paper's pipeline (:mod:`merging.paper`) on the
first Sim. pair: where each map's sinogram peaks (eq. 7 takes the rotation
from those peaks) and how the partial sinograms at α' = 180° and 90°
correlate (eqs. 11-17 take the translation from those correlations).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from merging.grid import occupied_cells
from merging.paper.method import (
    PAPER_ANGLES_DEG,
    axis_projections,
    coarse_translation,
    rotate_occupied,
    rotation_from_maxima,
    sinogram_maximum,
)
from merging.paper.sinogram import sinogram

from .plotting import pyplot, save
from .study import Case


def plot_sinograms(case: Case, path: Path) -> None:
    """Figure 3 of the paper: the sinograms of the two maps, their maxima marked."""
    figure, axes = pyplot().subplots(1, 2, figsize=(10, 4))
    for axis, cells, name in zip(axes, (case.map1, case.map2), ("M1", "M2"), strict=True):
        sino = sinogram(cells, angles_deg=PAPER_ANGLES_DEG)
        s_max, alpha_max = sinogram_maximum(sino)
        axis.imshow(
            np.sqrt(sino.values),
            aspect="auto",
            origin="lower",
            cmap="gray",
            extent=(0, 180, -sino.rho - 0.5, sino.rho + 0.5),
        )
        axis.plot(alpha_max, s_max, "r+", markersize=14, markeredgewidth=2)
        axis.set_title(f"S_{name}: maximum at (s={s_max:.0f}, α={alpha_max:.0f}°)")
        axis.text(2, -sino.rho * 0.95, "grey level: sqrt(S)", color="w", fontsize=7)
        axis.set_xlabel("α (degrees)")
        axis.set_ylabel("s (cells)")
    figure.suptitle(f"Sinograms (eqs. 4-5) of pair {case.label}")
    save(figure, path)


def plot_partial_sinograms(case: Case, path: Path) -> None:
    """Figures 4 and 5: partial sinograms at α' = 180° and 90° and their cross-correlations.

    Map 2 is turned by the paper's rotation estimate (eq. 7, the 180° ambiguity
    settled as :func:`merging.paper.method.paper_merge` does); the dashed line marks
    the shift the truth implies for that rotation.
    """
    delta = rotation_from_maxima(
        sinogram(case.map1, angles_deg=PAPER_ANGLES_DEG),
        sinogram(case.map2, angles_deg=PAPER_ANGLES_DEG),
    )
    thetas = [-np.deg2rad(delta + turn) for turn in (0.0, 180.0)]
    coarse = [coarse_translation(case.map1, case.map2, theta) for theta in thetas]
    chosen = int(np.argmax([peak for _, _, peak in coarse]))
    theta, correlations = thetas[chosen], coarse[chosen][1]
    rotated, to_rotated = rotate_occupied(case.map2, theta)
    rows = int(max(case.map1.shape[0], np.ceil(rotated[:, 1].max()) + 1))
    cols = int(max(case.map1.shape[1], np.ceil(rotated[:, 0].max()) + 1))
    first = axis_projections(occupied_cells(case.map1), (rows, cols))
    second = axis_projections(rotated, (rows, cols))
    implied = None
    if case.truth is not None:
        implied = (case.truth @ np.linalg.inv(to_rotated))[:2, 2]
    figure, axes = pyplot().subplots(2, 3, figsize=(12, 5.5))
    for k, (axis_name, figure_number) in enumerate((("X", 4), ("Y", 5))):
        lags, values = correlations[k]
        best = int(lags[int(np.argmax(values))])
        axes[k, 0].plot(first[k], "k-", linewidth=0.8)
        axes[k, 0].set_title(f"PS^{axis_name} of M1 (Fig. {figure_number})")
        axes[k, 1].plot(second[k], "k-", linewidth=0.8)
        axes[k, 1].set_title(f"PS^{axis_name} of M~2, turned by {np.rad2deg(theta):.0f}°")
        axes[k, 2].plot(lags, values, "b-", linewidth=0.8)
        axes[k, 2].axvline(best, color="r", linewidth=1, label=f"argmax {best}")
        if implied is not None:
            axes[k, 2].axvline(
                implied[k], color="g", linestyle="--", linewidth=1, label=f"truth {implied[k]:.0f}"
            )
        axes[k, 2].set_title(f"normalised CC{axis_name} (eq. {14 + k})")
        axes[k, 2].legend(fontsize=7)
        for axis in axes[k, :2]:
            axis.set_xlabel("x (cells)" if k == 0 else "y (cells)")
            axis.set_ylabel("occupied cells")
        axes[k, 2].set_xlabel("lag (cells)")
    save(figure, path)
