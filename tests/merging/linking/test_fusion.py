"""Fusion with known transforms: canvas growth, the conflict rule, and merge_all's spanning tree."""

from __future__ import annotations

import numpy as np
import pytest

from merging import OccupancyGrid, fuse, merge
from merging.linking.fusion import MAX_FUSED_CELLS, combine
from merging.transforms import apply_transform, rigid_matrix
from merging.warp import warp_cells

EXACT = 1e-9
"""Cells or metres: transforms built from whole cells and right angles compose exactly
up to floating-point rounding."""


def random_room_map(shape: tuple[int, int], *, seed: int) -> np.ndarray:
    """A grid of free space with a border wall and random wall segments, all known."""
    rng = np.random.default_rng(seed)
    cells = np.zeros(shape, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = 100
    for _ in range(6):
        r, c = rng.integers(2, shape[0] - 2), rng.integers(2, shape[1] - 2)
        if rng.random() < 0.5:
            cells[r, c : c + rng.integers(3, 10)] = 100
        else:
            cells[r : r + rng.integers(3, 10), c] = 100
    return cells


def translation(dx: float, dy: float) -> np.ndarray:
    return rigid_matrix(dx, dy, 0.0)


def test_identity_merge_returns_the_map_itself() -> None:
    cells = random_room_map((20, 30), seed=1)
    fused = merge(cells, cells.copy(), np.eye(3))
    np.testing.assert_array_equal(fused.cells, cells)
    np.testing.assert_allclose(fused.offset, np.eye(3), atol=EXACT)
    assert fused.grid is None


@pytest.mark.parametrize(("dx", "dy"), [(7, 0), (-7, 0), (0, 5), (0, -5), (-4, 9), (6, -3)])
def test_canvas_grows_in_every_direction(dx: int, dy: int) -> None:
    map1 = random_room_map((12, 15), seed=2)
    map2 = random_room_map((10, 8), seed=3)
    matrix = translation(dx, dy)
    fused = merge(map1, map2, matrix)
    rows = max(12, dy + 10) - min(0, dy)
    cols = max(15, dx + 8) - min(0, dx)
    assert fused.cells.shape == (rows, cols)
    # map 1 moves by the offset only when map 2 sticks out on the low side
    np.testing.assert_allclose(fused.offset, translation(-min(0, dx), -min(0, dy)), atol=EXACT)
    np.testing.assert_allclose(fused.to_fused[1], fused.offset @ matrix, atol=EXACT)
    x1, y1 = (int(v) for v in fused.offset[:2, 2])
    x2, y2 = (int(v) for v in fused.to_fused[1][:2, 2])  # type: ignore[index]
    expected = np.full((rows, cols), -1, dtype=np.int8)
    expected[y1 : y1 + 12, x1 : x1 + 15] = map1
    window = expected[y2 : y2 + 10, x2 : x2 + 8]
    window[...] = np.maximum(window, map2)
    np.testing.assert_array_equal(fused.cells, expected)


def test_quarter_turn_is_exact_and_lands_left_of_map1() -> None:
    map1 = np.zeros((5, 5), dtype=np.int8)
    map2 = np.full((3, 4), 0, dtype=np.int8)
    map2[0, 3] = 100  # cell (x, y) = (3, 0)
    matrix = rigid_matrix(0.0, 0.0, np.pi / 2)  # (x, y) -> (-y, x)
    fused = merge(map1, map2, matrix)
    # map 2 covers x in [-2, 0], y in [0, 3]: the canvas gains two columns on the left
    assert fused.cells.shape == (5, 7)
    np.testing.assert_allclose(fused.offset, translation(2, 0), atol=EXACT)
    # the occupied cell (3, 0) goes to (0, 3) in map 1, (2, 3) in the fused grid
    assert fused.cells[3, 2] == 100
    assert np.count_nonzero(fused.cells == 100) == 1
    np.testing.assert_allclose(
        apply_transform(fused.to_fused[1], [[3, 0]]), [[2.0, 3.0]], atol=EXACT
    )
    # map 2 reaches y = 3 only, so the two cells left of map 1's top row stay unknown
    unknown = np.argwhere(fused.cells == -1)
    np.testing.assert_array_equal(unknown, [[4, 0], [4, 1]])


@pytest.mark.parametrize(
    ("first", "second", "expected"),
    [
        (-1, -1, -1),  # nothing known
        (-1, 0, 0),  # known beats unknown
        (100, -1, 100),
        (0, 100, 100),  # occupied beats free, in either order
        (100, 0, 100),
        (30, 0, 30),  # the more occupied known value wins
        (0, 0, 0),
    ],
)
def test_conflict_rule(first: int, second: int, expected: int) -> None:
    map1 = np.full((3, 3), first, dtype=np.int8)
    map2 = np.full((3, 3), second, dtype=np.int8)
    fused = merge(map1, map2, np.eye(3))
    assert np.all(fused.cells == expected)
    assert combine(np.int8(second), np.int8(first)) == expected


def test_merge_is_symmetric_up_to_the_frame() -> None:
    """Swapping the maps and inverting the transform gives the same fused cells."""
    map1 = random_room_map((25, 30), seed=4)
    map2 = random_room_map((20, 18), seed=5)
    matrix = rigid_matrix(-6.0, 11.0, np.pi)
    forward = merge(map1, map2, matrix)
    backward = merge(map2, map1, np.linalg.inv(matrix))
    # backward's frame is map 2's; carry it into forward's frame: a half turn, exact on the grid
    into_forward = forward.to_fused[1] @ np.linalg.inv(backward.offset)
    carried = warp_cells(backward.cells, into_forward, forward.cells.shape)
    np.testing.assert_array_equal(carried, forward.cells)


def test_grid_keeps_map1_resolution_and_places_in_metres() -> None:
    yaw = 0.4
    map1 = OccupancyGrid(random_room_map((10, 12), seed=6), resolution=0.1, origin=(1.0, -2.0, yaw))
    map2 = OccupancyGrid(random_room_map((8, 8), seed=7), resolution=0.1, origin=(5.0, 5.0, 0.0))
    fused = merge(map1, map2, translation(-5, -3))
    assert fused.grid is not None
    assert fused.grid.resolution == 0.1
    assert fused.grid.origin[2] == yaw
    cells1 = np.array([[0, 0], [11, 9], [3, 7]], dtype=float)
    in_fused = apply_transform(fused.offset, cells1)
    np.testing.assert_allclose(
        fused.grid.cell_to_world(in_fused), map1.cell_to_world(cells1), atol=EXACT
    )
    np.testing.assert_array_equal(fused.grid.data, fused.cells)


def test_mixed_resolutions_are_refused() -> None:
    map1 = OccupancyGrid(np.zeros((4, 4), np.int8), resolution=0.05)
    map2 = OccupancyGrid(np.zeros((4, 4), np.int8), resolution=0.1)
    with pytest.raises(ValueError, match="resolution"):
        merge(map1, map2, np.eye(3))


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        (np.eye(2), "3x3"),
        (np.full((3, 3), np.nan), "3x3"),
        (np.array([[1, 0, 0], [0, 1, 0], [0.1, 0, 1]]), "affine"),
        (np.array([[1, 2, 0], [2, 4, 0], [0, 0, 1.0]]), "singular"),
        (translation(1e5, 1e5), "limit"),
        # Past 2**63 cells the box's integers wrapped, slipping past the size check.
        (translation(1e19, 0.0), "matrix lays map2 1e\\+19 cells from the frame's zero"),
    ],
)
def test_bad_matrices_are_refused(matrix: np.ndarray, message: str) -> None:
    cells = np.zeros((10, 10), dtype=np.int8)
    with pytest.raises(ValueError, match=message):
        merge(cells, cells, matrix)
    assert MAX_FUSED_CELLS < (1e5) ** 2


def test_merge_without_a_matrix_is_refused_not_map_1_alone() -> None:
    cells = np.zeros((10, 10), dtype=np.int8)
    with pytest.raises(TypeError, match="matrix is None"):
        merge(cells, cells, None)  # type: ignore[arg-type]


def test_fuse_needs_one_matrix_per_map() -> None:
    cells = np.zeros((3, 3), dtype=np.int8)
    with pytest.raises(ValueError, match="one per map"):
        fuse([cells, cells], [np.eye(3)])
    with pytest.raises(ValueError, match="every matrix is None"):
        fuse([cells], [None])


def test_unknown_borders_are_left_out_of_the_canvas() -> None:
    # Maps drawn on large canvases of unknown cells fuse into the box of what was seen.
    room1, room2 = random_room_map((12, 15), seed=11), random_room_map((10, 8), seed=12)
    map1 = np.full((300, 400), -1, dtype=np.int8)
    map1[100:112, 200:215] = room1
    map2 = np.full((500, 60), -1, dtype=np.int8)
    map2[250:260, 40:48] = room2
    matrix = translation(170, -150)  # map 2's room lands at (210, 100) of map 1
    fused = merge(map1, map2, matrix)
    expected = merge(room1, room2, translation(10, 0))
    np.testing.assert_array_equal(fused.cells, expected.cells)
    np.testing.assert_allclose(fused.offset, translation(-200, -100), atol=EXACT)
    np.testing.assert_allclose(fused.to_fused[1], fused.offset @ matrix, atol=EXACT)


def test_maps_with_nothing_observed_keep_their_canvas() -> None:
    blank = np.full((4, 6), -1, dtype=np.int8)
    fused = merge(blank, blank.copy(), translation(2, 0))
    assert fused.cells.shape == (4, 8)


def test_a_map_with_nothing_observed_does_not_widen_the_canvas() -> None:
    seen = np.full((20, 20), -1, dtype=np.int8)
    seen[5:8, 4:6] = 0
    blank = np.full((200, 300), -1, dtype=np.int8)
    fused = fuse([seen, blank], [np.eye(3), translation(-50, -60)])
    assert fused.cells.shape == (3, 2)
    np.testing.assert_allclose(fused.to_fused[1], fused.offset @ translation(-50, -60))


def test_names_are_checked() -> None:
    cells = np.zeros((3, 3), dtype=np.int8)
    with pytest.raises(ValueError, match="names must hold"):
        fuse([cells], [np.eye(3)], names=["map1"])  # type: ignore[list-item]
