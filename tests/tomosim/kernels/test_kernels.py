"""The compiled kernels against their numpy oracles (tomosim.kernels)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from merging.grid import UNKNOWN
from tomosim.kernels.crop import crop_max_pool
from tomosim.kernels.logodds import (
    SATURATED,
    beam_cells,
    beam_cells_narrow,
    beam_ends,
    code_thresholds,
    integrate_scan,
    ros_code,
    saturated_run,
)
from tomosim.kernels.raycast import TWO_PI, cast_scan, turn_remainder
from tomosim.kernels.reveal import first_of_keys, truth_under_table
from tomosim.lidar import Lidar, LidarConfig
from tomosim.mapping import (
    CODE_THRESHOLDS,
    HIT_DEPTH_CELLS,
    SAMPLE_STEP_CELLS,
    LogOddsMap,
    MappingConfig,
    integrate_rays,
    ray_cells,
    ros_codes,
)
from tomosim.ray_geometry import cast_circles, cast_segments, cull_segments, segment_bounds
from tomosim.simulation import Simulation, SimulationConfig
from tomosim.worlds import generate_floorplan

CASTER_TOLERANCE = 1e-9
"""Metres by which the kernel and the numpy caster may differ: the same intersections
in double precision, computed in another order."""


def numpy_scan(
    walls: np.ndarray,
    pose: np.ndarray,
    config: LidarConfig,
    centres: np.ndarray,
    radii: np.ndarray,
) -> np.ndarray:
    """The oracle: cull, sweep the walls, then the circles (tomosim.ray_geometry)."""
    origin = np.asarray(pose[:2], dtype=float)
    near = walls[cull_segments(origin, segment_bounds(walls), config.max_range)]
    first = pose[2] + config.first_angle
    ranges = cast_segments(origin, first, config.increment, config.beams, near, config.max_range)
    if len(centres):
        angles = pose[2] + config.angles()
        directions = np.column_stack([np.cos(angles), np.sin(angles)])
        np.minimum(
            ranges, cast_circles(origin, directions, centres, radii, config.max_range), out=ranges
        )
    return ranges


@pytest.mark.parametrize(
    ("seed", "config"),
    [
        (0, LidarConfig()),
        (5, LidarConfig(beams=181, fov=math.radians(270.0), max_range=5.0)),
        (9, LidarConfig(beams=1000, max_range=12.0)),
    ],
)
def test_ray_casting_kernel_matches_the_numpy_caster(seed: int, config: LidarConfig) -> None:
    world = generate_floorplan(seed)
    walls = world.walls
    flat = np.ascontiguousarray(walls.reshape(-1, 4))
    poses = world.sample_free_poses(12, clearance=0.4, min_separation=0.9, rng=seed)
    radii = np.full(len(poses) - 1, 0.2)
    hits = 0
    for index, pose in enumerate(poses):
        centres = np.ascontiguousarray(np.delete(poses[:, :2], index, axis=0))
        expected = numpy_scan(walls, pose, config, centres, radii)
        first = pose[2] + config.first_angle
        ours = cast_scan(
            pose[0], pose[1], first, config.increment, config.beams, flat, centres, radii,
            config.max_range,
        )  # fmt: skip
        np.testing.assert_array_equal(np.isfinite(ours), np.isfinite(expected))
        finite = np.isfinite(ours)
        assert np.max(np.abs(ours[finite] - expected[finite]), initial=0.0) <= CASTER_TOLERANCE
        hits += np.count_nonzero(finite)
    assert hits > len(poses) * config.beams // 4  # the scans do see walls


def test_ray_casting_kernel_on_shared_corners_and_collinear_walls() -> None:
    walls = np.array(
        [[-1, -1, 1, -1], [1, -1, 1, 1], [1, 1, -1, 1], [-1, 1, -1, -1], [2, 0, 3, 0]], float
    )
    # Even beams aim at the square's corners, where two walls meet.
    ranges = cast_scan(
        0.0, 0.0, math.pi / 4 - math.pi, math.pi / 4, 8, walls, np.zeros((0, 2)), np.zeros(0), 10.0
    )
    np.testing.assert_allclose(ranges[0::2], math.sqrt(2.0), atol=1e-9)
    np.testing.assert_allclose(ranges[1::2], 1.0, atol=1e-9)
    # From outside the room, a beam along the wall line hits the segment's near end.
    along = cast_scan(1.5, 0.0, 0.0, math.pi / 2, 4, walls[4:], np.zeros((0, 2)), np.zeros(0), 10.0)
    assert along[0] == pytest.approx(0.5) and np.all(np.isinf(along[1:]))


def test_ros_code_thresholds_match_the_exponential() -> None:
    near = CODE_THRESHOLDS[:100].astype(np.float32)  # float32 values at and beside each one
    beyond = np.array([-30.0, -8.0, -5.3, 5.3, 8.0, 30.0], np.float32)  # codes 0 and 100
    values = np.concatenate(
        [np.linspace(-2.0, 3.5, 20001, dtype=np.float32), near, np.nextafter(near, np.inf), beyond]
    )
    expected = ros_codes(values[None, :], np.ones((1, len(values)), bool))[0]
    ours = np.array([ros_code(float(v), code_thresholds()) for v in values])
    np.testing.assert_array_equal(ours, expected)
    assert set(ours[-len(beyond) :]) == {0, 100}
    clamped = ours[:20001]  # the clamp's range: 100 / (1 + e^2) = 11.9, 100 / (1 + e^-3.5) = 97.1
    assert clamped.min() == 12 and clamped.max() == 97


def random_scan(
    rng: np.random.Generator, shape: tuple[int, int], beams: int
) -> tuple[tuple[float, float], np.ndarray, np.ndarray]:
    """An origin and beam ends inside a grid of ``shape``, some of them hits."""
    rows, cols = shape
    origin = (float(rng.uniform(30, cols - 30)), float(rng.uniform(30, rows - 30)))
    angle = rng.uniform(-np.pi, np.pi) + np.linspace(0, 2 * np.pi, beams, endpoint=False)
    length = rng.uniform(0.0, 28.0, beams)
    ends = np.column_stack([origin[0] + length * np.cos(angle), origin[1] + length * np.sin(angle)])
    return origin, ends, rng.random(beams) < 0.7


def first_observed(
    observed: np.ndarray, origin: tuple[float, float], ends: np.ndarray, hit: np.ndarray
) -> np.ndarray:
    """The oracle of the kernel's fresh cells and their order: the cells unobserved before
    the scan, in the order the scan's samples, then its hits, first reach them."""
    passed, hits = ray_cells(origin, ends, hit, observed.shape[1])
    sequence = np.concatenate([passed, hits])
    _, first = np.unique(sequence, return_index=True)
    order = sequence[np.sort(first)]
    return order[~observed.reshape(-1)[order]]


def test_log_odds_kernel_matches_the_numpy_model_scan_by_scan() -> None:
    config = MappingConfig()
    shape = (90, 120)
    rng = np.random.default_rng(3)
    logodds, observed = np.zeros(shape, np.float32), np.zeros(shape, bool)
    kernel_logodds, kernel_observed = logodds.copy(), observed.copy()
    codes = np.full(shape, UNKNOWN, np.int8)
    stamps = np.zeros(shape, np.uint8)
    scratch = np.zeros(200_000, np.int64)  # more than any of these scans needs
    repeated = random_scan(rng, shape, 90)
    for scan in range(1, 60):
        # The last scans repeat one: its passes reach the lower clamp, its hits the upper.
        origin, ends, hit = random_scan(rng, shape, 90) if scan <= 40 else repeated
        expected_fresh = first_observed(observed, origin, ends, hit)
        integrate_rays(logodds, observed, origin, ends, hit, config)
        fresh = integrate_scan(
            kernel_logodds, kernel_observed, codes, stamps, scan, origin[0], origin[1], ends, hit,
            config.log_odds_hit, config.log_odds_miss, config.log_odds_min, config.log_odds_max,
            SAMPLE_STEP_CELLS, HIT_DEPTH_CELLS, CODE_THRESHOLDS, scratch,
        )  # fmt: skip
        np.testing.assert_array_equal(kernel_logodds, logodds)
        np.testing.assert_array_equal(kernel_observed, observed)
        np.testing.assert_array_equal(codes, ros_codes(logodds, observed))
        np.testing.assert_array_equal(fresh, expected_fresh)
        # The saturation flag marks exactly the cells at the clamp.
        saturated = (stamps & SATURATED) != 0
        np.testing.assert_array_equal(saturated, logodds == np.float32(config.log_odds_min))
    assert np.count_nonzero(observed) > shape[0] * shape[1] // 3
    assert np.count_nonzero(logodds == np.float32(config.log_odds_min)) > 500  # clamp exercised
    assert np.any(logodds == np.float32(config.log_odds_max))


def test_a_map_matches_the_numpy_model_past_the_wrap_of_its_scan_numbers() -> None:
    # 300 scans: the one-byte stamps are cleared and their numbers start again once.
    grid_map = LogOddsMap(MappingConfig(initial_extent=6.0))
    logodds = np.zeros(grid_map.shape, np.float32)
    observed = np.zeros(grid_map.shape, bool)
    lidar = Lidar(LidarConfig(beams=120, max_range=2.5), generate_floorplan(3).walls)
    rng = np.random.default_rng(8)
    for _ in range(300):
        pose = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-3, 3)])
        scan = lidar.scan(pose, rng=rng)
        grid_map.update(pose, scan)
        assert grid_map.shape == logodds.shape  # the room never makes the grid grow
        ends, hit, _ = beam_ends(*pose, scan.angles, scan.ranges, scan.max_range, True)
        origin = grid_map.to_cells(pose[:2])[0]
        integrate_rays(
            logodds, observed, (origin[0], origin[1]), grid_map.to_cells(ends), hit,
            grid_map.config,
        )  # fmt: skip
    np.testing.assert_array_equal(grid_map.logodds, logodds)
    np.testing.assert_array_equal(grid_map.observed, observed)
    np.testing.assert_array_equal(grid_map.cells, ros_codes(logodds, observed))


def test_a_growing_map_journals_every_cell_it_observes_once() -> None:
    world = generate_floorplan(2)
    small = MappingConfig(initial_extent=4.0, growth_padding=0.0)  # grows often
    sim = Simulation(world, robots=1, config=SimulationConfig(mapping=small), rng=4)
    grid_map = sim.maps[0]
    grid_map.start_journal()
    before = sim.grid(0)
    journal = []
    for step in range(80):
        sim.step([[0.9, math.sin(step / 9)]])
        journal.append(grid_map.take_journal())
    after = sim.grid(0)
    assert after.shape != before.shape  # the map grew while journalling
    cells = np.concatenate(journal)
    assert len(np.unique(cells, axis=0)) == len(cells)
    res = after.resolution
    lattice = {
        (round(after.origin[0] / res) + c, round(after.origin[1] / res) + r)
        for r, c in zip(*np.nonzero(after.data >= 0), strict=True)
    }
    old = {
        (round(before.origin[0] / res) + c, round(before.origin[1] / res) + r)
        for r, c in zip(*np.nonzero(before.data >= 0), strict=True)
    }
    assert {tuple(cell) for cell in cells.tolist()} == lattice - old
    np.testing.assert_array_equal(after.data, ros_codes(grid_map.logodds, grid_map.observed))


def numpy_crop(
    own: np.ndarray,
    own_anchor: tuple[int, int],
    layer: np.ndarray | None,
    layer_anchor: tuple[int, int],
    start: tuple[int, int],
    size: int,
    pool: int,
) -> np.ndarray:
    """The oracle: windows by slicing, own cells first, then a max over pool blocks."""

    def window(cells: np.ndarray, anchor: tuple[int, int]) -> np.ndarray:
        fine = size * pool
        out = np.full((fine, fine), UNKNOWN, np.int8)
        for r in range(fine):
            for c in range(fine):
                rr, cc = start[1] + r - anchor[1], start[0] + c - anchor[0]
                if 0 <= rr < cells.shape[0] and 0 <= cc < cells.shape[1]:
                    out[r, c] = cells[rr, cc]
        return out

    cells = window(own, own_anchor)
    if layer is not None:
        np.copyto(cells, window(layer, layer_anchor), where=cells < 0)
    return cells.reshape(size, pool, size, pool).max(axis=(1, 3))


@pytest.mark.parametrize("pool", [2, 3])  # 2, the default, has a loop of its own
@pytest.mark.parametrize("with_layer", [False, True])
def test_crop_kernel_matches_numpy_windows(with_layer: bool, pool: int) -> None:
    rng = np.random.default_rng(7)
    own = rng.choice(
        np.array([-1, 0, 10, 50, 100], np.int8), size=(40, 50), p=[0.5, 0.2, 0.1, 0.1, 0.1]
    )
    layer = rng.choice(np.array([-1, 0, 100], np.int8), size=(30, 30)) if with_layer else None
    # Windows partly off the grid, inside it across the layer's edge, off both, inside
    # both, and inside the grid beside the layer.
    for start in [(-5, -7), (10, 12), (40, 30), (-40, -40), (21, 16), (3, 0)]:
        expected = numpy_crop(own, (3, -2), layer, (20, 15), start, 8, pool)
        ours = crop_max_pool(
            own, 3, -2, layer if layer is not None else np.zeros((0, 0), np.int8), 20, 15,
            start[0], start[1], 8, pool,
        )  # fmt: skip
        np.testing.assert_array_equal(ours, expected)


def test_beam_cells_in_32_bits_are_the_64_bit_ones() -> None:
    rng = np.random.default_rng(12)
    cols = 517
    for _ in range(200):
        samples = int(rng.integers(1, 300))
        step = rng.uniform(-1, 1, 2).astype(np.float32)
        offset = rng.uniform(300, 320, 2).astype(np.float32)
        wide, narrow = np.zeros(samples, np.int64), np.zeros(samples, np.int32)
        beam_cells(step[0], step[1], offset[0], offset[1], samples, cols, wide)
        beam_cells_narrow(step[0], step[1], offset[0], offset[1], samples, np.int32(cols), narrow)
        np.testing.assert_array_equal(narrow, wide)


@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_saturated_run_finds_the_first_cell_not_saturated(dtype: type) -> None:
    rng = np.random.default_rng(13)
    stamp = np.where(rng.random(5000) < 0.97, SATURATED | 5, 5).astype(np.uint8)
    for samples in [*range(0, 20), 50, 123]:  # runs ending in and after a chunk of 8
        for _ in range(20):
            beam = rng.integers(0, len(stamp), samples).astype(dtype)
            not_saturated = np.flatnonzero(stamp[beam] < SATURATED)
            expected = int(not_saturated[0]) if len(not_saturated) else samples
            assert saturated_run(stamp, beam, samples) == expected


def test_log_odds_kernel_refuses_scratch_memory_too_small_for_the_scan() -> None:
    config = MappingConfig()
    shape = (90, 120)
    origin, ends, hit = random_scan(np.random.default_rng(3), shape, 90)
    logodds = np.zeros(shape, np.float32)
    with pytest.raises(ValueError, match="scratch memory is too small"):
        integrate_scan(
            logodds, np.zeros(shape, bool), np.full(shape, UNKNOWN, np.int8),
            np.zeros(shape, np.uint8), 1, origin[0], origin[1], ends, hit,
            config.log_odds_hit, config.log_odds_miss, config.log_odds_min, config.log_odds_max,
            SAMPLE_STEP_CELLS, HIT_DEPTH_CELLS, CODE_THRESHOLDS, np.zeros(10, np.int64),
        )  # fmt: skip
    assert not np.any(logodds)  # refused before it changed anything


def test_truth_under_finds_the_first_of_each_key_and_counts_them() -> None:
    rng = np.random.default_rng(14)
    keys = np.sort(rng.integers(0, 400, 300))  # repeated keys, and gaps
    table = first_of_keys(keys)
    assert table.shape == (keys[-1] + 1,)
    cells = rng.integers(-5, 30, (500, 2))  # some off the keys' lattice on either side
    starts = np.empty(500, np.int64)
    total = truth_under_table(cells, 2, 3, 20, keys, table, starts)
    expected_starts, expected_total = [], 0
    for a, b in cells:
        key = (b - 3) * 20 + (a - 2)
        hits = np.flatnonzero(keys == key) if 0 <= a - 2 < 20 else np.zeros(0, np.int64)
        expected_starts.append(hits[0] if len(hits) else -1)
        expected_total += len(hits)
    np.testing.assert_array_equal(starts, expected_starts)
    assert total == expected_total > 0
    assert np.count_nonzero(starts >= 0) > 50  # many cells found, many not
    assert first_of_keys(np.zeros(0, np.int64)).shape == (0,)


def test_turn_remainder_is_the_modulo_bit_for_bit() -> None:
    rng = np.random.default_rng(15)
    edges = [0.0, -0.0, TWO_PI, -TWO_PI, math.pi, -math.pi, 1e-300, -1e-300]
    edges += [float(np.nextafter(e, d)) for e in (TWO_PI, -TWO_PI, 0.0) for d in (-9, 9)]
    for angle in [*edges, *rng.uniform(-20, 20, 2000), *rng.uniform(-1e-9, 1e-9, 100)]:
        assert np.float64(turn_remainder(angle)).tobytes() == np.float64(angle % TWO_PI).tobytes()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_shared_free_kernel_matches_the_numpy_count(seed: int) -> None:
    from tomosim.frames import pose_matrix
    from tomosim.kernels.overlap import shared_free
    from tomosim.team.quality import shared_free_numpy

    generator = np.random.default_rng(seed)
    codes = np.array([UNKNOWN, 0, 10, 19, 20, 65, 100], dtype=np.int8)
    first = generator.choice(codes, size=(70, 90))
    second = generator.choice(codes, size=(60, 50))
    for _ in range(20):
        pose = (generator.uniform(-30, 60), generator.uniform(-30, 50), generator.uniform(-4, 4))
        matrix = pose_matrix(pose)
        assert shared_free(first, second, matrix) == shared_free_numpy(first, second, matrix)
    # Centres landing exactly half way between cells round to the even one, as np.rint.
    half = pose_matrix((10.5, 3.5, 0.0))
    assert shared_free(first, second, half) == shared_free_numpy(first, second, half)


@pytest.mark.parametrize("factor", [1, 2, 3, 5])
def test_block_states_kernel_matches_the_numpy_coarsening(factor: int) -> None:
    from tomosim.exploration.frontiers import coarsen
    from tomosim.kernels.planning import block_states

    generator = np.random.default_rng(factor)
    codes = np.array([UNKNOWN, 0, 10, 19, 20, 40, 64, 65, 100], dtype=np.int8)
    # Shapes that are and are not whole blocks, and a grid of mostly one state: blocks
    # of unknown cells only, of free cells only and of a lone wall cell among free ones.
    grids = [generator.choice(codes, size=shape) for shape in ((31, 47), (30, 45), (1, 7))]
    sparse = np.full((40, 50), UNKNOWN, dtype=np.int8)
    sparse[10:30, 5:45] = 0
    sparse[17, 20] = 100
    grids.append(sparse)
    for cells in grids:
        for free_below, occupied_from in ((20, 65), (50, 50), (70, 30)):
            expected = coarsen(cells, factor, free_below=free_below, occupied_from=occupied_from)
            found = block_states(cells, factor, free_below, occupied_from)
            assert found.dtype == expected.dtype
            np.testing.assert_array_equal(found, expected)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wall_distances_kernel_matches_scipy_to_the_bit(seed: int) -> None:
    from scipy import ndimage

    from tomosim.kernels.planning import distances_to_walls

    generator = np.random.default_rng(seed)
    # Dense and sparse walls, one wall cell, a single row and a single column, and grids
    # whose columns mostly hold no wall (their cells are reached along the rows only).
    masks = [generator.random((37, 53)) < share for share in (0.5, 0.05, 0.002)]
    lone = np.zeros((29, 41), dtype=bool)
    lone[generator.integers(29), generator.integers(41)] = True
    masks += [lone, generator.random((1, 30)) < 0.2, generator.random((30, 1)) < 0.2]
    for occupied in masks:
        if not occupied.any():
            occupied[0, 0] = True
        expected = ndimage.distance_transform_edt(~occupied)
        assert distances_to_walls(occupied).tobytes() == expected.tobytes()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_frontier_groups_kernel_matches_the_labelled_clusters(seed: int) -> None:
    from tomosim.exploration.frontiers import frontier_clusters
    from tomosim.kernels.planning import frontier_groups

    generator = np.random.default_rng(seed)
    # Grids of every mix of unknown, free and occupied cells, from a single row or column
    # up; clusters touching the edges, merging late (a U shape) and crossing diagonally.
    states = [
        generator.choice(np.arange(3, dtype=np.uint8), size=shape, p=generator.dirichlet([1] * 3))
        for shape in [(1, 25), (25, 1), *(tuple(generator.integers(2, 40, 2)) for _ in range(60))]
    ]
    u_shape = np.zeros((9, 9), dtype=np.uint8)
    u_shape[1:8, 1] = u_shape[7, 1:8] = u_shape[1:8, 7] = 1
    diagonal = np.zeros((6, 6), dtype=np.uint8)
    diagonal[np.arange(6), np.arange(6)] = 1
    states += [u_shape, diagonal]
    for state in states:
        cells, starts = frontier_groups(state)
        expected = frontier_clusters(state)
        assert len(starts) - 1 == len(expected)
        for first, last, cluster in zip(starts[:-1], starts[1:], expected, strict=True):
            assert cluster.size == last - first
            assert cells.dtype == cluster.cells.dtype
            np.testing.assert_array_equal(cells[first:last], cluster.cells)
