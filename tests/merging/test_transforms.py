"""Map transformation matrices (eq. 1): direction, composition, poses, and cells -> metres."""

from __future__ import annotations

import numpy as np
import pytest

from merging.grid import OccupancyGrid
from merging.transforms import (
    apply_transform,
    cells_to_metres,
    checked_transform,
    halfway,
    matrix_to_pose,
    rigid_matrix,
    rotation_about,
    wrap_angle,
)

EXACT = 1e-9
"""Cells or radians: closed-form rotations agree to floating-point rounding."""


def test_rigid_matrix_rotates_counter_clockwise_then_translates() -> None:
    matrix = rigid_matrix(10.0, -2.0, np.pi / 2)
    # eq. (1): x1 = cos(t) x2 - sin(t) y2 + dx, y1 = sin(t) x2 + cos(t) y2 + dy
    np.testing.assert_allclose(apply_transform(matrix, [[1.0, 0.0]]), [[10.0, -1.0]], atol=EXACT)
    np.testing.assert_allclose(apply_transform(matrix, [[0.0, 1.0]]), [[9.0, -2.0]], atol=EXACT)
    np.testing.assert_allclose(matrix[2], [0.0, 0.0, 1.0])


@pytest.mark.parametrize("theta", [0.0, 0.3, -1.2, np.pi / 2, 3.0, np.pi])
def test_matrix_to_pose_inverts_rigid_matrix(theta: float) -> None:
    dx, dy, back = matrix_to_pose(rigid_matrix(4.5, -7.25, theta))
    assert (dx, dy) == (4.5, -7.25)
    assert back == pytest.approx(theta, abs=EXACT)


def test_matrix_to_pose_wraps_angles_past_pi() -> None:
    assert matrix_to_pose(rigid_matrix(0, 0, 1.5 * np.pi))[2] == pytest.approx(-np.pi / 2)


def test_composition_order_is_right_to_left() -> None:
    """T_13 = T_12 @ T_23 takes map 3's cells to map 1's."""
    t12 = rigid_matrix(5.0, 1.0, 0.4)
    t23 = rigid_matrix(-3.0, 2.0, -1.1)
    point3 = np.array([[2.0, 7.0]])
    via_2 = apply_transform(t12, apply_transform(t23, point3))
    np.testing.assert_allclose(apply_transform(t12 @ t23, point3), via_2, atol=EXACT)
    assert matrix_to_pose(t12 @ t23)[2] == pytest.approx(0.4 - 1.1)


def test_rotation_about_fixes_its_centre() -> None:
    matrix = rotation_about(np.pi / 2, (3.0, 4.0))
    np.testing.assert_allclose(apply_transform(matrix, [[3.0, 4.0]]), [[3.0, 4.0]], atol=EXACT)
    np.testing.assert_allclose(apply_transform(matrix, [[4.0, 4.0]]), [[3.0, 5.0]], atol=EXACT)


def test_apply_transform_takes_one_point_or_many() -> None:
    matrix = rigid_matrix(1.0, 2.0, 0.0)
    assert apply_transform(matrix, [0.0, 0.0]).shape == (1, 2)
    assert apply_transform(matrix, np.zeros((5, 2))).shape == (5, 2)


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [(0.0, 0.0), (np.pi, np.pi), (-np.pi, np.pi), (3 * np.pi, np.pi), (1.5 * np.pi, -0.5 * np.pi)],
)
def test_wrap_angle_lands_in_minus_pi_to_pi(angle: float, wrapped: float) -> None:
    assert float(wrap_angle(angle)) == pytest.approx(wrapped, abs=EXACT)


def test_cells_to_metres_is_identity_for_two_views_of_one_frame() -> None:
    """Two grids of the same map frame whose origins differ by (1.0, 0.5) m at 0.05 m."""
    grid1 = OccupancyGrid(np.zeros((10, 10), np.int8), resolution=0.05, origin=(0.0, 0.0, 0.0))
    grid2 = OccupancyGrid(np.zeros((10, 10), np.int8), resolution=0.05, origin=(1.0, 0.5, 0.0))
    cell_matrix = rigid_matrix(20.0, 10.0, 0.0)  # grid 2's cell (0, 0) is grid 1's (20, 10)
    np.testing.assert_allclose(cells_to_metres(cell_matrix, grid1, grid2), np.eye(3), atol=EXACT)


def test_cells_to_metres_carries_a_point_like_its_cell_matrix() -> None:
    grid1 = OccupancyGrid(np.zeros((5, 5), np.int8), resolution=0.1, origin=(2.0, -1.0, 0.3))
    grid2 = OccupancyGrid(np.zeros((5, 5), np.int8), resolution=0.1, origin=(-4.0, 0.5, -0.8))
    cell_matrix = rigid_matrix(3.0, 1.5, 0.9)
    metres = cells_to_metres(cell_matrix, grid1, grid2)
    cells2 = np.array([[0.0, 0.0], [4.0, 1.0], [2.5, 3.0]])
    expected = grid1.cell_to_world(apply_transform(cell_matrix, cells2))
    np.testing.assert_allclose(
        apply_transform(metres, grid2.cell_to_world(cells2)), expected, atol=EXACT
    )
    # same resolution: the metric transform is rigid, rotated by 0.3 + 0.9 - (-0.8)
    assert matrix_to_pose(metres)[2] == pytest.approx(float(wrap_angle(0.3 + 0.9 + 0.8)))


def test_halfway_turns_by_the_mean_angle_and_lays_the_centroid_halfway() -> None:
    points = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 20.0]])
    a = rigid_matrix(4.0, -2.0, np.radians(179.0))
    b = rigid_matrix(6.0, 2.0, np.radians(-179.0))
    between = halfway(a, b, points)
    assert abs(matrix_to_pose(between)[2]) == pytest.approx(np.pi)
    centre = points.mean(axis=0)[None, :]
    expected = (apply_transform(a, centre) + apply_transform(b, centre)) / 2
    assert apply_transform(between, centre) == pytest.approx(expected)
    np.testing.assert_allclose(halfway(a, a, points), a, atol=1e-12)


def test_the_helpers_name_what_they_cannot_take() -> None:
    # Once an IndexError and an AttributeError from inside.
    with pytest.raises(ValueError, match=r"3x3 transform, got shape \(2, 2\)"):
        matrix_to_pose(np.eye(2))
    with pytest.raises(TypeError, match="grid2 must be an OccupancyGrid"):
        cells_to_metres(np.eye(3), OccupancyGrid(np.zeros((2, 2), np.int8)), np.zeros((2, 2)))  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("matrix", "invertible", "message"),
    [
        (np.eye(2), True, r"3x3 transform, got shape \(2, 2\)"),
        ("abc", True, "3x3 array of numbers"),
        (np.full((3, 3), np.inf), True, "must be finite"),
        (
            [[1, 0, 0], [0, 1, 0], [1, 1, 1]],
            True,
            r"\[0, 0, 1\], got last row \[1\.0, 1\.0, 1\.0\]",
        ),
        (np.diag([1.0, 0.0, 1.0]), True, "singular"),
    ],
)
def test_checked_transform_says_which_condition_fails(matrix, invertible, message) -> None:
    with pytest.raises(ValueError, match=message):
        checked_transform(matrix, invertible=invertible)


def test_checked_transform_takes_a_folding_matrix_only_when_asked() -> None:
    folding = np.diag([1.0, 0.0, 1.0])
    np.testing.assert_array_equal(checked_transform(folding, invertible=False), folding)
    np.testing.assert_array_equal(checked_transform(np.eye(3).tolist()), np.eye(3))
