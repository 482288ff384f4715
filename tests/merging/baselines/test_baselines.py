"""The baselines: known transforms recovered, the merger contract kept, the pieces' mathematics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from skimage.feature import corner_harris, corner_peaks

import merging
from merging.baselines.common import render, verdict
from merging.baselines.patches import orientations, oriented_patches
from merging.baselines.registration import _turn, rotation_modulo_half_turn
from merging.baselines.spectral import (
    ANGLE_STEP_DEG,
    circular_correlation,
    rotation_peaks,
    spectrum_shift,
)
from merging.evaluation.metrics import transform_error
from merging.evidence.refine import SmoothedMap, constraint_strength
from merging.evidence.verify import confidence, prepare_map, verify
from merging.transforms import apply_transform, rigid_matrix
from tests.merging.builders import UNMERGEABLE_CASES, synthetic_building, turned, unmergeable_pair
from tests.support import run_python

BASELINES = ("spectral", "sift", "harris", "shi_tomasi", "orb", "registration")
RIGHT_CELLS = 2.0
"""A transform is right when it puts map 2's walls within 2 cells RMS of the truth."""
RIGHT_DEGREES = 0.5
"""... and its rotation within half a degree (a 450-cell map's far end moves 2 cells)."""
ORIENTATION_DEG = 15.0
"""A corner's orientation follows the map's turn within one and a half 10° histogram
bins: rasterising a turned one-cell wall bends its gradients by up to about 12°."""


@pytest.fixture(scope="module")
def robot_map(maps_folder) -> np.ndarray:
    """One ap_hill robot's real map (300 x 450 cells): small, so every baseline runs fast."""
    return merging.load_map(maps_folder / "ap_hill_robot3.yaml").data


@pytest.mark.slow
@pytest.mark.parametrize("method", BASELINES)
@pytest.mark.parametrize("degrees", [-150.0, 65.0])
def test_recovers_a_known_transform_on_a_real_map(robot_map, method: str, degrees: float) -> None:
    map2, truth = turned(robot_map, degrees, (5.0, 12.0))
    result = merging.estimate_transform(robot_map, map2, method=method, rng=1)
    rms, rotation_error = transform_error(result.matrix, truth, map2)
    assert rms < RIGHT_CELLS and rotation_error < RIGHT_DEGREES
    # Sign pinned: map 2 shows map 1 turned by +degrees, so T turns by -degrees.
    assert np.rad2deg(result.rotation) == pytest.approx(
        np.rad2deg(np.angle(np.exp(-1j * np.deg2rad(degrees)))), abs=RIGHT_DEGREES
    )
    assert result.accepted
    assert result.method == method and "total" in result.timings


@pytest.mark.slow
@pytest.mark.parametrize("method", BASELINES)
def test_confidence_is_the_shared_verification(robot_map, method: str) -> None:
    # "accepted" must mean the same for every method: recompute the shared check.
    map2, _ = turned(robot_map, 30.0, (0.0, 0.0))
    result = merging.estimate_transform(robot_map, map2, method=method, rng=2)
    first, second = prepare_map(robot_map), prepare_map(map2)
    strength = constraint_strength(SmoothedMap(first.walls, first.shape), second, result.matrix)
    expected = confidence(verify(first, second, result.matrix), None, strength=strength)
    assert result.confidence == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize("method", BASELINES)
@pytest.mark.parametrize(
    ("bad", "error", "message"),
    [
        (np.zeros((3, 3, 3), dtype=np.int8), ValueError, "2-D"),
        (np.array([[0.0, np.nan]]), ValueError, "NaN"),
        (np.array([[0, 101]], dtype=np.int16), ValueError, "-1..100"),
        ([[0, 100]], TypeError, "numpy array"),
    ],
)
def test_invalid_input_raises_a_named_error(method: str, bad, error, message) -> None:
    good = np.zeros((10, 10), dtype=np.int8)
    with pytest.raises(error, match=message):
        merging.estimate_transform(bad, good, method=method)
    with pytest.raises(error, match="map2"):
        merging.estimate_transform(good, bad, method=method)


@pytest.mark.parametrize(
    ("method", "options", "error", "message"),
    [
        ("spectral", {"colour": 1}, TypeError, "colour"),
        ("spectral", {"hypotheses": 0}, ValueError, "hypotheses"),
        ("sift", {"threshold": -1.0}, ValueError, "threshold"),
        ("orb", {"iterations": 2.5}, ValueError, "iterations"),
        ("harris", {"detector": "sift"}, TypeError, "detector"),
        ("registration", {"upsample": 3}, TypeError, "upsample"),
    ],
)
def test_bad_options_are_named(method: str, options, error, message) -> None:
    grid = np.zeros((40, 40), dtype=np.int8)
    grid[5:35, 10] = grid[20, 5:35] = 100
    with pytest.raises(error, match=message):
        merging.estimate_transform(grid, grid, method=method, **options)


@pytest.mark.parametrize("method", BASELINES)
@pytest.mark.parametrize("case", UNMERGEABLE_CASES)
def test_valid_but_unmergeable_input_is_not_accepted(method: str, case: str) -> None:
    pair = unmergeable_pair(case)
    result = merging.estimate_transform(*pair, method=method, rng=0)
    assert not result.accepted
    assert 0.0 <= result.confidence < 0.5
    assert result.reason
    assert result.matrix.shape == (3, 3) and np.all(np.isfinite(result.matrix))


grids = arrays(
    np.int8,
    st.tuples(st.integers(1, 40), st.integers(1, 40)),
    elements=st.sampled_from([-1, 0, 0, 0, 50, 100, 100]),
)


@pytest.mark.parametrize("method", BASELINES)
@example(first=np.full((1, 10), 100, np.int8), second=np.full((27, 27), 100, np.int8))
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(first=grids, second=grids)
def test_never_raises_on_valid_grids(method: str, first: np.ndarray, second: np.ndarray) -> None:
    result = merging.estimate_transform(first, second, method=method, rng=0)
    assert 0.0 <= result.confidence <= 1.0
    assert np.all(np.isfinite(result.matrix))


@pytest.mark.slow
@pytest.mark.parametrize("method", ["sift", "orb", "harris", "shi_tomasi"])
def test_feature_matchers_are_seeded(building: np.ndarray, method: str) -> None:
    map2, _ = turned(building, 40.0, (3.0, 0.0))
    a = merging.estimate_transform(building, map2, method=method, rng=9)
    b = merging.estimate_transform(building, map2, method=method, rng=9)
    assert np.array_equal(a.matrix, b.matrix)


def test_verdict_refuses_a_wrong_transform(building: np.ndarray) -> None:
    timings: dict[str, float] = {}
    right = verdict(building, building, np.eye(3), method="x", timings=timings)
    wrong = verdict(building, building, rigid_matrix(60.0, 0.0, 0.0), method="x", timings=timings)
    assert right.accepted and not wrong.accepted
    assert wrong.reason.startswith("the walls do not line up")


def test_render_codes_walls_dark_free_light_unknown_grey() -> None:
    cells = np.array([[-1, 0, 100, 50, 19, 65]], dtype=np.int8)
    assert np.array_equal(render(cells, blur=0.0), [[0.5, 1.0, 0.0, 0.5, 1.0, 0.0]])


# --- the spectral merger's pieces -----------------------------------------------------------


def test_circular_correlation_peaks_at_the_turn() -> None:
    # HS_2(θ + φ) = HS_1(θ): the peak is at φ, the sign the method relies on.
    spectrum = np.random.default_rng(1).random(720)
    shifted = np.roll(spectrum, 40)
    correlation = circular_correlation(spectrum, shifted)
    assert int(np.argmax(correlation)) == 40
    assert correlation.max() == pytest.approx(1.0) and correlation.min() == pytest.approx(0.0)


def test_rotation_peaks_are_refined_between_samples() -> None:
    angles = np.arange(720) * ANGLE_STEP_DEG
    correlation = np.exp(-0.5 * ((angles - 33.1) / 2.0) ** 2)
    (peak,) = rotation_peaks(correlation, count=1)
    assert peak == pytest.approx(33.1, abs=0.02)


def test_spectrum_shift_lays_the_second_set_on_the_first() -> None:
    points = np.random.default_rng(2).uniform(0, 200, size=(300, 2))
    normal = np.array([np.cos(0.3), np.sin(0.3)])
    assert spectrum_shift(points + 25.0 * normal, points, normal) == pytest.approx(25.0)


# --- the registration's rotation --------------------------------------------------------------


@pytest.mark.parametrize("degrees", [-120.0, -35.0, 17.0])
def test_log_polar_rotation_is_found_modulo_a_half_turn(robot_map: np.ndarray, degrees) -> None:
    # (A rectilinear building can make φ ± 90° the stronger peak, at 75° for this
    # map: the magnitude spectrum cannot tell its quarter turns apart.)
    map2, _ = turned(robot_map, degrees, (0.0, 0.0))
    found = np.rad2deg(rotation_modulo_half_turn(render(robot_map), render(map2)))
    difference = (found - degrees + 90.0) % 180.0 - 90.0
    assert abs(difference) < 0.5


@pytest.mark.parametrize("shape", [(5, 8), (6, 9), (7, 7), (1, 12)])
def test_a_quarter_turn_lays_every_cell_on_a_cell_where_its_matrix_says(shape) -> None:
    cells = np.arange(np.prod(shape)).reshape(shape).astype(np.int8) % 100
    cols, rows = np.meshgrid(np.arange(shape[1]), np.arange(shape[0]))
    points = np.column_stack([cols.ravel(), rows.ravel()]).astype(float)
    for quarter in range(4):
        canvas, to_canvas = _turn(cells, quarter * np.pi / 2)
        landed = apply_transform(to_canvas, points)
        np.testing.assert_allclose(landed, np.rint(landed), atol=1e-9)
        spots = np.rint(landed).astype(int)
        np.testing.assert_array_equal(canvas[spots[:, 1], spots[:, 0]], cells.ravel())


@pytest.mark.parametrize("shape", [(100, 140), (101, 140), (120, 160)])
def test_registration_places_a_shifted_copy_to_the_cell(shape) -> None:
    # Grids whose sides differ in parity from the turned canvas's once came back
    # half a cell off in each axis, accepted: the nearest-neighbour warp had moved
    # the cells a whole cell or none, the matrix kept the half.
    building = synthetic_building(3, shape)
    shifted = np.full_like(building, -1)
    shifted[3:, 7:] = building[:-3, :-7]
    for map2, truth in ((building.copy(), np.eye(3)), (shifted, rigid_matrix(-7.0, -3.0, 0.0))):
        result = merging.estimate_transform(building, map2, method="registration")
        assert result.accepted
        np.testing.assert_allclose(result.matrix, truth, atol=1e-9)


# --- the corner descriptors -------------------------------------------------------------------


@pytest.mark.slow
def test_patches_turn_with_the_map(building: np.ndarray) -> None:
    degrees = 50.0
    map2, truth = turned(building, degrees, (0.0, 0.0))
    image1, image2 = render(building), render(map2)
    # The strongest Harris corners of map 1 that lie well inside it, and where they are in map 2.
    peaks = corner_peaks(corner_harris(image1, sigma=1.5), min_distance=10, num_peaks=40)
    inside = np.all((peaks > 30) & (peaks < np.array(building.shape) - 30), axis=1)
    corners1 = peaks[inside][:8, ::-1].astype(float)
    corners2 = apply_transform(np.linalg.inv(truth), corners1)
    index1, angles1 = orientations(image1, corners1)
    index2, angles2 = orientations(image2, corners2)
    patches1 = oriented_patches(image1, corners1[index1], angles1)
    patches2 = oriented_patches(image2, corners2[index2], angles2)
    assert np.allclose(np.linalg.norm(patches1, axis=1), 1.0)
    for corner in range(len(corners1)):
        mine1, mine2 = index1 == corner, index2 == corner
        assert mine1.any() and mine2.any()
        # Some orientation of the corner in map 2 is its orientation in map 1 turned by the
        # map's turn, and the patches there are alike.
        turn = np.angle(np.exp(1j * (angles2[mine2][None, :] - angles1[mine1][:, None])))
        similarity = patches1[mine1] @ patches2[mine2].T
        assert np.any((np.abs(np.rad2deg(turn) - degrees) < ORIENTATION_DEG) & (similarity > 0.8))


ROS_PIPELINES = ("ros_akaze", "ros_orb")


@pytest.fixture(scope="module")
def opencv():
    """OpenCV, or a skip naming the install command."""
    return pytest.importorskip(
        "cv2", reason='the ROS pipeline baselines need OpenCV: pip install "tomosim[opencv]"'
    )


@pytest.mark.parametrize("method", ROS_PIPELINES)
def test_ros_pipeline_recovers_a_known_transform(opencv, robot_map, method: str) -> None:
    map2, truth = turned(robot_map, 65.0, (5.0, 12.0))
    result = merging.estimate_transform(robot_map, map2, method=method, rng=1)
    rms, rotation_error = transform_error(result.matrix, truth, map2)
    assert rms < RIGHT_CELLS and rotation_error < 2 * RIGHT_DEGREES
    assert result.accepted
    # Its own acceptance rule: the pair confidence c of OpenCV's matcher, c / (1 + c).
    assert result.confidence >= 0.5


@pytest.mark.parametrize("method", ROS_PIPELINES)
@pytest.mark.parametrize("case", UNMERGEABLE_CASES)
def test_ros_pipeline_refuses_unmergeable_pairs(opencv, method: str, case: str) -> None:
    result = merging.estimate_transform(*unmergeable_pair(case), method=method, rng=0)
    assert not result.accepted and result.reason
    assert np.all(np.isfinite(result.matrix))


def test_ros_pipeline_without_opencv_names_the_install(monkeypatch) -> None:
    import builtins

    real_import = builtins.__import__

    def no_cv2(name, *args, **kwargs):
        if name == "cv2":
            raise ImportError("No module named 'cv2'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_cv2)
    grid = synthetic_building(4)
    with pytest.raises(ImportError, match=r"tomosim\[opencv\]"):
        merging.estimate_transform(grid, grid, method="ros_akaze")


@pytest.mark.slow
@pytest.mark.parametrize("method", ROS_PIPELINES)
@pytest.mark.parametrize("shape", [(1, 300), (300, 1)])
def test_ros_pipeline_refuses_a_grid_one_cell_wide(opencv, method: str, shape) -> None:
    # OpenCV's AKAZE corrupts the heap on such an image (the process aborts), so the
    # call runs in a child process: a regression fails this test, not the whole run.
    script = (
        "import numpy as np, merging\n"
        f"thin = np.full({shape}, 100, np.int8); thin.reshape(-1)[::3] = 0\n"
        "wide = np.zeros((60, 60), np.int8); wide[::7, :] = 100\n"
        "for pair in ((wide, thin), (thin, wide)):\n"
        f"    result = merging.estimate_transform(*pair, method={method!r}, rng=0)\n"
        "    assert not result.accepted, result\n"
        "    print(result.reason)\n"
    )
    assert "at least 2 cells a side" in run_python(script)


def test_importing_merging_leaves_the_feature_and_signal_libraries_unloaded() -> None:
    # Every program that imports merging (the command, the search worker) would pay
    # for them: `import merging` took 1.1 s with them and takes 0.7 s without. The
    # baselines needing them import them when they run.
    script = (
        "import sys, merging; "
        "print(sorted(m for m in ('skimage.feature', 'scipy.signal') if m in sys.modules))"
    )
    assert run_python(script).strip() == "[]"
    assert "sift" in merging.available_methods()
