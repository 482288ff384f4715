"""The compiled nearest-neighbour warp against scipy's affine_transform (its oracle)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from merging.warp import warp_cells


def scipy_warp(
    cells: np.ndarray, matrix: np.ndarray, shape: tuple[int, int], fill: int
) -> np.ndarray:
    """The oracle: ndimage's order-0 resampling, given the inverse with its axes swapped."""
    inverse = np.linalg.inv(matrix)
    swapped = np.array([[inverse[1, 1], inverse[1, 0]], [inverse[0, 1], inverse[0, 0]]])
    offset = np.array([inverse[1, 2], inverse[0, 2]])
    return ndimage.affine_transform(
        cells, swapped, offset=offset, output_shape=shape, order=0,
        mode="grid-constant", cval=fill, prefilter=False,
    )  # fmt: skip


def random_case(
    rng: np.random.Generator, kind: int
) -> tuple[np.ndarray, np.ndarray, tuple[int, int], int]:
    """Cells, a matrix, an output shape and a fill value; ``kind`` picks the transform:
    any rotation, quarter turns (whose pre-images fall on cell boundaries), a pure
    shift, or a rotation with a scale."""
    rows, cols = (int(n) for n in rng.integers(1, 50, 2))
    cells = rng.integers(-1, 101, (rows, cols)).astype(np.int8)
    angle = [rng.uniform(-np.pi, np.pi), rng.integers(4) * np.pi / 2, 0.0][kind % 3]
    scale = rng.uniform(0.3, 3.0) if kind == 3 else 1.0
    # Shifts by whole, half and quarter cells put pre-images exactly between cells.
    shift = rng.integers(-20, 20, 2) + rng.choice([0.0, 0.5, 0.25, rng.uniform()], 2)
    c, s = scale * np.cos(angle), scale * np.sin(angle)
    matrix = np.array([[c, -s, shift[0]], [s, c, shift[1]], [0.0, 0.0, 1.0]])
    shape = (int(rng.integers(1, 70)), int(rng.integers(1, 70)))
    return cells, matrix, shape, int(rng.choice([-1, 0, 100]))


@pytest.mark.parametrize("kind", [0, 1, 2, 3])
def test_warp_matches_scipy_cell_for_cell(kind: int) -> None:
    rng = np.random.default_rng(kind)
    for _ in range(400):
        cells, matrix, shape, fill = random_case(rng, kind)
        np.testing.assert_array_equal(
            warp_cells(cells, matrix, shape, fill=fill), scipy_warp(cells, matrix, shape, fill)
        )


def test_warp_rounds_half_way_pre_images_up_and_fills_off_the_input() -> None:
    cells = np.arange(1, 6, dtype=np.int8)[None, :]
    half = np.array([[1.0, 0.0, -0.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    # Output cell c has pre-image c + 0.5, which rounds to input cell c + 1.
    np.testing.assert_array_equal(warp_cells(cells, half, (1, 6)), [[2, 3, 4, 5, -1, -1]])
    assert warp_cells(cells, np.eye(3), (0, 3)).shape == (0, 3)
