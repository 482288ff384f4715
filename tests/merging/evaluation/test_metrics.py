"""Merge-quality metrics: matching index (eq. 31), acceptance index, error against the truth."""

from __future__ import annotations

import numpy as np
import pytest

from merging.evaluation.metrics import (
    acceptance_index,
    match_indices,
    matching_index,
    transform_error,
)
from merging.grid import OccupancyGrid, free_mask, occupied_mask
from merging.transforms import rigid_matrix, rotation_about
from merging.warp import warp_cells
from tests.merging.builders import turned

EXACT = 1e-9
"""Ratios of cell counts and closed-form distances agree to floating-point rounding."""


def wall_map(*, rows: int = 20, cols: int = 20, wall: tuple[int, ...] = (10, 11)) -> np.ndarray:
    """A fully known free grid with a vertical wall in the given columns."""
    cells = np.zeros((rows, cols), dtype=np.int8)
    cells[:, list(wall)] = 100
    return cells


def office(seed: int) -> np.ndarray:
    """A known grid with random thin walls, for checks that need an irregular map."""
    rng = np.random.default_rng(seed)
    cells = np.zeros((60, 60), dtype=np.int8)
    for _ in range(12):
        r, c = rng.integers(0, 50, size=2)
        if rng.random() < 0.5:
            cells[r, c : c + 10] = 100
        else:
            cells[r : r + 10, c] = 100
    return cells


def test_matching_index_is_one_for_identical_maps_at_identity() -> None:
    cells = office(3)
    assert matching_index(cells, cells, np.eye(3)) == pytest.approx(1.0, abs=EXACT)


def test_matching_index_of_a_shifted_thick_wall() -> None:
    """A 2-cell wall shifted by one cell shares 1 of the 3 wall columns in the overlap."""
    cells = wall_map()
    assert matching_index(cells, cells, rigid_matrix(1, 0, 0)) == pytest.approx(1 / 3, abs=EXACT)
    assert matching_index(cells, cells, rigid_matrix(2, 0, 0)) == 0.0


def test_matching_index_drops_under_a_shift_and_a_turn() -> None:
    cells = office(4)
    shifted = matching_index(cells, cells, rigid_matrix(3, 0, 0))
    turned = matching_index(cells, cells, rotation_about(np.radians(10), (30, 30)))
    assert shifted < 0.5
    assert turned < 0.5


def test_matching_index_without_overlap_is_zero() -> None:
    cells = office(5)
    assert matching_index(cells, cells, rigid_matrix(500, 0, 0)) == 0.0


def test_acceptance_index_counts_agreeing_and_disagreeing_cells() -> None:
    cells = wall_map()
    assert acceptance_index(cells, cells, np.eye(3)) == pytest.approx(1.0, abs=EXACT)
    # one-cell shift, 19 overlapping columns: wall-wall at col 11, free-free at 16 columns,
    # wall over free at cols 10 and 12
    assert acceptance_index(cells, cells, rigid_matrix(1, 0, 0)) == pytest.approx(
        17 / 19, abs=EXACT
    )


def test_acceptance_index_ignores_unknown_cells() -> None:
    cells = wall_map()
    unknown = np.full_like(cells, -1)
    assert acceptance_index(cells, unknown, np.eye(3)) == 0.0
    half = cells.copy()
    half[:, :10] = -1  # what is left still agrees exactly
    assert acceptance_index(cells, half, np.eye(3)) == pytest.approx(1.0, abs=EXACT)


def test_match_indices_equal_the_separate_metrics(building: np.ndarray) -> None:
    # The benchmark scores every answer with both indices from one warp.
    map2, truth = turned(building, 25.0, (4.0, -6.0))
    for matrix in (truth, rigid_matrix(3.0, 1.0, 0.02) @ truth, np.eye(3)):
        assert match_indices(building, map2, matrix) == (
            matching_index(building, map2, matrix),
            acceptance_index(building, map2, matrix),
        )


def warped_indices(map1: np.ndarray, map2: np.ndarray, matrix: np.ndarray) -> tuple[float, float]:
    """The oracle: warp map 2 whole into map 1's grid, then count with masks."""
    warped = warp_cells(map2, matrix, map1.shape)
    overlap = (map1 >= 0) & (warped >= 0)
    occ1, occ2 = occupied_mask(map1) & overlap, occupied_mask(warped) & overlap
    either = np.count_nonzero(occ1 | occ2)
    matching = np.count_nonzero(occ1 & occ2) / either if either else 0.0
    free1, free2 = free_mask(map1), free_mask(warped)
    agree = np.count_nonzero((occ1 & occ2) | (free1 & free2))
    disagree = np.count_nonzero((occ1 & free2) | (free1 & occ2))
    return matching, agree / (agree + disagree) if agree + disagree else 0.0


def test_indices_equal_warping_map_2_whole_and_counting() -> None:
    rng = np.random.default_rng(12)
    values = np.array([-1, 0, 10, 19, 20, 50, 64, 65, 100], np.int8)
    for trial in range(60):
        map1 = rng.choice(values, size=tuple(rng.integers(5, 40, 2)))
        map2 = rng.choice(values, size=tuple(rng.integers(5, 40, 2)))
        if trial % 3 == 0:  # a small known patch: only the map 1 cells it can reach are looked at
            patch = map2[:4, 2:7].copy()
            map2[...] = -1
            map2[:4, 2:7] = patch
        angle = rng.integers(4) * np.pi / 2 if trial % 2 else rng.uniform(-np.pi, np.pi)
        dx, dy = rng.integers(-10, 10, 2) + rng.choice([0.0, 0.5], 2)
        matrix = rigid_matrix(float(dx), float(dy), float(angle))
        expected = warped_indices(map1, map2, matrix)
        assert match_indices(map1, map2, matrix) == expected  # the same counts, exactly
        assert matching_index(map1, map2, matrix) == expected[0]
        assert acceptance_index(map1, map2, matrix) == expected[1]


def test_transform_error_of_the_truth_is_zero() -> None:
    cells = office(6)
    truth = rigid_matrix(4.0, -3.0, 0.5)
    rms, rotation = transform_error(truth, truth, cells)
    assert rms == pytest.approx(0.0, abs=EXACT)
    assert rotation == pytest.approx(0.0, abs=EXACT)


def test_transform_error_of_a_pure_offset_is_its_length() -> None:
    cells = office(7)
    truth = rigid_matrix(4.0, -3.0, 0.5)
    rms, rotation = transform_error(rigid_matrix(3.0, 4.0, 0.0) @ truth, truth, cells)
    assert rms == pytest.approx(5.0, abs=EXACT)
    assert rotation == pytest.approx(0.0, abs=EXACT)


def test_transform_error_of_a_half_turn_about_a_cell() -> None:
    """Points at distance r from the centre move by 2r under a half turn."""
    cells = np.zeros((5, 5), dtype=np.int8)
    cells[2, 4] = 100  # (x, y) = (4, 2), two cells right of the centre (2, 2)
    rms, rotation = transform_error(rotation_about(np.pi, (2, 2)), np.eye(3), cells)
    assert rms == pytest.approx(4.0, abs=EXACT)
    assert rotation == pytest.approx(180.0, abs=EXACT)


def test_transform_error_of_an_empty_map_uses_its_corners() -> None:
    cells = np.zeros((4, 6), dtype=np.int8)
    rms, _ = transform_error(rigid_matrix(0.0, 2.0, 0.0), np.eye(3), cells)
    assert rms == pytest.approx(2.0, abs=EXACT)


def test_metrics_take_occupancy_grids_as_the_other_functions_do(building: np.ndarray) -> None:
    grid, matrix = OccupancyGrid(building), rigid_matrix(3.0, -1.0, 0.1)
    assert matching_index(grid, grid, matrix) == matching_index(building, building, matrix)
    assert acceptance_index(grid, grid, matrix) == acceptance_index(building, building, matrix)
    assert transform_error(matrix, np.eye(3), grid) == transform_error(matrix, np.eye(3), building)


@pytest.mark.parametrize(
    ("matrix", "message"),
    [(np.full((3, 3), np.nan), "3x3"), (np.eye(2), "3x3"), (np.diag([1.0, 0.0, 1.0]), "singular")],
)
def test_metrics_refuse_a_matrix_that_is_not_a_transform(matrix: np.ndarray, message: str) -> None:
    cells = np.zeros((4, 6), dtype=np.int8)
    with pytest.raises(ValueError, match=message):
        match_indices(cells, cells, matrix)
    if message == "3x3":
        with pytest.raises(ValueError, match=message):
            transform_error(matrix, np.eye(3), cells)
