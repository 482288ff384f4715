"""Tracking a known transform: refine from a nearby start, verify, refuse lost tracks."""

from __future__ import annotations

import numpy as np
import pytest

from merging import estimate_transform
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from merging.grid import OccupancyGrid
from merging.tomographic.tracking import frame_to_cells, track_transform
from merging.transforms import cells_to_metres, rigid_matrix
from tests.merging.builders import synthetic_building

TRACKED_CELLS = 1.0
"""Cells (RMS over map 2's walls) a tracked transform must end within: refinement on
the sharp fields reaches a fraction of a cell from a start a few cells off."""


def grids(pair: object, origin2: tuple[float, float] = (1.3, -0.7)) -> tuple[OccupancyGrid, ...]:
    """The pair's maps as grids with frames (map 2's origin elsewhere, as a robot's is)."""
    first = OccupancyGrid(pair.map1, resolution=0.05, origin=(0.0, 0.0, 0.0))  # type: ignore[attr-defined]
    second = OccupancyGrid(pair.map2, resolution=0.05, origin=(*origin2, 0.0))  # type: ignore[attr-defined]
    return first, second


def test_a_start_a_few_cells_off_is_refined_onto_the_truth() -> None:
    accepted = 0
    for pair in cut_window_pairs(synthetic_building(5), count=6, rng=2):
        first, second = grids(pair)
        truth = cells_to_metres(pair.truth, first, second)
        start = truth @ rigid_matrix(0.12, -0.09, np.radians(1.0))  # 2-3 cells and a degree off
        result = track_transform(first, second, start)
        assert result.matrix_metres is not None
        np.testing.assert_allclose(
            result.matrix, frame_to_cells(result.matrix_metres, first, second), atol=1e-9
        )
        rms, _ = transform_error(result.matrix, pair.truth, pair.map2)
        before, _ = transform_error(frame_to_cells(start, first, second), pair.truth, pair.map2)
        assert before > TRACKED_CELLS
        if result.accepted:  # an accepted tracked transform is right
            assert rms <= TRACKED_CELLS
        # Where the global search vouches for the pair, tracking from near the truth does too.
        if estimate_transform(first, second).accepted:
            assert result.accepted, result.reason
            accepted += 1
    assert accepted >= 2


def test_a_wrong_start_is_refused() -> None:
    (pair,) = cut_window_pairs(synthetic_building(6), count=1, rng=4)
    first, second = grids(pair)
    truth = cells_to_metres(pair.truth, first, second)
    far = track_transform(first, second, truth @ rigid_matrix(2.0, 1.0, np.radians(30.0)))
    assert not far.accepted and far.reason
    turned = track_transform(first, second, truth @ rigid_matrix(0.0, 0.0, np.pi))
    assert not turned.accepted and turned.reason


def test_bad_input_is_named() -> None:
    grid = OccupancyGrid(np.zeros((5, 5), np.int8))
    with pytest.raises(ValueError, match="3x3"):
        track_transform(grid, grid, np.eye(2))
    with pytest.raises(TypeError, match="OccupancyGrids"):
        track_transform(grid.data, grid, np.eye(3))  # type: ignore[arg-type]
    empty = track_transform(grid, grid, np.eye(3))
    assert not empty.accepted and "too few occupied" in empty.reason
