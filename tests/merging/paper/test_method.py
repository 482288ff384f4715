"""The paper's method follows its equations: eq. (7), eqs. (11)-(17), the mixtures, the MCO."""

from __future__ import annotations

import numpy as np
import pytest

import merging
from merging.evaluation.metrics import transform_error
from merging.paper.method import (
    PAPER_ANGLES_DEG,
    coarse_translation,
    cross_correlation,
    rotation_from_maxima,
    sinogram_maximum,
)
from merging.paper.monte_carlo import entropy, search_space
from merging.paper.sinogram import sinogram
from tests.merging.builders import turned


def long_wall_map(normal_deg: float) -> np.ndarray:
    """A map whose strongest feature is one long wall with its normal at ``normal_deg``."""
    grid = np.zeros((161, 161), dtype=np.int8)
    direction = np.deg2rad(normal_deg + 90.0)
    for t in np.linspace(-70, 70, 400):
        x, y = 80 + t * np.cos(direction), 80 + 10 + t * np.sin(direction)
        grid[round(y), round(x)] = 100
    grid[30:36, 40:44] = 100  # a small box so the map is not a bare line
    return grid


def test_eq7_rotation_is_the_difference_of_maximum_angles() -> None:
    # The paper's example: maxima at 91° and 106° give Δθ = 15°.
    first = sinogram(long_wall_map(91.0), angles_deg=PAPER_ANGLES_DEG)
    second = sinogram(long_wall_map(106.0), angles_deg=PAPER_ANGLES_DEG)
    assert sinogram_maximum(first)[1] == pytest.approx(91.0, abs=1.0)
    assert sinogram_maximum(second)[1] == pytest.approx(106.0, abs=1.0)
    assert rotation_from_maxima(first, second) == pytest.approx(15.0, abs=1.0)


def test_partial_sinogram_correlation_finds_a_pure_shift() -> None:
    grid = np.zeros((120, 150), dtype=np.int8)
    grid[20, 10:90] = grid[10:70, 30] = grid[55, 40:120] = 100
    shifted = np.zeros_like(grid)
    shifted[7:, 12:] = grid[:-7, :-12]
    matrix, _, _ = coarse_translation(grid, shifted, 0.0)
    # Map 2 is map 1 moved by (+12, +7): T moves it back.
    assert np.allclose(matrix[:2, 2], [-12.0, -7.0])
    assert np.allclose(matrix[:2, :2], np.eye(2))


def test_cross_correlation_is_normalised_with_lags() -> None:
    a = np.array([0.0, 1, 2, 1, 0, 0, 0])
    b = np.array([0.0, 0, 0, 1, 2, 1, 0])
    lags, values = cross_correlation(a, b)
    assert lags[int(np.argmax(values))] == -2
    assert values.max() == pytest.approx(1.0)


def test_entropy_of_flat_and_constant_values() -> None:
    assert entropy(np.zeros(10)) == 0.0
    assert entropy(np.arange(256.0)) == pytest.approx(8.0)


def test_search_space_is_centred_on_the_coarse_estimate(building: np.ndarray) -> None:
    map2, _ = turned(building, 30.0, (0.0, 0.0))
    s1 = sinogram(building, angles_deg=PAPER_ANGLES_DEG)
    s2 = sinogram(map2, angles_deg=PAPER_ANGLES_DEG)
    coarse, correlations, _ = coarse_translation(building, map2, -np.deg2rad(30.0))
    space = search_space(s1, s2, correlations, coarse)
    assert space.rotation_means[0] == pytest.approx(merging.matrix_to_pose(coarse)[2])
    assert 1 <= len(space.rotation_means) <= 8  # ⌈entropy⌉ of 256 grey levels
    assert space.rotation_sigma > 0 and np.all(space.translation_sigma > 0)


def test_paper_method_merges_an_easy_pair(building: np.ndarray) -> None:
    # A turn by a multiple of the sinogram step keeps the maxima exact.
    map2, truth = turned(building, 20.0, (3.0, -4.0))
    coarse = merging.estimate_transform(building, map2, method="paper", optimise=False)
    assert transform_error(coarse.matrix, truth, map2)[1] < 1.5
    result = merging.estimate_transform(building, map2, method="paper", rng=3)
    assert transform_error(result.matrix, truth, map2)[1] < 5.0
    assert set(result.timings) >= {"sinograms", "translation", "optimisation", "total"}


def test_paper_method_is_seeded(building: np.ndarray) -> None:
    map2, _ = turned(building, 50.0, (0.0, 0.0))
    a = merging.estimate_transform(building, map2, method="paper", rng=11)
    b = merging.estimate_transform(building, map2, method="paper", rng=11)
    assert np.array_equal(a.matrix, b.matrix)


def test_paper_method_rejects_bad_sample_counts(building: np.ndarray) -> None:
    with pytest.raises(ValueError, match="rotation_samples"):
        merging.estimate_transform(building, building, method="paper", rotation_samples=0)
    for bad in (2.5, True, "3"):
        with pytest.raises(ValueError, match="saliency_points must be a whole number >= 1"):
            merging.estimate_transform(building, building, method="paper", saliency_points=bad)
    with pytest.raises(ValueError, match="optimise must be True or False"):
        merging.estimate_transform(building, building, method="paper", optimise="no")
