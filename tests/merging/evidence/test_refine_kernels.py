"""The compiled loops of the refinement, verification and mirror check against numpy.

Each kernel replaced a loop of numpy statements; these tests keep those
statements as the reference and ask for the same numbers to the last bit, so
that the merger's answers do not move when the loop is compiled.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import fft, ndimage

from merging.evidence.blur import blur_walls
from merging.evidence.mirror import _landing_mask
from merging.evidence.refine import (
    Field,
    SmoothedMap,
    _field_sample,
    _gauss_newton,
    constraint_strength,
)
from merging.evidence.refine_kernels import normal_equations, pairwise_sum
from merging.evidence.solve3 import solve3
from merging.evidence.verify import _landing, prepare_map, verify
from merging.params import GaussNewtonParams
from merging.tomographic.correlate import padded_rfft2
from merging.transforms import rigid_matrix, rotation_about
from tests.merging.builders import synthetic_building, turned


@pytest.mark.parametrize("count", [0, 1, 7, 8, 9, 100, 128, 129, 136, 1000, 4099, 30011])
def test_pairwise_sum_is_numpys_sum(count: int) -> None:
    values = np.random.default_rng(count).random(count) ** 3
    assert pairwise_sum(values) == float(values.sum())


def _numpy_gauss_newton(field: Field, points, start, iterations: int, params: GaussNewtonParams):
    """The refinement's loop as numpy statements (the reference of the compiled one); the
    3 x 3 solve is :func:`solve3`'s Python (``tests/merging/evidence/test_solve3.py``
    holds it to numpy's)."""

    def step_matrix(step, pivot):
        update = rotation_about(float(step[2]), pivot)
        update[:2, 2] += step[:2]
        return update

    best, best_total, current = start, -np.inf, start
    step, pivot, halvings = np.zeros(3), np.zeros(2), 0
    for _ in range(iterations + params.backtracks):
        landed, value, gx, gy = _field_sample(field, current, points)
        if len(value) < 3:
            break
        total = float(value.sum())
        if total <= best_total:
            if halvings == params.backtracks:
                break
            step /= 2
            halvings += 1
            current = step_matrix(step, pivot) @ best
            continue
        best, best_total, halvings = current, total, 0
        pivot, radius, normal, rhs = normal_equations(landed, value, gx, gy, field.scale)
        normal += params.damping * (np.trace(normal) / 3 + 1e-12) * np.eye(3)
        motion = params.newton_factor * solve3.py_func(normal, rhs)
        length = float(np.linalg.norm(motion))
        longest = max(params.max_step_cells, params.max_step_sigmas * field.sigma)
        if length > longest:
            motion *= longest / length
        if length < params.converged_cells:
            break
        step = np.array([motion[0], motion[1], motion[2] / radius])
        current = step_matrix(step, pivot) @ best
    return best


@pytest.mark.parametrize("sigma", [4.0, 2.0, 1.0, 0.6])
def test_compiled_gauss_newton_is_the_numpy_loop(sigma: float) -> None:
    grid = synthetic_building(3)
    map2, truth = turned(grid, 25.0, (6.0, -4.0))
    first, second = prepare_map(grid), prepare_map(map2)
    field = SmoothedMap(first.walls, first.shape).field(sigma)
    params = GaussNewtonParams()
    generator = np.random.default_rng(int(sigma * 10))
    for _ in range(5):
        start = rigid_matrix(*generator.normal(0, 2, 2), generator.normal(0, 0.02)) @ truth
        expected = _numpy_gauss_newton(field, second.points, start, 10, params)
        assert np.array_equal(_gauss_newton(field, second.points, start, 10, params), expected)
        assert not np.array_equal(expected, start)


def test_constraint_strength_is_the_numpy_finite_differences() -> None:
    grid = synthetic_building(4)
    map2, truth = turned(grid, 40.0, (3.0, 2.0))
    first, second = prepare_map(grid), prepare_map(map2)
    smoothed = SmoothedMap(first.walls, first.shape)
    params = GaussNewtonParams()
    field = smoothed.field(params.curvature_sigma)
    stride = max(1, int(np.ceil(len(second.points) / params.curvature_points)))
    points = second.points[::stride]
    landed = points @ truth[:2, :2].T + truth[:2, 2]
    pivot = landed.mean(axis=0)
    metric = np.diag([1.0, 1.0, float(np.mean(np.sum((landed - pivot) ** 2, axis=1)))])
    steps = params.curvature_step / np.sqrt(np.diag(metric))

    def objective(delta):
        update = rotation_about(delta[2], pivot)
        update[:2, 2] += delta[:2]
        return float(_field_sample(field, update @ truth, points)[1].sum())

    centre, hessian, basis = objective(np.zeros(3)), np.zeros((3, 3)), np.eye(3) * steps
    for i in range(3):
        plus, minus = objective(basis[i]), objective(-basis[i])
        hessian[i, i] = (plus - 2 * centre + minus) / steps[i] ** 2
        for j in range(i + 1, 3):
            pp, pm = objective(basis[i] + basis[j]), objective(basis[i] - basis[j])
            mp, mm = objective(-basis[i] + basis[j]), objective(-basis[i] - basis[j])
            hessian[i, j] = hessian[j, i] = (pp - pm - mp + mm) / (4 * steps[i] * steps[j])
    whiten = np.diag(1.0 / np.sqrt(np.diag(metric)))
    curvature = -whiten @ hessian @ whiten
    expected = max(float(np.linalg.eigvalsh(0.5 * (curvature + curvature.T))[0]), 0.0) * stride
    assert constraint_strength(smoothed, second, truth, params=params) == expected
    assert expected > 0


@pytest.mark.parametrize("sigma", [0.6, 1.0, 2.0, 4.0])
@pytest.mark.parametrize("box", [None, (30, 20, 170, 140)])
def test_field_image_is_the_blurred_scaled_capped_walls(sigma, box) -> None:
    grid = synthetic_building(2)
    first = prepare_map(grid)
    smoothed = SmoothedMap(first.walls, first.shape)
    field = smoothed.field(sigma, box=box)
    x_lo, y_lo, x_hi, y_hi = box or (0, 0, grid.shape[1], grid.shape[0])
    walls = first.walls
    inside = (
        (walls[:, 0] >= x_lo) & (walls[:, 0] < x_hi) & (walls[:, 1] >= y_lo) & (walls[:, 1] < y_hi)
    )
    cells = ((walls[inside] - np.array([x_lo, y_lo])) // field.scale).astype(np.intp)
    shape = tuple(int(np.ceil(n / field.scale)) for n in (y_hi - y_lo, x_hi - x_lo))
    width = sigma / field.scale
    smooth = blur_walls(cells[:, 1], cells[:, 0], shape, width, truncate=3.0)
    smooth *= np.float32(np.sqrt(2 * np.pi) * width)
    expected = np.pad(np.minimum(smooth, 1.0), 1)
    assert field.image.dtype == np.float32
    assert np.array_equal(field.image, expected)


def test_verification_counts_both_ways_as_numpy_does(building: np.ndarray) -> None:
    first, second = prepare_map(building), prepare_map(turned(building, 20.0, (5, -3))[0])
    matrix = rigid_matrix(12.0, -7.0, 0.35)
    inverse = np.linalg.inv(matrix)
    for stride in (1, 3):
        check = verify(first, second, matrix, stride=stride)
        known_f, near_f, clear_f = _landing(matrix, second.points, stride, first)
        known_b, near_b, clear_b = _landing(inverse, first.points, stride, second)
        weight1, weight2 = first.point_weight * stride, second.point_weight * stride
        assert check.overlap == known_f * weight2 + known_b * weight1
        assert check.agreeing == near_f * weight2 + near_b * weight1
        assert check.conflict * check.overlap == pytest.approx(
            clear_f * weight2 + clear_b * weight1
        )
        open_f = _landing(matrix, second.open_points, stride, first)[2]
        open_b = _landing(inverse, first.open_points, stride, second)[2]
        shared = open_f * (second.open_weight * stride) + open_b * (first.open_weight * stride)
        assert check.shared_space == shared
        assert shared > 0


def _numpy_landing_mask(source, matrix, target, stride: int):
    """The landing mask as numpy statements: samples carried, looked up, grown to blocks."""
    sampled = source[::stride, ::stride]
    rows, cols = np.nonzero(sampled)
    x = np.rint(matrix[0, 0] * cols * stride + matrix[0, 1] * rows * stride + matrix[0, 2])
    y = np.rint(matrix[1, 0] * cols * stride + matrix[1, 1] * rows * stride + matrix[1, 2])
    x, y = x.astype(np.intp), y.astype(np.intp)
    inside = (y >= 0) & (y < target.shape[0]) & (x >= 0) & (x < target.shape[1])
    hit = np.zeros(sampled.shape, dtype=bool)
    hit[rows[inside], cols[inside]] = target[y[inside], x[inside]]
    grown = np.repeat(np.repeat(hit, stride, axis=0), stride, axis=1)
    return grown[: source.shape[0], : source.shape[1]] & source


@pytest.mark.parametrize("stride_cells", [1, 3])
@pytest.mark.parametrize(
    "pose",
    [(-20.0, 13.5, 0.4), (300.0, -100.0, 2.5), (-150.0, 200.0, -1.0), (200.0, -100.0, np.pi / 2)],
)
def test_landing_mask_is_the_numpy_one(stride_cells: int, pose, monkeypatch) -> None:
    # Blocks of cells are decided together above REGION_SAMPLES cells; shrink it to test both.
    import merging.evidence.mirror as mirror

    grid = synthetic_building(1)
    source, target = grid >= 0, np.random.default_rng(2).random((150, 230)) < 0.6
    monkeypatch.setattr(mirror, "REGION_SAMPLES", source.size // stride_cells**2)
    stride = max(1, int(np.sqrt(source.size / mirror.REGION_SAMPLES)))
    assert stride == stride_cells
    matrix = rigid_matrix(*pose)
    result = _landing_mask(source, matrix, target)
    assert np.array_equal(result, _numpy_landing_mask(source, matrix, target, stride))
    assert 0 < result.sum() < source.sum()
    # The reflection the mirror check uses lands cells the same way.
    flipped = np.array([[-1.0, 0.0, 229.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) @ matrix
    expected = _numpy_landing_mask(source, flipped, target, stride)
    assert np.array_equal(_landing_mask(source, flipped, target), expected)
    # A target with a few set cells only: just the cells that land on them.
    sparse = np.zeros_like(target)
    sparse[60:70, 100:104] = True
    expected = _numpy_landing_mask(source, matrix, sparse, stride)
    assert np.array_equal(_landing_mask(source, matrix, sparse), expected)


def test_fields_in_kept_work_space_match_fresh_ones() -> None:
    # Each field leaves the blur's work space zeroed, so the next one, of another size,
    # starts clean: fields made one after the other equal those made alone.
    from merging.evidence import refine

    grid = synthetic_building(6)
    first = prepare_map(grid)
    requests = [(1.0, None), (0.6, (40, 30, 200, 150)), (2.0, None), (1.0, (10, 5, 90, 250))]
    made = [SmoothedMap(first.walls, first.shape).field(s, box=b).image for s, b in requests]
    for (sigma, box), image in zip(reversed(requests), reversed(made), strict=True):
        again = SmoothedMap(first.walls, first.shape).field(sigma, box=box)
        assert np.array_equal(again.image, image)
    state, down, sums = refine._work_space(1)
    assert not state.any() and not down.any() and not sums.any()


@pytest.mark.parametrize(
    "shape, size", [((37, 50), (80, 96)), ((120, 9), (125, 160)), ((1, 1), (8, 8))]
)
def test_padded_rfft2_is_scipys(shape, size) -> None:
    image = (np.random.default_rng(shape[0]).random(shape) < 0.1).astype(np.float32)
    expected = fft.rfft2(image, s=size)
    result = padded_rfft2(image, size)
    assert result.dtype == expected.dtype == np.complex64
    assert np.array_equal(result, expected)


def test_blur_reflects_at_the_edges_as_scipy_does() -> None:
    # Walls on the border and a kernel wider than a tiny image: every index folds back.
    rows, cols = np.array([0, 0, 2, 1]), np.array([0, 3, 3, 1])
    for sigma in (0.6, 2.0, 5.0):
        image = np.zeros((3, 4), dtype=np.float32)
        image[rows, cols] = 1.0
        expected = ndimage.gaussian_filter(image, sigma, truncate=3.0)
        assert np.array_equal(blur_walls(rows, cols, (3, 4), sigma, truncate=3.0), expected)
