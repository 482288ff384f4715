"""The merger contract: validation, graceful refusal, and never raising on valid grids."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import merging
from merging.grid import OccupancyGrid
from merging.resample import to_resolution
from merging.transforms import apply_transform
from tests.merging.builders import UNMERGEABLE_CASES, unmergeable_pair


@pytest.mark.parametrize(
    ("bad", "error", "message"),
    [
        (np.zeros((3, 3, 3), dtype=np.int8), ValueError, "2-D"),
        (np.array([[0.0, np.nan]]), ValueError, "NaN"),
        (np.array([[0, 101]], dtype=np.int16), ValueError, "-1..100"),
        (np.array([[-2, 0]], dtype=np.int16), ValueError, "-1..100"),
        (np.zeros((0, 5), dtype=np.int8), ValueError, "at least one cell"),
        (np.zeros((4, 4), dtype=bool), TypeError, "from_bool"),
        ([[0, 100]], TypeError, "numpy array"),
        # Its masked cells were read as their data.
        (np.ma.masked_equal(np.zeros((4, 4), np.int8), 0), TypeError, r"filled\(-1\)"),
        (np.array([[0.5, 0.0]]), ValueError, "fractional"),
    ],
)
def test_invalid_input_raises_a_named_error(bad, error, message) -> None:
    good = np.zeros((10, 10), dtype=np.int8)
    with pytest.raises(error, match=message):
        merging.estimate_transform(bad, good)
    with pytest.raises(error, match="map2"):
        merging.estimate_transform(good, bad)


@pytest.mark.parametrize(
    ("rng", "error"), [(-1, ValueError), (1.5, TypeError), ("x", TypeError), (True, TypeError)]
)
def test_a_bad_rng_is_named(rng: object, error: type) -> None:
    grid = np.zeros((5, 5), dtype=np.int8)
    with pytest.raises(error, match="rng must be None, a non-negative int"):
        merging.estimate_transform(grid, grid, rng=rng)  # type: ignore[arg-type]


def test_unknown_method_is_named() -> None:
    grid = np.zeros((5, 5), dtype=np.int8)
    with pytest.raises(ValueError, match="unknown merging method 'nope'"):
        merging.estimate_transform(grid, grid, method="nope")


@pytest.mark.parametrize(
    ("returned", "error", "message"),
    [
        (None, TypeError, "method 'misbehaving' must be a MergeResult, got NoneType"),
        ({"confidence": float("nan")}, ValueError, "method 'misbehaving' has the confidence nan"),
        ({"matrix": np.full((3, 3), np.nan)}, ValueError, "matrix of the result of .* finite"),
        ({"matrix": np.eye(2)}, ValueError, "3x3"),
        ({"accepted": "yes"}, TypeError, "accepted='yes'"),
        # A pair is read either way round: its hypotheses are inverted with its matrix.
        (
            {"hypotheses": (merging.result.Hypothesis(np.diag([1.0, 0.0, 1.0]), 1.0),)},
            ValueError,
            r"matrix of hypotheses\[0\] of .* singular",
        ),
        ({"hypotheses": (np.eye(3),)}, TypeError, r"hypotheses\[0\] .* must be a Hypothesis"),
        # Clipped only within rounding: more is the method's error, a bool no number.
        ({"confidence": 5.0}, ValueError, "has the confidence 5.0"),
        ({"confidence": True}, ValueError, "has the confidence True"),
    ],
)
def test_a_method_returning_what_the_contract_forbids_is_named(
    monkeypatch, returned, error, message
) -> None:
    # Once passed on as it was: a NaN confidence accepted, a 2 x 2 matrix failing in
    # the frame change with numpy's words.
    def misbehaving(cells1, cells2, *, rng):
        if returned is None:
            return None
        fields = {"matrix": np.eye(3), "confidence": 0.9, "accepted": True, **returned}
        return merging.MergeResult(method="misbehaving", **fields)

    monkeypatch.setitem(merging.api._METHODS, "misbehaving", misbehaving)
    monkeypatch.setitem(merging.api._PARAMS_TYPES, "misbehaving", None)
    grid = np.zeros((20, 20), dtype=np.int8)
    grid[5, :] = grid[:, 5] = 100
    with pytest.raises(error, match=message):
        merging.estimate_transform(grid, grid, method="misbehaving")


def test_a_method_overshooting_its_confidence_by_rounding_is_clipped(monkeypatch) -> None:
    def overshooting(cells1, cells2, *, rng):
        return merging.MergeResult(np.eye(3), 1.0 + 1e-12, True, "overshooting")

    monkeypatch.setitem(merging.api._METHODS, "overshooting", overshooting)
    monkeypatch.setitem(merging.api._PARAMS_TYPES, "overshooting", None)
    grid = np.zeros((20, 20), dtype=np.int8)
    grid[5, :] = grid[:, 5] = 100
    assert merging.estimate_transform(grid, grid, method="overshooting").confidence == 1.0


@pytest.mark.parametrize("name", [5, "", None])
def test_a_method_name_must_be_text(name) -> None:
    with pytest.raises(TypeError, match="non-empty str"):
        merging.api.register_method(name)  # type: ignore[arg-type]
    assert all(isinstance(known, str) for known in merging.available_methods())


def test_maps_of_different_resolutions_are_merged(building) -> None:
    # The same building at 0.05 m and, coarsened by max-pooling, at 0.1 m: the cell
    # matrix scales by 2 and the transform in metres is the frames' offset.
    fine = OccupancyGrid(building, resolution=0.05, origin=(1.0, 2.0, 0.0))
    coarse, to_coarse = to_resolution(OccupancyGrid(building, resolution=0.05), 0.1)
    second = OccupancyGrid(coarse.data, resolution=0.1, origin=(-3.0, 0.5, 0.0))
    result = merging.estimate_transform(fine, second)
    assert result.accepted
    assert result.matrix_metres is not None
    assert np.allclose(result.matrix_metres[:2, :2], np.eye(2), atol=0.01)
    assert np.allclose(result.matrix_metres[:2, 2], [4.0, 1.5], atol=0.05)
    assert np.sqrt(abs(np.linalg.det(result.matrix[:2, :2]))) == pytest.approx(2.0, rel=0.01)
    # The fused map keeps map 1's resolution and finds map 2's walls on map 1's.
    fused = merging.merge(fine, second, result.matrix)
    assert fused.grid is not None and fused.grid.resolution == 0.05
    assert not np.allclose(to_coarse, np.eye(3))
    assert _walls_on_walls(fused, 1, second.data) > 0.9


def _walls_on_walls(fused: merging.FusedMap, index: int, cells: np.ndarray) -> float:
    """Share of ``cells``' walls that ``fused.to_fused[index]`` lays on a fused wall."""
    matrix = fused.to_fused[index]
    assert matrix is not None
    rows, cols = np.nonzero(cells == 100)
    placed = np.rint(apply_transform(matrix, np.column_stack([cols, rows]).astype(float)))
    x, y = placed.astype(int).T
    inside = (x >= 0) & (y >= 0) & (x < fused.cells.shape[1]) & (y < fused.cells.shape[0])
    return float(np.mean(inside & (fused.cells[y.clip(0), x.clip(0)] == 100)))


def test_a_map_far_coarser_than_the_grid_is_one_cell_not_terabytes() -> None:
    # A whole factor once padded the grid to the factor's square before reducing it.
    cells = np.full((30, 40), -1, dtype=np.int8)
    cells[3, 4], cells[20, 30] = 0, 100
    grid = OccupancyGrid(cells, resolution=0.05)
    coarse, _ = to_resolution(grid, 0.05 * 10**9)
    np.testing.assert_array_equal(coarse.data, [[100]])
    with pytest.raises(ValueError, match="not a finite number"):
        to_resolution(OccupancyGrid(cells, resolution=1e-300), 1e300)
    result = merging.estimate_transform(grid, OccupancyGrid(cells, resolution=1e-9))
    assert not result.accepted and "too few occupied cells" in result.reason


def test_a_finer_map_2_is_placed_by_its_own_cells(building) -> None:
    # to_fused takes each input's own cells, not those of the coarsened copy fused.
    fine = OccupancyGrid(building, resolution=0.05)
    coarse, _ = to_resolution(fine, 0.1)
    result = merging.estimate_transform(coarse, fine)
    assert result.accepted
    fused = merging.merge(coarse, fine, result.matrix)
    np.testing.assert_allclose(fused.to_fused[1], fused.offset @ result.matrix)
    assert _walls_on_walls(fused, 1, building) > 0.9


def test_fusing_needs_a_matrix_that_scales_by_the_resolutions() -> None:
    a = OccupancyGrid(np.zeros((5, 5), dtype=np.int8), resolution=0.05)
    b = OccupancyGrid(np.zeros((5, 5), dtype=np.int8), resolution=0.1)
    with pytest.raises(ValueError, match=r"map2 has resolution 0\.1 m.*matrix must scale by 2"):
        merging.merge(a, b, np.eye(3))


@pytest.mark.parametrize("method", ["tomographic", "paper"])
@pytest.mark.parametrize("case", UNMERGEABLE_CASES)
def test_valid_but_unmergeable_input_is_not_accepted(method: str, case: str) -> None:
    pair = unmergeable_pair(case)
    result = merging.estimate_transform(*pair, method=method, rng=0)
    assert not result.accepted
    assert 0.0 <= result.confidence < 0.5
    assert result.matrix.shape == (3, 3) and np.all(np.isfinite(result.matrix))


def test_occupancy_grids_give_the_transform_in_metres() -> None:
    cells = np.full((120, 150), -1, dtype=np.int8)
    cells[10:110, 10:140] = 0
    cells[10, 10:140] = cells[109, 10:140] = cells[10:110, 10] = cells[10:110, 139] = 100
    cells[10:80, 60] = cells[50, 60:139] = cells[30:45, 100:104] = 100
    first = OccupancyGrid(cells, resolution=0.05, origin=(1.0, 2.0, 0.0))
    second = OccupancyGrid(cells, resolution=0.05, origin=(-3.0, 0.5, 0.0))
    result = merging.estimate_transform(first, second)
    assert result.accepted
    # Same cells, frames offset: a point of map 2's frame sits 4 m left, 1.5 m lower in map 1's.
    assert result.matrix_metres is not None
    assert np.allclose(result.matrix_metres[:2, 2], [4.0, 1.5], atol=0.03)


grids = arrays(
    np.int8,
    st.tuples(st.integers(1, 48), st.integers(1, 48)),
    elements=st.sampled_from([-1, 0, 0, 0, 50, 100, 100]),
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(first=grids, second=grids)
def test_never_raises_on_valid_grids(first: np.ndarray, second: np.ndarray) -> None:
    result = merging.estimate_transform(first, second)
    assert 0.0 <= result.confidence <= 1.0
    assert isinstance(result.accepted, bool)
    assert np.all(np.isfinite(result.matrix))
