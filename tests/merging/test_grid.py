"""The conventions of merging.grid: cell coding, thresholds, constructors, cell <-> metres."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from merging.grid import (
    FREE_THRESHOLD,
    OCCUPIED_THRESHOLD,
    OccupancyGrid,
    occupied_cells,
    validate_cells,
)

ROUND_TRIP = 1e-9
"""Cells: cell -> metres -> cell passes through one 3x3 inverse, exact up to rounding."""


def test_thresholds_are_map_server_s() -> None:
    assert OCCUPIED_THRESHOLD == 65  # occupied_thresh 0.65
    assert FREE_THRESHOLD == 19  # free_thresh 0.196 = 19.6 %
    values = np.array([[-1, 0, 19, 20, 64, 65, 100]], dtype=np.int8)
    grid = OccupancyGrid(values)
    np.testing.assert_array_equal(grid.occupied()[0], [0, 0, 0, 0, 0, 1, 1])
    np.testing.assert_array_equal(grid.free()[0], [0, 1, 1, 0, 0, 0, 0])
    np.testing.assert_array_equal(grid.known()[0], [0, 1, 1, 1, 1, 1, 1])


def test_occupied_cells_are_col_row() -> None:
    cells = np.zeros((3, 4), dtype=np.int8)
    cells[2, 1] = 100  # row 2, col 1
    np.testing.assert_array_equal(occupied_cells(cells), [[1.0, 2.0]])


def test_from_bool_without_free_mask_makes_everything_known() -> None:
    occupied = np.array([[True, False], [False, False]])
    grid = OccupancyGrid.from_bool(occupied, resolution=0.1)
    np.testing.assert_array_equal(grid.data, [[100, 0], [0, 0]])
    assert grid.data.dtype == np.int8
    assert grid.resolution == 0.1


def test_from_bool_with_free_mask_leaves_the_rest_unknown_and_walls_win() -> None:
    occupied = np.array([[True, False, False]])
    free = np.array([[True, True, False]])
    grid = OccupancyGrid.from_bool(occupied, free)
    np.testing.assert_array_equal(grid.data, [[100, 0, -1]])


def test_from_bool_refuses_non_boolean_and_mismatched_masks() -> None:
    with pytest.raises(TypeError, match="boolean"):
        OccupancyGrid.from_bool(np.zeros((2, 2), dtype=int))
    with pytest.raises(ValueError, match="shape"):
        OccupancyGrid.from_bool(np.zeros((2, 2), bool), np.zeros((3, 2), bool))
    with pytest.raises(ValueError, match="2-D"):
        OccupancyGrid.from_bool(np.zeros(4, bool))


def test_from_probability_maps_percent_and_nan_to_unknown() -> None:
    prob = np.array([[0.0, 0.19, 0.5, 0.65, 1.0, np.nan]])
    grid = OccupancyGrid.from_probability(prob)
    np.testing.assert_array_equal(grid.data, [[0, 19, 50, 65, 100, -1]])
    np.testing.assert_array_equal(grid.free()[0], [1, 1, 0, 0, 0, 0])
    np.testing.assert_array_equal(grid.occupied()[0], [0, 0, 0, 1, 1, 0])
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        OccupancyGrid.from_probability(np.array([[0.5, 1.2]]))
    for infinite in (np.inf, -np.inf):  # out of range, not unknown
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            OccupancyGrid.from_probability(np.array([[0.5, infinite]]))


def test_cell_to_world_puts_cell_centres_as_ros_does() -> None:
    grid = OccupancyGrid(np.zeros((4, 4), np.int8), resolution=0.5, origin=(1.0, 2.0, np.pi / 2))
    # centre of cell (0, 0) is origin + R(yaw) (0.25, 0.25); +x in cells is +y in metres
    np.testing.assert_allclose(grid.cell_to_world([[0, 0]]), [[0.75, 2.25]], atol=ROUND_TRIP)
    np.testing.assert_allclose(grid.cell_to_world([[1, 0]]), [[0.75, 2.75]], atol=ROUND_TRIP)
    np.testing.assert_allclose(grid.cell_to_world([[0, 1]]), [[0.25, 2.25]], atol=ROUND_TRIP)


def test_world_to_cell_inverts_cell_to_world_with_a_yaw() -> None:
    rng = np.random.default_rng(20240601)
    grid = OccupancyGrid(np.zeros((50, 60), np.int8), resolution=0.05, origin=(-3.0, 4.5, 0.7))
    cells = rng.uniform(-5, 70, size=(100, 2))
    np.testing.assert_allclose(
        grid.world_to_cell(grid.cell_to_world(cells)), cells, atol=ROUND_TRIP
    )
    # the origin itself is the corner of cell (0, 0): half a cell below and left of its centre
    np.testing.assert_allclose(grid.world_to_cell([[-3.0, 4.5]]), [[-0.5, -0.5]], atol=ROUND_TRIP)


def test_validate_cells_accepts_the_coding_and_returns_int8() -> None:
    ints = np.array([[-1, 0, 100]], dtype=np.int64)
    out = validate_cells(ints)
    assert out.dtype == np.int8
    np.testing.assert_array_equal(out, ints)
    already = np.array([[1, 2]], dtype=np.int8)
    assert validate_cells(already) is already
    np.testing.assert_array_equal(validate_cells(np.array([[-1.0, 50.0]])), [[-1, 50]])
    grid = OccupancyGrid(already)
    assert validate_cells(grid) is grid.data


def test_grids_of_only_0_and_1_percent_are_taken_unless_a_float_mask() -> None:
    # 0 and 1 percent are free cells of a map, as int8 grids, probabilities or loaded
    # maps hold them; a float array of 0.0 and 1.0 is refused above.
    np.testing.assert_array_equal(validate_cells(np.array([[0, 1]], np.int8)), [[0, 1]])
    grid = OccupancyGrid.from_probability(np.array([[0.0, 0.01]]))
    np.testing.assert_array_equal(grid.data, [[0, 1]])


@pytest.mark.parametrize(
    ("cells", "error", "message"),
    [
        (np.zeros(5), ValueError, "2-D"),
        (np.zeros((2, 2, 2)), ValueError, "2-D"),
        (np.zeros((0, 3)), ValueError, "at least one cell"),
        (np.array([[0.0, np.nan]]), ValueError, "NaN"),
        (np.array([[0.0, np.inf]]), ValueError, "NaN"),
        (np.array([[0.5, 1.0]]), ValueError, "fractional"),
        (np.array([[101, 0]]), ValueError, "-1..100"),
        (np.array([[-2, 0]]), ValueError, "-1..100"),
        (np.array([[0, 205, 254]], np.uint8), ValueError, "pixels of a map_server image"),
        (np.array([[0, 255, 100]], np.uint8), ValueError, "255 for unknown"),
        (np.array([[0.0, 1.0, 0.0]]), ValueError, "only 0 and 1.*from_bool"),
        (np.array([[True, False]]), TypeError, "from_bool"),
        (np.array([["a", "b"]]), TypeError, "dtype"),
        ([[0, 100]], TypeError, "list"),
        (None, TypeError, "NoneType"),
    ],
)
def test_validate_cells_names_the_problem(cells: object, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        validate_cells(cells, name="map7")
    with pytest.raises(error, match="map7"):
        validate_cells(cells, name="map7")


def test_grid_validates_resolution_and_origin_and_is_frozen() -> None:
    data = np.zeros((2, 2), np.int8)
    with pytest.raises(ValueError, match="resolution"):
        OccupancyGrid(data, resolution=0.0)
    with pytest.raises(ValueError, match="origin"):
        OccupancyGrid(data, origin=(0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="origin"):
        OccupancyGrid(data, origin=(0.0, np.nan, 0.0))
    for resolution in ("0.05", None, True, np.array([0.05, 0.1])):
        with pytest.raises(ValueError, match="resolution must be a positive number"):
            OccupancyGrid(data, resolution=resolution)  # type: ignore[arg-type]
    for origin in (None, 5, "123", (0.0, 0.0, True)):
        with pytest.raises(ValueError, match="origin must be three finite numbers"):
            OccupancyGrid(data, origin=origin)  # type: ignore[arg-type]
    # Origins of 1e308 m once made an accepted merge's transform in metres NaN.
    with pytest.raises(ValueError, match=r"origin \(1e\+308, 0\.0, 0\.0\) lies more than 1e\+09 m"):
        OccupancyGrid(data, origin=(1e308, 0.0, 0.0))
    assert OccupancyGrid(data, resolution=np.float32(0.1), origin=np.zeros(3)).origin == (0, 0, 0)
    grid = OccupancyGrid(data)
    assert grid.shape == (2, 2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        grid.resolution = 1.0  # type: ignore[misc]
