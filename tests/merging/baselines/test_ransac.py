"""The rigid fit (Kabsch without scale) and RANSAC over it: exact recovery, outliers, seeding."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from merging.baselines.ransac import fit_rigid, ransac_rigid
from merging.transforms import apply_transform, matrix_to_pose, rigid_matrix

EXACT = 1e-9
"""Noise-free correspondences are fitted to floating-point rounding."""


def scattered(count: int, seed: int) -> np.ndarray:
    """``count`` points spread over a 400 x 300 cell map."""
    return np.random.default_rng(seed).uniform([0, 0], [400, 300], size=(count, 2))


@settings(max_examples=30, deadline=None)
@given(
    dx=st.floats(-500, 500),
    dy=st.floats(-500, 500),
    theta=st.floats(-np.pi, np.pi),
    seed=st.integers(0, 1000),
)
def test_fit_recovers_any_rigid_transform_exactly(dx, dy, theta, seed) -> None:
    truth = rigid_matrix(dx, dy, theta)
    source = scattered(12, seed)
    estimate = fit_rigid(source, apply_transform(truth, source))
    assert np.allclose(estimate, truth, atol=1e-6)


def test_fit_never_returns_a_reflection() -> None:
    # Mirrored targets have no rigid explanation; the fit must stay a rotation.
    source = scattered(20, 1)
    mirrored = source * np.array([-1.0, 1.0])
    estimate = fit_rigid(source, mirrored)
    assert np.linalg.det(estimate[:2, :2]) == pytest.approx(1.0, abs=EXACT)


def test_zero_weight_ignores_a_pair() -> None:
    truth = rigid_matrix(3.0, -7.0, 0.4)
    source = scattered(10, 2)
    target = apply_transform(truth, source)
    target[0] += [80.0, -50.0]
    weights = np.ones(10)
    weights[0] = 0.0
    assert np.allclose(fit_rigid(source, target, weights=weights), truth, atol=EXACT)


def test_ransac_finds_the_transform_among_outliers() -> None:
    truth = rigid_matrix(120.0, -40.0, np.deg2rad(-75.0))
    source = scattered(100, 3)
    target = apply_transform(truth, source)
    rng = np.random.default_rng(5)
    target += rng.normal(0.0, 0.5, size=target.shape)
    wrong = rng.random(100) < 0.7  # 70 % of the pairs are wrong matches
    target[wrong] = rng.uniform([0, 0], [400, 300], size=(int(wrong.sum()), 2))
    fit = ransac_rigid(source, target, threshold=3.0, rng=11)
    assert fit is not None
    dx, dy, theta = matrix_to_pose(fit.matrix @ np.linalg.inv(truth))
    assert np.hypot(dx, dy) < 2.0 and abs(np.rad2deg(theta)) < 0.5
    # Every right pair is an inlier; wrong ones only by the chance of landing within 3 cells.
    assert np.all(fit.inliers[~wrong])
    assert np.count_nonzero(fit.inliers[wrong]) <= 2


def test_ransac_is_seeded() -> None:
    source = scattered(60, 4)
    target = scattered(60, 5)
    target[:20] = apply_transform(rigid_matrix(5.0, 5.0, 1.0), source[:20])
    a = ransac_rigid(source, target, threshold=2.0, rng=7)
    b = ransac_rigid(source, target, threshold=2.0, rng=7)
    assert a is not None and b is not None
    assert np.array_equal(a.matrix, b.matrix) and a.iterations == b.iterations


def test_ransac_gives_none_without_consensus() -> None:
    # Unrelated points: no rigid transform lines up five of them within half a cell.
    fit = ransac_rigid(scattered(30, 6), scattered(30, 7), threshold=0.5, rng=0, min_inliers=5)
    assert fit is None
    assert ransac_rigid(np.zeros((1, 2)), np.ones((1, 2)), threshold=1.0, rng=0) is None


@pytest.mark.parametrize(
    ("source", "target", "kwargs", "message"),
    [
        (np.zeros((5, 3)), np.zeros((5, 3)), {}, "source must be an"),
        (np.zeros((5, 2)), np.zeros((4, 2)), {}, "target must have the shape"),
        (np.full((5, 2), np.nan), np.zeros((5, 2)), {}, "finite"),
        (np.zeros((5, 2)), np.zeros((5, 2)), {"threshold": 0.0}, "threshold"),
        (np.zeros((5, 2)), np.zeros((5, 2)), {"max_iterations": 0}, "max_iterations"),
        (np.zeros((5, 2)), np.zeros((5, 2)), {"min_inliers": 1}, "min_inliers"),
    ],
)
def test_ransac_rejects_bad_input_by_name(source, target, kwargs, message) -> None:
    options = {"threshold": 1.0, **kwargs}
    with pytest.raises(ValueError, match=message):
        ransac_rigid(source, target, rng=0, **options)


def test_fit_rejects_too_few_pairs_and_bad_weights() -> None:
    with pytest.raises(ValueError, match="at least 2"):
        fit_rigid(np.zeros((1, 2)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="weights"):
        fit_rigid(np.zeros((3, 2)), np.zeros((3, 2)), weights=[1.0, -1.0, 1.0])
