"""Log-odds mapping: the inverse sensor model, growth, export, and a mapped world."""

from __future__ import annotations

import numpy as np
import pytest

from merging.evaluation.metrics import acceptance_index
from merging.grid import OccupancyGrid
from tomosim.lidar import Lidar, LidarConfig, Scan
from tomosim.mapping import LogOddsMap, MappingConfig, integrate_rays, update_maps
from tomosim.worlds import world_from_map


def cell_of(grid: OccupancyGrid, point: tuple[float, float]) -> tuple[int, int]:
    """``(row, col)`` of the cell holding ``point`` (a point on a boundary goes up/right,
    as the mapping kernel rounds)."""
    x, y = np.floor(grid.world_to_cell([point])[0] + 0.5).astype(int)
    return int(y), int(x)


def fresh(shape: tuple[int, int] = (20, 30)) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(shape, dtype=np.float32), np.zeros(shape, dtype=bool)


def test_one_beam_frees_the_cells_before_its_hit_and_marks_the_hit() -> None:
    config = MappingConfig()
    logodds, observed = fresh()
    # A surface on the boundary between cells 11 and 12 marks cell 12.
    integrate_rays(logodds, observed, (2.0, 5.0), np.array([[11.5, 5.0]]), np.array([True]), config)
    row = logodds[5]
    np.testing.assert_allclose(row[2:12], config.log_odds_miss)
    assert row[12] == pytest.approx(config.log_odds_hit)
    assert np.count_nonzero(logodds) == 11
    np.testing.assert_array_equal(observed, logodds != 0)


def test_beam_without_return_only_frees() -> None:
    config = MappingConfig()
    logodds, observed = fresh()
    integrate_rays(
        logodds, observed, (2.0, 5.0), np.array([[11.5, 5.0]]), np.array([False]), config
    )
    assert np.all(logodds[5, 2:12] < 0)
    assert logodds[5, 12] == 0 and not observed[5, 12]


def test_a_cell_is_updated_once_per_scan_and_a_hit_wins() -> None:
    config = MappingConfig()
    logodds, observed = fresh()
    # Three beams share the cells near the origin; the third ends where the
    # first passes through, which must end up hit, not hit-and-passed.
    ends = np.array([[11.5, 5.0], [11.5, 5.0], [6.5, 5.0]])
    integrate_rays(logodds, observed, (2.0, 5.0), ends, np.array([True, True, True]), config)
    np.testing.assert_allclose(logodds[5, 2:7], config.log_odds_miss)
    assert logodds[5, 7] == pytest.approx(config.log_odds_hit)
    np.testing.assert_allclose(logodds[5, 8:12], config.log_odds_miss)
    assert logodds[5, 12] == pytest.approx(config.log_odds_hit)


def test_log_odds_are_clamped() -> None:
    config = MappingConfig()
    logodds, observed = fresh()
    for _ in range(50):
        integrate_rays(
            logodds, observed, (2.0, 5.0), np.array([[11.5, 5.0]]), np.array([True]), config
        )
    assert logodds[5, 12] == pytest.approx(config.log_odds_max)
    assert logodds[5, 2] == pytest.approx(config.log_odds_min)


def test_export_uses_the_ros_coding() -> None:
    config = MappingConfig(initial_extent=4.0)
    grid_map = LogOddsMap(config)
    scan = Scan(np.array([0.0]), np.array([1.0]), 5.0)
    grid_map.update((0.0, 0.0, 0.0), scan)
    once = grid_map.to_occupancy_grid()
    assert once.data[cell_of(once, (1.0, 0.0))] >= 65  # one hit is enough for occupied
    passed = cell_of(once, (0.5, 0.0))
    assert 19 < once.data[passed] < 65  # one pass is not yet free
    for _ in range(3):
        grid_map.update((0.0, 0.0, 0.0), scan)
    assert grid_map.to_occupancy_grid().data[passed] <= 19  # four passes are
    assert once.data[cell_of(once, (-1.0, -1.0))] == -1


def test_grid_grows_and_keeps_cells_in_place() -> None:
    config = MappingConfig(initial_extent=4.0, growth_padding=1.0)
    grid_map = LogOddsMap(config)
    scan = Scan(np.array([0.0]), np.array([1.0]), 5.0)
    grid_map.update((0.0, 0.0, 0.0), scan)
    before = grid_map.to_occupancy_grid()
    shape = grid_map.shape
    grid_map.update((-6.01, -7.0, np.pi / 2), scan)  # far outside the first allocation
    after = grid_map.to_occupancy_grid()
    assert grid_map.shape[0] > shape[0] and grid_map.shape[1] > shape[1]
    # The origin moved by whole cells and the first hit is where it was: the
    # surface at x = 1 m marks the cell spanning [1.0, 1.05] m.
    steps = np.asarray(after.origin[:2]) / config.resolution
    np.testing.assert_allclose(steps, np.rint(steps), atol=1e-9)
    for grid in (before, after):
        assert grid.data[cell_of(grid, (1.025, 0.01))] >= 65
    assert after.data[cell_of(after, (-6.01, -5.975))] >= 65
    # Grid cell centres lie at integer multiples of the resolution plus a half.
    assert after.cell_to_world([[0, 0]])[0] == pytest.approx(
        np.asarray(after.origin[:2]) + 0.5 * config.resolution
    )


def test_dropouts_change_nothing() -> None:
    grid_map = LogOddsMap(MappingConfig(initial_extent=4.0))
    grid_map.update((0.0, 0.0, 0.0), Scan(np.zeros(3), np.full(3, np.nan), 5.0))
    assert not np.any(grid_map.observed)


def test_mapping_a_room_from_known_poses_reproduces_it() -> None:
    occupied = np.zeros((100, 140), dtype=bool)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    occupied[30:70, 60:64] = True  # a pillar
    truth = OccupancyGrid.from_bool(occupied, resolution=0.05)
    world = world_from_map(truth)
    lidar = Lidar(LidarConfig(range_noise_std=0.0, dropout_probability=0.0), world.walls)
    grid_map = LogOddsMap(MappingConfig())
    rng = np.random.default_rng(0)
    for x, y in [(1.0, 1.0), (5.5, 1.0), (5.5, 4.0), (1.0, 4.0), (3.0, 0.8), (3.0, 4.2)]:
        # The map frame is the world frame here: the robot "starts" at the origin.
        grid_map.update((x, y, 0.0), lidar.scan((x, y, 0.0), rng=rng))
    mapped = grid_map.to_occupancy_grid()
    # Carry the map's cells into the truth grid: both frames agree, so the
    # matrix is a shift by the origins, in cells.
    shift = (np.asarray(mapped.origin[:2]) - np.asarray(truth.origin[:2])) / 0.05
    matrix = np.array([[1.0, 0.0, shift[0]], [0.0, 1.0, shift[1]], [0.0, 0.0, 1.0]])
    index = acceptance_index(truth.data, mapped.data, matrix)
    assert index > 0.98
    assert np.count_nonzero(mapped.data >= 0) > 0.8 * truth.data.size


def test_config_is_validated() -> None:
    with pytest.raises(ValueError, match="log_odds_hit"):
        MappingConfig(log_odds_hit=-1.0)
    with pytest.raises(ValueError, match="resolution"):
        MappingConfig(resolution=0.0)
    with pytest.raises(ValueError, match="pose"):
        LogOddsMap().update((np.nan, 0.0, 0.0), Scan(np.zeros(1), np.ones(1), 5.0))


@pytest.mark.parametrize(
    "settings",
    [
        {"log_odds_max": float("inf")},  # would switch the clamp off
        {"log_odds_min": -float("inf")},
        {"initial_extent": float("inf")},
        {"growth_padding": float("nan")},
    ],
)
def test_config_refuses_values_that_are_not_finite(settings: dict[str, float]) -> None:
    with pytest.raises(ValueError, match=f"{next(iter(settings))} must be a finite number"):
        MappingConfig(**settings)


def test_config_refuses_a_grid_no_memory_holds() -> None:
    # 5000 given as cells, not metres: 100000 cells a side at 0.05 m.
    with pytest.raises(ValueError, match=r"initial_extent of 5000\.0 m is 100000 cells"):
        MappingConfig(initial_extent=5000.0)
    with pytest.raises(
        TypeError, match=r"resolution must be a positive number of metres, got '0\.05'"
    ):
        MappingConfig(resolution="0.05")  # type: ignore[arg-type]
    assert MappingConfig(resolution=np.float32(0.1)).resolution == np.float32(0.1)


def test_hits_at_the_edge_of_the_grid_grow_it_first() -> None:
    config = MappingConfig(initial_extent=2.0, growth_padding=0.0)
    grid_map = LogOddsMap(config)
    rng = np.random.default_rng(3)
    angles = np.linspace(-np.pi, np.pi, 90, endpoint=False)
    for _ in range(100):
        pose = rng.uniform(-3.0, 3.0, 3)
        ranges = rng.uniform(0.0, 4.0, len(angles))
        grid_map.update(pose, Scan(angles, ranges, 5.0))
        # Every end point's hit cell lies on the grid (no index error above).
        grid = grid_map.to_occupancy_grid()
        ends = pose[:2] + ranges[:, None] * np.column_stack(
            [np.cos(pose[2] + angles), np.sin(pose[2] + angles)]
        )
        cells = np.floor(grid.world_to_cell(ends) + 0.5).astype(int)
        assert np.all(cells >= 0) and np.all(cells < grid.shape[::-1])


@pytest.mark.parametrize(
    ("angles", "ranges", "max_range", "match"),
    [
        (2, np.full(2000, 3.0), 8.0, "one angle per range"),  # read past the angles
        (8, np.full(8, np.inf), np.nan, "max_range must be a positive number of metres"),
        (8, np.full(8, np.inf), np.inf, "max_range must be a positive number of metres"),
        (None, np.full(8, 3.0), 8.0, "angle of a scan must be finite"),
        (8, np.full(8, -1.0), 8.0, "within \\[0, max_range\\]"),
        (8, np.full(8, 1e30), 8.0, "within \\[0, max_range\\]"),
    ],
)
def test_a_scan_that_does_not_add_up_is_refused(angles, ranges, max_range, match) -> None:
    # Each of these crashed the interpreter, drew beams at numbers past the end of
    # the angles, or failed deep inside with an unreadable error.
    beams = LidarConfig(beams=8).angles()
    angles = np.full(8, np.nan) if angles is None else beams[:angles]
    grid_map = LogOddsMap()
    with pytest.raises(ValueError, match=match):
        grid_map.update((0.0, 0.0, 0.0), Scan(angles, ranges, max_range))
    assert not grid_map.observed.any()


def test_updating_a_team_s_maps_at_once_equals_updating_each() -> None:
    occupied = np.zeros((42, 62), dtype=bool)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    world = world_from_map(OccupancyGrid.from_bool(occupied, resolution=0.1))
    lidar = Lidar(LidarConfig(beams=90, max_range=3.0), world.walls)
    config = MappingConfig(initial_extent=2.0, growth_padding=0.5)  # grows on the way
    together = [LogOddsMap(config) for _ in range(3)]
    alone = [LogOddsMap(config) for _ in range(3)]
    for grid_map in together + alone:
        grid_map.start_journal()
    rng = np.random.default_rng(2)
    for _ in range(40):
        poses = np.column_stack(
            [rng.uniform(1.0, 5.0, 3), rng.uniform(1.0, 3.0, 3), rng.uniform(-3.0, 3.0, 3)]
        )
        ranges = np.stack([lidar.scan(pose, rng=rng).ranges for pose in poses])
        update_maps(together, poses, lidar.angles, ranges, lidar.config.max_range)
        for grid_map, pose, row in zip(alone, poses, ranges, strict=True):
            grid_map.update(pose, Scan(lidar.angles, row, lidar.config.max_range))
    for ours, theirs in zip(together, alone, strict=True):
        assert ours.shape != (40, 40)  # the maps grew
        np.testing.assert_array_equal(ours.logodds, theirs.logodds)
        np.testing.assert_array_equal(ours.cells, theirs.cells)
        np.testing.assert_array_equal(ours.take_journal(), theirs.take_journal())


def test_updating_a_team_s_maps_refuses_rows_that_do_not_match() -> None:
    maps = [LogOddsMap(), LogOddsMap()]
    angles = np.linspace(-np.pi, np.pi, 8, endpoint=False)
    ranges = np.ones((2, 8))
    with pytest.raises(ValueError, match=r"shape \(2, 3\), got \(1, 3\)"):
        update_maps(maps, np.zeros((1, 3)), angles, ranges, 8.0)
    with pytest.raises(ValueError, match="poses must be finite"):
        update_maps(maps, np.full((2, 3), np.nan), angles, ranges, 8.0)
    with pytest.raises(ValueError, match="one row per map"):
        update_maps(maps, np.zeros((2, 3)), angles, ranges[:1], 8.0)
    with pytest.raises(ValueError, match="one angle per range"):
        update_maps(maps, np.zeros((2, 3)), angles[:5], ranges, 8.0)
