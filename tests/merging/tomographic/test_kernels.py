"""The default merger's kernels on their own: angular spectra, refinement, verification."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage

import merging
from merging.evidence.blur import blur_walls
from merging.evidence.refine import (
    BOXED_FIELDS_KEPT,
    Field,
    SmoothedMap,
    _field_sample,
    curvature_matrix,
    refine_transform,
)
from merging.evidence.refine_kernels import normal_equations
from merging.evidence.verify import (
    CLEAR_BIT,
    KNOWN_BIT,
    NEAR_BIT,
    Verification,
    _landing,
    confidence,
    confidence_factors,
    dilate,
    prepare_map,
    verify,
)
from merging.grid import free_mask, occupied_mask
from merging.params import (
    ConfidenceParams,
    GaussNewtonParams,
    RefineStage,
    RobustParams,
    TomographicParams,
    TranslationParams,
    VerifyParams,
)
from merging.tomographic.angular import (
    _bilinear,
    _upper_half_magnitude,
    angular_spectrum,
    rotation_correlation,
    rotation_peaks,
)
from merging.tomographic.correlate import clear_blocks
from merging.tomographic.search import refine_from
from merging.transforms import apply_transform, cells_to_metres, rigid_matrix
from tests.merging.builders import synthetic_building, turned

SPECTRUM_SIZE = 512
"""FFT size for the angular spectra of the 260 x 360 test building."""


def walls_image(cells: np.ndarray) -> np.ndarray:
    return (cells >= 65).astype(np.float32)


def test_translation_leaves_the_angular_spectrum_unchanged(building: np.ndarray) -> None:
    # A whole-cell shift inside the FFT frame changes only the phase of the spectrum.
    moved = np.full((300, 400), -1, dtype=np.int8)
    moved[23 : 23 + building.shape[0], 31 : 31 + building.shape[1]] = building
    first = angular_spectrum(walls_image(building), size=SPECTRUM_SIZE)
    second = angular_spectrum(walls_image(moved), size=SPECTRUM_SIZE)
    assert np.allclose(first.values, second.values, atol=1e-4)


@pytest.mark.parametrize("shape", [(157, 150), (64, 200), (256, 13)])
def test_upper_half_magnitude_is_that_of_the_full_transform(shape) -> None:
    image = (np.random.default_rng(4).random(shape) < 0.1).astype(np.float32)
    padded = np.zeros((256, 256), dtype=np.float32)
    padded[: shape[0], : shape[1]] = image
    full = np.abs(np.fft.fftshift(np.fft.fft2(padded)))
    half = _upper_half_magnitude(image, 256)
    assert half.shape == (129, 256)
    assert np.allclose(half[:128], full[128:], rtol=1e-4, atol=1e-3)  # Nyquist row aside
    # The first rows alone, as the angular spectrum asks for them, are the same to the bit.
    assert np.array_equal(_upper_half_magnitude(image, 256, rows=97), half[:97])


@pytest.mark.parametrize("degrees", [17.0, 63.0, 121.0])
def test_rotation_correlation_peaks_at_the_turn_of_map_2(building, degrees: float) -> None:
    # Map 2 shows map 1 turned counter-clockwise by +degrees: the correlation peaks at
    # +degrees (modulo 180), not at -degrees.
    map2, _ = turned(building, degrees, (0.0, 0.0))
    first = angular_spectrum(walls_image(building), size=SPECTRUM_SIZE)
    second = angular_spectrum(walls_image(map2), size=SPECTRUM_SIZE)
    (angle, _), *_ = rotation_peaks(rotation_correlation(first, second), count=1)
    error = (angle - degrees + 90.0) % 180.0 - 90.0
    assert abs(error) < 1.0


@pytest.mark.parametrize("offset", [(1.5, 0.0), (0.0, -1.5), (1.06, 1.06)])
def test_gauss_newton_from_one_and_a_half_cells_off_converges(offset) -> None:
    grid = synthetic_building(5)
    first, second = prepare_map(grid), prepare_map(grid)
    smoothed = SmoothedMap(first.walls, first.shape)
    start = rigid_matrix(offset[0], offset[1], np.deg2rad(0.3))
    refined = refine_transform(smoothed, second, start, sigmas=(2.0, 1.0, 0.6), iterations=10)
    # The truth is the identity: every wall cell should land within 0.1 cell of itself.
    moved = second.points @ refined[:2, :2].T + refined[:2, 2]
    rms = float(np.sqrt(np.mean(np.sum((moved - second.points) ** 2, axis=1))))
    assert rms < 0.1


def test_refine_from_a_nearby_start_verifies_and_accepts(building: np.ndarray) -> None:
    map2, truth = turned(building, 30.0, (4.0, -3.0))
    start = rigid_matrix(1.2, -0.8, np.deg2rad(0.4)) @ truth
    result = refine_from(building, map2, start)
    assert result.accepted
    assert merging.transform_error(result.matrix, truth, map2)[0] < 0.5
    # No search, so no search for the mirror image either: the start vouches for that.
    assert "mirror" not in result.timings and "mirror_share" not in result.evidence


GOOD = Verification(agreement=0.9, conflict=0.02, overlap=2000.0, agreeing=1800.0,
                    shared_space=3000.0)  # fmt: skip
"""A verification that every factor likes, but none saturates."""


@pytest.mark.parametrize(
    ("factor", "worse", "better"),
    [
        ("fit", replace(GOOD, agreement=0.8), GOOD),
        ("fit", replace(GOOD, conflict=0.05), GOOD),
        ("support", replace(GOOD, agreeing=60.0), replace(GOOD, agreeing=200.0)),
        ("shared space", replace(GOOD, shared_space=500.0), replace(GOOD, shared_space=2000.0)),
    ],
)
def test_confidence_rises_with_each_factor(factor, worse, better) -> None:
    assert confidence(better) > confidence(worse), factor


def test_confidence_rises_with_distinctiveness_and_constraint() -> None:
    close = replace(GOOD, agreement=0.7)  # a runner-up explaining nearly as much
    far = replace(GOOD, agreement=0.4)
    assert confidence(GOOD, far) > confidence(GOOD, close)
    assert confidence(GOOD, strength=30.0) > confidence(GOOD, strength=3.0)
    factors = confidence_factors(GOOD, far, strength=30.0)
    assert len(factors) == 5 and all(0.0 <= f <= 1.0 for f in factors)
    assert confidence(GOOD, far, strength=30.0) == pytest.approx(float(np.prod(factors)))


@pytest.mark.parametrize("radius", [0, 1, 3, 4, 13, 30, 41])
@pytest.mark.parametrize("shape", [(57, 83), (3, 5), (1, 40)])
def test_dilate_matches_scipy(radius: int, shape: tuple[int, int]) -> None:
    # Radii of several doubling shifts, on grids narrower than the radius: what the
    # edge cuts off must not be missed.
    mask = np.random.default_rng(2).random(shape) < 0.05
    mask[0, 0] = mask[-1, -1] = True  # the edges too
    expected = ndimage.binary_dilation(mask, structure=np.ones((2 * radius + 1,) * 2, bool))
    assert np.array_equal(dilate(mask, radius), expected)


@pytest.mark.parametrize("sigma, truncate", [(0.6, 3.0), (1.0, 3.0), (2.0, 3.0), (1.5, 4.0)])
def test_wall_blur_matches_scipy_cell_for_cell(sigma: float, truncate: float) -> None:
    rng = np.random.default_rng(3)
    for shape in ((57, 83), (4, 9), (1, 1)):
        count = max(1, shape[0] * shape[1] // 20)
        rows, cols = rng.integers(0, shape[0], count), rng.integers(0, shape[1], count)
        rows[0], cols[0] = shape[0] - 1, shape[1] - 1  # an edge, where the blur reflects
        image = np.zeros(shape, np.float32)
        image[rows, cols] = 1.0
        expected = ndimage.gaussian_filter(image, sigma, truncate=truncate)
        blurred = blur_walls(rows, cols, shape, sigma, truncate=truncate)
        assert blurred.dtype == np.float32
        assert np.array_equal(blurred, expected)


def test_wall_blur_of_a_real_map_matches_scipy(building: np.ndarray) -> None:
    prepared = prepare_map(building)
    cells = prepared.walls.astype(np.intp)
    image = np.zeros(prepared.shape, np.float32)
    image[cells[:, 1], cells[:, 0]] = 1.0
    for sigma in (0.6, 1.0, 2.0):
        expected = ndimage.gaussian_filter(image, sigma, truncate=3.0)
        blurred = blur_walls(cells[:, 1], cells[:, 0], prepared.shape, sigma, truncate=3.0)
        assert np.array_equal(blurred, expected)


def test_wall_blur_refuses_what_it_cannot_blur() -> None:
    rows, cols = np.array([1, 2]), np.array([3, 4])
    with pytest.raises(ValueError, match="sigma and truncate must be positive"):
        blur_walls(rows, cols, (5, 5), 0.0)
    with pytest.raises(ValueError, match="inside the shape"):
        blur_walls(np.array([-1, 2]), cols, (5, 5), 1.0)
    with pytest.raises(ValueError, match="inside the shape"):
        blur_walls(rows, np.array([3, 5]), (5, 5), 1.0)
    assert not blur_walls(rows[:0], cols[:0], (5, 5), 1.0).any()


def test_compiled_bilinear_matches_map_coordinates() -> None:
    rng = np.random.default_rng(4)
    image = rng.random((40, 50)).astype(np.float32)
    rows, cols = rng.uniform(0, 39.0, 500), rng.uniform(0, 49.0, 500)
    rows[:5], cols[:5] = np.arange(5.0), np.arange(5.0)  # on the grid points too
    rows[5:8], cols[5:8] = [39.0, 12.5, 39.0], [7.25, 49.0, 49.0]  # the last row and column
    expected = ndimage.map_coordinates(image, [rows, cols], order=1)
    assert np.array_equal(_bilinear(image, rows, cols), expected)


@pytest.mark.parametrize("tolerance, clearance", [(1, 2), (3, 2), (2, 0)])
def test_tolerant_masks_grow_walls_as_two_dilations_would(
    building: np.ndarray, tolerance: int, clearance: int
) -> None:
    prepared = prepare_map(building)
    occupied = occupied_mask(building)
    grown, far_free = prepared.tolerant_masks(tolerance, clearance)
    assert np.array_equal(grown, dilate(occupied, tolerance))
    wide = ndimage.binary_dilation(occupied, np.ones((2 * (tolerance + clearance) + 1,) * 2, bool))
    assert np.array_equal(far_free, free_mask(building) & ~wide)
    assert prepared.tolerant_masks(tolerance, clearance)[0] is grown  # kept


def test_verification_counts_agreement_and_conflict() -> None:
    # A wall carried onto the other map's wall agrees; carried into its open room it conflicts.
    grid = np.full((60, 60), 0, dtype=np.int8)
    grid[30, 5:55] = 100
    first = second = prepare_map(grid)
    on = verify(first, second, np.eye(3))
    assert on.agreement == pytest.approx(1.0) and on.conflict == 0.0
    off = verify(first, second, rigid_matrix(0.0, 12.0, 0.0))
    assert off.conflict > 0.9 and off.agreement == 0.0


def test_params_change_the_verdict(building: np.ndarray) -> None:
    map2, _ = turned(building, 40.0, (3.0, 2.0))
    default = merging.estimate_transform(building, map2)
    assert default.accepted
    never = TomographicParams()
    never = replace(never, confidence=replace(never.confidence, accept=1.0))
    refused = merging.estimate_transform(building, map2, params=never)
    assert not refused.accepted
    assert np.allclose(refused.matrix, default.matrix)


def test_params_for_a_method_without_settings_are_a_type_error(building) -> None:
    with pytest.raises(TypeError, match="'paper' method takes no params"):
        merging.estimate_transform(building, building, method="paper", params=TomographicParams())
    with pytest.raises(TypeError, match="must be a TomographicParams"):
        merging.estimate_transform(building, building, params={"accept": 0.4})


def test_params_validate_the_schedule() -> None:
    with pytest.raises(ValueError, match="at least one RefineStage"):
        TomographicParams(stages=())
    with pytest.raises(TypeError, match="stages\\[0\\] must be a RefineStage"):
        TomographicParams(stages=("wide",))  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("make", "error", "message"),
    [
        (lambda: TomographicParams(confidence="x"), TypeError, "confidence must be a Confidence"),
        (
            lambda: VerifyParams(screen_stride=0),
            ValueError,
            "screen_stride must be a whole number >= 1",
        ),
        (
            lambda: TranslationParams(coarse_cells=0),
            ValueError,
            "coarse_cells must be a whole number >= 1",
        ),
        (lambda: VerifyParams(near_radius=1.5), TypeError, "near_radius must be a whole number"),
        (lambda: ConfidenceParams(accept="0.7"), TypeError, r"accept must be a number in \[0, 1\]"),
        (lambda: ConfidenceParams(accept=1.5), ValueError, r"accept must be a number in \[0, 1\]"),
        (lambda: ConfidenceParams(accept=float("nan")), ValueError, "accept must be a number in"),
        (
            lambda: RobustParams(widths=()),
            TypeError,
            "widths must be a tuple of at least one number",
        ),
        (lambda: RobustParams(widths=(1.0,)), ValueError, "widths must hold 7 entries"),
        (
            lambda: RefineStage(1, 1, (0.0,), 1, 3, True),
            ValueError,
            r"sigmas\[0\] must be a positive number",
        ),
        (lambda: TranslationParams(peaks=True), TypeError, "peaks must be a whole number"),
        (lambda: RefineStage(1, 1, (1.0,), 1, 3, 1), TypeError, "local must be True or False"),
    ],
)
def test_params_name_a_setting_of_the_wrong_kind(make, error, message: str) -> None:
    # Unchecked, each failed deep inside the search (a zero stride, a string threshold)
    # or refused every match with a reason about the walls (a threshold above 1).
    with pytest.raises(error, match=message):
        make()


def test_params_take_numpy_numbers() -> None:
    assert TranslationParams(coarse_cells=np.int64(120)).coarse_cells == 120
    assert ConfidenceParams(accept=np.float32(0.7)).accept == pytest.approx(0.7)


def test_refine_from_validates_its_input(building: np.ndarray) -> None:
    with pytest.raises(ValueError, match="3x3"):
        refine_from(building, building, np.eye(2))
    with pytest.raises(TypeError, match="TomographicParams"):
        refine_from(building, building, np.eye(3), params=object())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="singular"):
        refine_from(building, building, np.diag([1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="held_against_search must be True or False"):
        refine_from(building, building, np.eye(3), held_against_search="no")  # type: ignore[arg-type]
    grid = merging.OccupancyGrid(building)
    result = refine_from(grid, grid, rigid_matrix(0.8, -0.5, 0.002))
    assert result.accepted
    assert np.allclose(result.matrix_metres, cells_to_metres(result.matrix, grid, grid))
    assert result.timings["total"] >= result.timings["refine"]
    coarser = merging.OccupancyGrid(building, resolution=0.1)
    with pytest.raises(ValueError, match="resolutions differ"):
        refine_from(grid, coarser, np.eye(3))


def test_refine_from_refuses_a_map_without_walls(building: np.ndarray) -> None:
    start = rigid_matrix(2.0, 1.0, 0.0)
    result = refine_from(building, np.zeros((50, 50), np.int8), start)
    assert not result.accepted and "too few occupied cells" in result.reason
    assert np.array_equal(result.matrix, start)


def test_compiled_field_sampling_matches_numpy() -> None:
    # The refinement's compiled lookup against the same steps written in numpy:
    # move, locate in the field's pixels, keep what lands inside, interpolate.
    generator = np.random.default_rng(4)
    image = generator.random((40, 50)).astype(np.float32)
    field = Field(image, scale=2.0, corner=(6, 4))
    points = generator.uniform(-20, 110, (500, 2))
    matrix = rigid_matrix(3.5, -2.0, 0.3)
    landed, value, grad_x, grad_y = _field_sample(field, matrix, points)
    moved = apply_transform(matrix, points)
    pixels = field.locate(moved)
    ok = (
        (pixels[:, 0] >= 0)
        & (pixels[:, 0] < image.shape[1] - 1)
        & (pixels[:, 1] >= 0)
        & (pixels[:, 1] < image.shape[0] - 1)
    )
    assert 0 < ok.sum() < len(points)
    x, y = pixels[ok, 0], pixels[ok, 1]
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    v00, v01 = image[y0, x0], image[y0, x0 + 1]
    v10, v11 = image[y0 + 1, x0], image[y0 + 1, x0 + 1]
    top, bottom = v00 * (1 - fx) + v01 * fx, v10 * (1 - fx) + v11 * fx
    np.testing.assert_allclose(landed, moved[ok], atol=1e-9)
    np.testing.assert_allclose(value, top * (1 - fy) + bottom * fy, atol=1e-6)
    np.testing.assert_allclose(grad_x, (v01 - v00) * (1 - fy) + (v11 - v10) * fy, atol=1e-6)
    np.testing.assert_allclose(grad_y, bottom - top, atol=1e-6)


def test_compiled_normal_equations_match_numpy() -> None:
    generator = np.random.default_rng(5)
    landed = generator.uniform(0, 100, (300, 2))
    value, grad_x, grad_y = generator.random((3, 300))
    pivot, radius, normal, rhs = normal_equations(landed, value, grad_x, grad_y, 2.0)
    rel = landed - landed.mean(axis=0)
    expected_radius = np.sqrt(np.mean(np.sum(rel**2, axis=1))) + 1e-9
    gx, gy = grad_x / 2.0, grad_y / 2.0
    jacobian = np.column_stack([gx, gy, (-gx * rel[:, 1] + gy * rel[:, 0]) / expected_radius])
    np.testing.assert_allclose(pivot, landed.mean(axis=0))
    assert radius == pytest.approx(expected_radius)
    np.testing.assert_allclose(normal, jacobian.T @ jacobian, rtol=1e-10)
    np.testing.assert_allclose(rhs, jacobian.T @ (1.0 - value), rtol=1e-10)


def test_compiled_landing_counts_match_numpy(building: np.ndarray) -> None:
    first, second = prepare_map(building), prepare_map(turned(building, 20.0, (5, -3))[0])
    matrix = rigid_matrix(12.0, -7.0, 0.35)
    for stride in (1, 3):
        counts = _landing(matrix, second.points, stride, first)
        moved = apply_transform(matrix, second.points[::stride])
        cols, rows = np.rint(moved[:, 0]).astype(int), np.rint(moved[:, 1]).astype(int)
        inside = (rows >= 0) & (rows < first.shape[0]) & (cols >= 0) & (cols < first.shape[1])
        rows, cols = rows[inside], cols[inside]
        near = first.near_occupied[rows, cols]
        known = (first.cells[rows, cols] >= 0) | near
        clear = first.clear_free[rows, cols]
        assert counts == (known.sum(), near.sum(), clear.sum())
        assert counts[1] > 0 and counts[0] > counts[1]


def test_landing_codes_hold_each_mask_in_its_bit(building: np.ndarray) -> None:
    prepared = prepare_map(building)
    codes = prepared.landing
    near = prepared.near_occupied
    assert np.array_equal((codes & KNOWN_BIT) > 0, near | (prepared.cells >= 0))
    assert np.array_equal((codes & NEAR_BIT) > 0, near)
    assert np.array_equal((codes & CLEAR_BIT) > 0, prepared.clear_free)
    assert codes.max() <= KNOWN_BIT | NEAR_BIT | CLEAR_BIT


def test_clear_blocks_are_clear_at_their_corners_and_centre(building: np.ndarray) -> None:
    prepared = prepare_map(building)
    assert np.array_equal(clear_blocks(prepared, 1), prepared.clear_free)
    blocks = clear_blocks(prepared, 4)
    assert blocks.shape == (-(-building.shape[0] // 4), -(-building.shape[1] // 4))
    for row, col in zip(*np.nonzero(blocks), strict=True):
        cells = prepared.clear_free[4 * row : 4 * row + 4, 4 * col : 4 * col + 4]
        assert cells[0, 0] and cells[0, -1] and cells[-1, 0] and cells[-1, -1] and cells[2, 2]
    # A block holding a wall is never clear.
    walls = prepared.walls.astype(np.intp) // 4
    assert not blocks[walls[:, 1], walls[:, 0]].any()


def test_curvature_is_kept_for_the_same_placement_only(building: np.ndarray) -> None:
    first, second = prepare_map(building), prepare_map(turned(building, 20.0, (5, -3))[0])
    smoothed = SmoothedMap(first.walls, first.shape)
    matrix = rigid_matrix(12.0, -7.0, 0.35)
    curvature, stride = curvature_matrix(smoothed, second, matrix, local=True)
    again, _ = curvature_matrix(smoothed, second, matrix.copy(), local=True)
    assert again is curvature and curvature is not None and not curvature.flags.writeable
    fresh, fresh_stride = curvature_matrix(
        SmoothedMap(first.walls, first.shape), second, matrix, local=True
    )
    assert fresh is not None and np.array_equal(curvature, fresh) and stride == fresh_stride
    # Another placement, another map 2 or other settings are computed anew.
    default, wider = GaussNewtonParams(), replace(GaussNewtonParams(), curvature_sigma=3.0)
    others = (
        (second, rigid_matrix(14.0, -6.0, 0.3), default),
        (prepare_map(turned(building, 25.0, (5, -3))[0]), matrix, default),
        (second, matrix, wider),
    )
    for other_second, other_matrix, params in others:
        kept = SmoothedMap(first.walls, first.shape)
        curvature_matrix(kept, second, matrix, local=True)
        got = curvature_matrix(kept, other_second, other_matrix, local=True, params=params)[0]
        want = curvature_matrix(
            SmoothedMap(first.walls, first.shape),
            other_second,
            other_matrix,
            local=True,
            params=params,
        )[0]
        assert got is not None and want is not None
        assert np.array_equal(got, want) and not np.array_equal(got, curvature)


def test_boxed_fields_are_kept_and_equal_to_fresh_ones(building: np.ndarray) -> None:
    walls = prepare_map(building).walls
    smoothed = SmoothedMap(walls, building.shape)
    box = (40, 30, 160, 120)
    field = smoothed.field(1.0, box=box)
    assert smoothed.field(1.0, box=box) is field
    fresh = SmoothedMap(walls, building.shape).field(1.0, box=box)
    assert np.array_equal(field.image, fresh.image) and field.corner == fresh.corner
    # Another width or box is another field; the oldest kept one is dropped first.
    assert smoothed.field(0.6, box=box) is not field
    for shift in range(BOXED_FIELDS_KEPT):
        smoothed.field(1.0, box=(41 + shift, 30, 160, 120))
    again = smoothed.field(1.0, box=box)
    assert again is not field and np.array_equal(again.image, field.image)
