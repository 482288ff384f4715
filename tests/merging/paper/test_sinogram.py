"""The sinogram (eqs. 2-6): analytic cases and agreement with skimage's Radon transform."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.transform import radon

from merging.paper.sinogram import map_centre, project_points, sinogram, sinogram_radius


def test_one_occupied_cell_traces_a_sine() -> None:
    # A single cell at (x, y) relative to the centre projects to s = x cos α + y sin α.
    cells = np.zeros((41, 61), dtype=np.int8)
    centre = (30.0, 20.0)
    x, y = 12, -7
    cells[int(centre[1]) + y, int(centre[0]) + x] = 100
    sino = sinogram(cells, centre=centre)
    alphas = np.deg2rad(sino.angles_deg)
    expected = np.rint(x * np.cos(alphas) + y * np.sin(alphas)).astype(int)
    rows, columns = np.nonzero(sino.values)
    order = np.argsort(columns)
    rows, columns = rows[order], columns[order]
    assert np.array_equal(columns, np.arange(len(alphas)))
    assert np.array_equal(rows - sino.rho, expected)
    assert np.all(sino.values[rows, columns] == 1.0)
    assert len(columns) == len(alphas)


def test_a_straight_wall_peaks_at_its_normal() -> None:
    # A horizontal wall of 40 cells at y = +5: at α = 90° all its mass sits at s = 5.
    cells = np.zeros((51, 51), dtype=np.int8)
    cells[25 + 5, 5:45] = 100
    sino = sinogram(cells, centre=(25.0, 25.0))
    column = sino.column(90.0)
    assert column[sino.rho + 5] == 40
    assert column.sum() == 40
    # Near 90° the wall still falls in one bin, so the maximum is a plateau around 90°.
    peak_angles = sino.angles_deg[np.nonzero(sino.values.max(axis=0) == sino.values.max())[0]]
    assert 90.0 in peak_angles and np.all(np.abs(peak_angles - 90.0) <= 2.0)
    assert sino.values.max() == 40


def test_every_column_holds_every_occupied_cell() -> None:
    rng = np.random.default_rng(11)
    cells = np.where(rng.random((70, 90)) < 0.05, 100, 0).astype(np.int8)
    sino = sinogram(cells)
    assert np.allclose(sino.values.sum(axis=0), np.count_nonzero(cells == 100))


def test_radius_and_centre_follow_eq6() -> None:
    # The paper's 1-based centre (⌊(r+1)/2⌋, ⌊(c+1)/2⌋) = (4, 5) for a 7 x 10 map.
    assert map_centre((7, 10)) == (4.0, 3.0)
    # The farthest cell (9, 0) lies at distance sqrt(5² + 3²) = 5.83 -> ceil 6, plus 1.
    assert sinogram_radius((7, 10), (4.0, 3.0)) == 7


@pytest.mark.parametrize("theta", [0.0, 17.0, 45.0, 90.0, 128.0, 163.0])
def test_agrees_with_skimage_radon(theta: float) -> None:
    # skimage projects s' = (x - c) cos θ - (y - c) sin θ with rows as y, so its
    # column θ is ours at α = -θ (mod 360), read with s reversed past 180°.
    rng = np.random.default_rng(5)
    image = np.zeros((64, 80))
    image[10:12, 5:60] = 1
    image[20:50, 30] = 1
    image[rng.integers(0, 64, 30), rng.integers(0, 80, 30)] = 1
    cells = np.where(image > 0, 100, 0).astype(np.int8)
    rows, cols = image.shape
    ours = sinogram(cells, angles_deg=np.arange(360.0), centre=(cols // 2, rows // 2))
    theirs = radon(image, theta=[theta], circle=False)[:, 0]
    column = ours.values[:, int((-theta) % 360)]
    s_theirs = np.arange(len(theirs)) - len(theirs) // 2
    resampled = np.interp(s_theirs, ours.offsets, column, left=0.0, right=0.0)
    total = image.sum()
    assert abs(theirs.sum() - total) < 0.05 * total
    # Binning moves mass by under one cell of s: compare cumulative profiles.
    gap = np.abs(np.cumsum(theirs) - np.cumsum(resampled))
    assert gap.max() < 0.06 * total
    if theta in (0.0, 90.0):
        assert np.allclose(theirs, resampled)


def test_weights_scale_the_mass() -> None:
    points = np.array([[0.0, 0.0], [3.0, 4.0]])
    plain = project_points(points, [0.0], 6)
    weighted = project_points(points, [0.0], 6, weights=[2.0, 0.5])
    assert plain[6, 0] == 1 and plain[9, 0] == 1
    assert weighted[6, 0] == 2.0 and weighted[9, 0] == 0.5


def test_rejects_a_three_dimensional_grid() -> None:
    with pytest.raises(ValueError, match="2-D"):
        sinogram(np.zeros((3, 3, 3), dtype=np.int8))
