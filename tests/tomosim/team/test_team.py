"""Team merging: truth of relative transforms, confirmation, shared maps, team coverage."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from merging.grid import UNKNOWN, OccupancyGrid
from merging.result import MergeResult
from tomosim.evaluation import coverage, known_in_world
from tomosim.frames import place_grid, pose_matrix
from tomosim.simulation import Simulation
from tomosim.team import (
    ORACLE,
    SharedMaps,
    TeamConfig,
    TeamCoverage,
    TeamMerger,
    TeamSession,
    TrackingParams,
    frame_errors,
    score_round,
    teammate_layer,
    true_relative,
)
from tomosim.team.merger import HELD_ONLY
from tomosim.worlds import World, generate_floorplan
from tomosim.worlds.from_map import world_from_grid

SMALL_FLOOR = {"width": 12.0, "height": 9.0}
"""A floor small enough for quick tests: a few rooms and a corridor."""
EXACT = 1e-9
"""Tolerance for results that are exact up to floating-point rounding."""
MERGE_ROTATION_DEG = 0.5
"""Degrees: error allowed to a merge of two noise-free views of the truth (cells
resampled to the nearest cell cost a fraction of a cell, a few hundredths of a degree
over a 10 m map)."""
MERGE_TRANSLATION_M = 0.1
"""Metres: same, two cells."""


@pytest.fixture(scope="module")
def world() -> World:
    return generate_floorplan(3, **SMALL_FLOOR)


def robot_view(world: World, start: np.ndarray, extent: float = 5.0) -> OccupancyGrid:
    """The truth seen from ``start``: a grid on the robot's lattice, ``extent`` metres around it.

    Each cell takes the truth value under its centre (nearest truth cell), as a
    robot with perfect odometry and sensing would map it.
    """
    res = world.resolution
    side = round(2 * extent / res)
    a0 = b0 = -side // 2
    cols, rows = np.meshgrid(np.arange(side), np.arange(side))
    local = np.stack([(a0 + cols + 0.5) * res, (b0 + rows + 0.5) * res, np.ones_like(cols, float)])
    world_points = np.tensordot(pose_matrix(start), local, axes=1)[:2].reshape(2, -1).T
    cells = np.rint(world.truth.world_to_cell(world_points)).astype(int)
    t_rows, t_cols = world.truth.shape
    inside = (
        (cells[:, 0] >= 0) & (cells[:, 0] < t_cols) & (cells[:, 1] >= 0) & (cells[:, 1] < t_rows)
    )
    data = np.full(side * side, UNKNOWN, dtype=np.int8)
    data[inside] = world.truth.data[cells[inside, 1], cells[inside, 0]]
    return OccupancyGrid(data.reshape(side, side), resolution=res, origin=(a0 * res, b0 * res, 0.0))


def test_true_relative_places_the_second_start_in_the_first_frame() -> None:
    start_i, start_j = np.array([1.0, 2.0, 0.3]), np.array([4.0, -1.0, 1.2])
    matrix = true_relative(start_i, start_j)
    c, s = math.cos(-0.3), math.sin(-0.3)
    expected = np.array([[c, -s], [s, c]]) @ (start_j[:2] - start_i[:2])
    np.testing.assert_allclose(matrix[:2, 2], expected, atol=EXACT)
    assert math.atan2(matrix[1, 0], matrix[0, 0]) == pytest.approx(0.9, abs=EXACT)


def test_frame_errors_measure_rotation_and_start_displacement() -> None:
    truth = pose_matrix((2.0, -1.0, 3.1))
    estimate = pose_matrix((2.3, -1.4, 3.1 + math.radians(1.5) - 2 * math.pi))
    rotation, translation = frame_errors(estimate, truth)
    assert rotation == pytest.approx(1.5, abs=1e-9)
    assert translation == pytest.approx(0.5, abs=EXACT)
    assert frame_errors(np.full((3, 3), np.nan), truth) == (math.inf, math.inf)


def fake_result(pose: tuple[float, float, float], *, accepted: bool) -> MergeResult:
    metres = pose_matrix(pose)
    return MergeResult(np.eye(3), 0.7 if accepted else 0.1, accepted, "fake", metres)


def test_confirmation_needs_consecutive_consistent_acceptances() -> None:
    merger = TeamMerger(TeamConfig(confirmations=2), rng=0)
    pair = (0, 1)
    assert merger.confirm(pair, fake_result((1.0, 2.0, 0.5), accepted=True)) == 1
    assert merger.confirm(pair, fake_result((1.1, 2.0, 0.51), accepted=True)) == 2
    # A jump of 10 degrees is a different match: the run starts again.
    assert merger.confirm(pair, fake_result((1.1, 2.0, 0.51 + 0.17), accepted=True)) == 1
    assert merger.confirm(pair, fake_result((1.1, 2.0, 0.68), accepted=False)) == 0
    assert merger.confirm(pair, fake_result((1.1, 2.0, 0.68), accepted=True)) == 1


def test_an_estimate_held_only_at_the_keeping_threshold_confirms_nothing() -> None:
    merger = TeamMerger(TeamConfig(confirmations=2), rng=0)
    pair = (0, 1)
    held = replace(fake_result((1.0, 2.0, 0.5), accepted=True), evidence={HELD_ONLY: 1.0})
    assert merger.confirm(pair, fake_result((1.0, 2.0, 0.5), accepted=True)) == 1
    assert merger.confirm(pair, held) == 1  # the run is held, not lengthened
    assert merger.confirm(pair, fake_result((1.0, 2.0, 0.5), accepted=True)) == 2
    assert merger.confirm(pair, held) == 2  # a confirmed link stays confirmed
    jumped = replace(held, matrix_metres=pose_matrix((4.0, 2.0, 0.5)))
    assert merger.confirm(pair, jumped) == 1  # a different placement starts a new run
    # With no run to keep (a round refused the pair), it starts one, as any accepted one.
    assert merger.confirm(pair, replace(held, accepted=False)) == 0
    assert merger.confirm(pair, held) == 1


def test_only_a_confident_estimate_of_its_own_skips_the_second_round() -> None:
    sure = replace(fake_result((1.0, 2.0, 0.5), accepted=True), confidence=0.9)
    held = replace(sure, evidence={HELD_ONLY: 1.0})  # a kept track, not a new placement
    refused = replace(sure, accepted=False)
    merger = TeamMerger(TeamConfig(confirm_at_once_confidence=0.85), rng=0)
    assert merger.confident(sure)
    assert not merger.confident(held) and not merger.confident(refused)
    assert not merger.confident(replace(sure, confidence=0.84))
    assert not TeamMerger(TeamConfig(confirm_at_once_confidence=None), rng=0).confident(sure)


def test_a_link_made_at_once_is_kept_by_the_rounds_that_hold_it() -> None:
    """A confident estimate counts as a whole run: the next round's estimate held only at
    the keeping threshold keeps the link, as it keeps one confirmed round by round."""
    merger = TeamMerger(TeamConfig(confirmations=2, confirm_at_once_confidence=0.85), rng=0)
    pair = (0, 1)
    sure = replace(fake_result((1.0, 2.0, 0.5), accepted=True), confidence=0.9)
    held = replace(sure, confidence=0.55, evidence={HELD_ONLY: 1.0})
    assert merger.confirm(pair, sure) == 2
    assert merger.confirm(pair, held) == 2
    assert merger.confirm(pair, replace(held, evidence={})) == 3
    jumped = replace(held, matrix_metres=pose_matrix((4.0, 2.0, 0.5)))
    assert merger.confirm(pair, jumped) == 1  # a different placement starts again
    waiting = TeamMerger(TeamConfig(confirmations=2, confirm_at_once_confidence=None), rng=0)
    assert [waiting.confirm(pair, result) for result in (sure, held)] == [1, 1]


def test_the_confirmation_tolerances_are_team_settings() -> None:
    # The same half-degree step confirms within 3 degrees and starts again within 0.1.
    steps = [
        fake_result((1.0, 2.0, 0.5), accepted=True),
        fake_result((1.0, 2.0, 0.51), accepted=True),
    ]
    for tolerance, runs in ((3.0, [1, 2]), (0.1, [1, 1])):
        merger = TeamMerger(TeamConfig(confirm_rotation_deg=tolerance), rng=0)
        assert [merger.confirm((0, 1), result) for result in steps] == runs
    moved = [
        fake_result((1.0, 2.0, 0.5), accepted=True),
        fake_result((1.3, 2.0, 0.5), accepted=True),
    ]
    merger = TeamMerger(TeamConfig(confirm_translation_m=0.2), rng=0)
    assert [merger.confirm((0, 1), result) for result in moved] == [1, 1]


def test_merge_round_scores_views_of_the_truth(world: World) -> None:
    """Two noise-free views of one room: the accepted estimate matches the true transform."""
    starts = np.array([[3.2, 2.4, 0.4], [4.4, 3.1, -2.2]])
    grids = [robot_view(world, start) for start in starts]
    merger = TeamMerger(TeamConfig(merge_interval=1, confirmations=1), rng=0)
    merge = merger.merge(1, grids)
    scored = score_round(merge, grids, starts, world.truth)
    (pair,) = scored.pairs
    assert pair.accepted and pair.confirmed and pair.used
    assert pair.rotation_error_deg < MERGE_ROTATION_DEG
    assert pair.translation_error_m < MERGE_TRANSLATION_M
    np.testing.assert_allclose(pair.truth[:2], true_relative(*starts)[:2, 2], atol=EXACT)
    assert merge.groups == (0, 0) and merge.merged_robots == (0, 1)
    relative = merge.relative(0, 1)
    assert relative is not None
    assert frame_errors(relative, true_relative(*starts))[0] < MERGE_ROTATION_DEG
    assert scored.agreement > 0.95


def test_unconfirmed_estimates_do_not_link_maps(world: World) -> None:
    starts = np.array([[3.2, 2.4, 0.4], [4.4, 3.1, -2.2]])
    grids = [robot_view(world, start) for start in starts]
    merger = TeamMerger(
        TeamConfig(merge_interval=1, confirmations=2, confirm_at_once_confidence=None), rng=0
    )
    first = merger.merge(1, grids)
    assert first.pairs[0].accepted and not first.pairs[0].confirmed
    assert not first.linked(0) and first.relative(0, 1) is None
    second = merger.merge(2, grids)
    assert second.pairs[0].confirmed and second.linked(1)


def test_a_confident_estimate_links_maps_at_once_and_a_doubtful_one_waits(world: World) -> None:
    starts = np.array([[3.2, 2.4, 0.4], [4.4, 3.1, -2.2], [6.0, 5.0, 1.0]])
    grids = [robot_view(world, start) for start in starts]
    confidences = {(0, 1): 0.9, (0, 2): 0.7, (1, 2): 0.1}

    def estimator(i: int, j: int, first: OccupancyGrid, second: OccupancyGrid) -> MergeResult:
        metres = true_relative(starts[i], starts[j])
        cells = np.linalg.inv(first.cell_to_world_matrix()) @ metres @ second.cell_to_world_matrix()
        confidence = confidences[(i, j)]
        return MergeResult(cells, confidence, confidence > 0.5, "fixed confidences", metres)

    config = TeamConfig(merge_interval=1, confirmations=2, confirm_at_once_confidence=0.85)
    merger = TeamMerger(config, estimator=estimator)
    first = merger.merge(1, grids)
    assert [p.confirmed for p in first.pairs] == [True, False, False]
    assert first.linked(1) and not first.linked(2)
    second = merger.merge(2, grids)
    assert [p.confirmed for p in second.pairs] == [True, True, False]
    assert second.linked(2)


def test_a_pair_estimator_replaces_the_merging_method(world: World) -> None:
    """The hook sees each pair once as (i, j), i < j, and its answers link the maps."""
    starts = np.array([[3.2, 2.4, 0.4], [4.4, 3.1, -2.2], [6.0, 5.0, 1.0]])
    grids = [robot_view(world, start) for start in starts]
    asked = []

    def truth_estimator(i: int, j: int, first: OccupancyGrid, second: OccupancyGrid):
        asked.append((i, j))
        metres = true_relative(starts[i], starts[j])
        cells = np.linalg.inv(first.cell_to_world_matrix()) @ metres @ second.cell_to_world_matrix()
        return MergeResult(cells, 1.0, True, "truth", metres)

    merger = TeamMerger(TeamConfig(method=ORACLE, confirmations=1), estimator=truth_estimator)
    merge = merger.merge(1, grids)
    assert asked == [(0, 1), (0, 2), (1, 2)]
    assert merge.merged_robots == (0, 1, 2) and len(merge.linking.tree) == 2
    for k in (1, 2):
        relative = merge.relative(0, k)
        assert relative is not None
        np.testing.assert_allclose(relative, true_relative(starts[0], starts[k]), atol=EXACT)


def test_rounds_come_sooner_while_the_maps_are_not_all_linked_into_one(world: World) -> None:
    starts = np.array([[3.2, 2.4, 0.4], [4.4, 3.1, -2.2], [6.0, 5.0, 1.0]])
    grids = [robot_view(world, start) for start in starts]
    refused = {"pairs": {(0, 1), (0, 2), (1, 2)}}

    def estimator(i: int, j: int, first: OccupancyGrid, second: OccupancyGrid) -> MergeResult:
        metres = true_relative(starts[i], starts[j])
        cells = np.linalg.inv(first.cell_to_world_matrix()) @ metres @ second.cell_to_world_matrix()
        return MergeResult(cells, 1.0, (i, j) not in refused["pairs"], "truth", metres)

    config = TeamConfig(method=ORACLE, merge_interval=20, unlinked_merge_interval=5,
                        confirmations=1)  # fmt: skip
    merger = TeamMerger(config, estimator=estimator)
    assert merger.interval == 5 and merger.due(5) and not merger.due(7)  # before any round
    merger.merge(5, grids)
    assert merger.interval == 5
    refused["pairs"] = {(0, 2), (1, 2)}  # robot 2 stays alone
    merger.merge(10, grids)
    assert merger.interval == 5 and merger.due(15)
    refused["pairs"] = set()
    merger.merge(15, grids)
    assert merger.interval == 20 and not merger.due(25) and merger.due(40)
    # Between regular rounds, a round runs only when it could change something.
    twice = TeamConfig(method=ORACLE, merge_interval=20, unlinked_merge_interval=5,
                       confirm_at_once_confidence=None)  # fmt: skip
    unlinked = TeamMerger(twice, estimator=estimator, round_wanted=lambda grids: False)
    refused["pairs"] = {(0, 1), (0, 2), (1, 2)}
    assert unlinked.due(5) and not unlinked.due(5, lambda: grids)  # without grids: it runs
    unlinked.merge(5, grids)
    assert not unlinked.due(10, lambda: grids) and unlinked.due(20, lambda: grids)
    refused["pairs"] = {(0, 2), (1, 2)}
    unlinked.merge(20, grids)  # (0, 1) accepted once: its confirmation is due
    assert unlinked.due(25, lambda: grids)
    unlinked.merge(25, grids)  # confirmed; robot 2 is still alone, with nothing to do
    assert not unlinked.due(30, lambda: grids) and unlinked.due(40, lambda: grids)
    # A pair linked at once by a confident estimate awaits nothing.
    at_once = TeamMerger(replace(twice, confirm_at_once_confidence=0.85), estimator=estimator,
                         round_wanted=lambda grids: False)  # fmt: skip
    refused["pairs"] = {(0, 2), (1, 2)}
    assert at_once.merge(20, grids).pairs[0].confirmed
    assert not at_once.due(25, lambda: grids)
    # Never shorter than merge_interval, and one robot alone has nobody to link to.
    assert TeamMerger(TeamConfig(merge_interval=4)).interval == 4
    alone = TeamMerger(TeamConfig(merge_interval=20))
    alone.merge(10, grids[:1])
    assert alone.interval == 20


def lattice_grid(
    rng: np.random.Generator, shape: tuple[int, int], anchor: tuple[int, int]
) -> OccupancyGrid:
    data = rng.choice(np.array([UNKNOWN, 0, 10, 100], np.int8), size=shape)
    return OccupancyGrid(data, resolution=0.05, origin=(anchor[0] * 0.05, anchor[1] * 0.05, 0.0))


def test_teammate_layer_carries_a_quarter_turn_exactly() -> None:
    """A teammate whose frame is the robot's turned by 90 degrees: the layer is its grid
    turned back, cell for cell (a quarter turn maps the lattice onto itself)."""
    rng = np.random.default_rng(5)
    mate = lattice_grid(rng, (30, 40), (-7, 4))
    # Lattice cell (a, b) of the teammate is at ((a + .5) r, (b + .5) r); turned by +90
    # degrees it lands on cell (-b - 1, a) of the robot's lattice.
    into_robot = pose_matrix((0.0, 0.0, math.pi / 2))
    layer = teammate_layer([mate], [into_robot], 0.05)
    assert layer is not None
    cells, anchor = layer
    rows, cols = mate.shape
    for r in range(rows):
        for c in range(cols):
            a, b = -7 + c, 4 + r
            target = (-b - 1 - anchor[0], a - anchor[1])
            if mate.data[r, c] >= 0:
                assert cells[target[1], target[0]] == mate.data[r, c]


def test_best_map_keeps_own_cells_and_fills_the_rest_from_teammates() -> None:
    rng = np.random.default_rng(6)
    own = lattice_grid(rng, (20, 20), (0, 0))
    mate = lattice_grid(rng, (20, 20), (5, 3))
    shared = SharedMaps(2, refresh_interval=1)
    shared.set_links(0, {1: np.eye(3)})  # the teammate's frame is the robot's
    shared.refresh(1, [own, mate])
    best = shared.best_grid(0, [own, mate])
    assert best.origin == (0.0, 0.0, 0.0)
    expected = np.full((23, 25), UNKNOWN, np.int8)
    expected[3:, 5:] = mate.data
    window = expected[:20, :20]
    np.copyto(window, own.data, where=own.data >= 0)
    np.testing.assert_array_equal(best.data, expected)
    # A free cell of the robot's own stays free under a teammate's wall.
    clash = (own.data[3:, 5:] == 0) & (mate.data[:17, :15] == 100)
    assert np.any(clash)
    assert np.all(best.data[3:20, 5:20][clash] == 0)
    assert shared.best_grid(1, [own, mate]) is mate  # robot 1 links to nobody


def test_shared_maps_are_due_when_a_linked_robots_layer_is() -> None:
    rng = np.random.default_rng(6)
    grids = [lattice_grid(rng, (20, 20), (0, 0)) for _ in range(3)]
    shared = SharedMaps(3, refresh_interval=10)
    assert not shared.due(0) and not shared.due(10**6)  # nobody linked
    shared.set_links(0, {1: np.eye(3)})
    assert shared.due(0)  # a new link's layer is built at the next refresh
    shared.refresh(4, grids)
    assert not shared.due(13) and shared.due(14)
    shared.set_links(2, {1: np.eye(3)})
    assert shared.due(5)
    shared.refresh(7, grids)  # robot 2's layer now; robot 0's is not due before 14
    assert not shared.due(13) and shared.due(14)
    shared.set_links(0, {})
    assert not shared.due(16) and shared.due(17)


def test_crop_is_centred_and_pools_by_maximum() -> None:
    data = np.full((40, 40), UNKNOWN, np.int8)
    data[20, 20] = 0  # the robot's cell, free
    data[10, 11] = 100  # one wall cell among unknown ones
    grid = OccupancyGrid(data, resolution=0.05, origin=(-1.0, -1.0, 0.0))
    shared = SharedMaps(1, refresh_interval=TeamConfig().share_interval)
    # Position (0.01, 0.01) m lies in lattice cell (0, 0), which is grid cell (20, 20).
    crop = shared.crop(0, [grid], (0.01, 0.01), size=8, pool=2)
    assert crop.shape == (8, 8)
    assert crop[4, 4] == 0
    # The wall, grid cell (col 11, row 10), is lattice cell (-9, -10): outside the window
    # of lattice cells [-8, 8) of this crop, inside the window [-16, 16) of a wider one,
    # where it is fine cell (7, 6) and so crop cell (3, 3).
    assert not np.any(crop == 100)
    wide = shared.crop(0, [grid], (0.01, 0.01), size=16, pool=2)
    assert wide[3, 3] == 100  # occupied beats unknown when pooling
    assert np.count_nonzero(wide >= 0) == 2


@pytest.mark.parametrize("incremental", [True, False])
def test_team_coverage_matches_the_evaluation_rule(world: World, incremental: bool) -> None:
    sim = Simulation(world, robots=2, rng=11)
    cover = TeamCoverage(world, sim.start_poses, resolution=sim.config.mapping.resolution)
    previous = float(cover.update([sim.grid(k) for k in range(2)]).sum())
    for grid_map in sim.maps:
        grid_map.start_journal()
    total_area = previous
    commands = np.array([[0.8, 0.3], [0.6, -0.4]])
    for _ in range(25):
        sim.step(commands)
        journals = [grid_map.take_journal() for grid_map in sim.maps]
        if incremental:
            gained = cover.reveal(journals)
        else:
            gained = cover.update([sim.grid(k) for k in range(2)])
        total_area += float(gained.sum())
        area = cover.fraction * cover.total * cover.cell_area
        assert cover.fraction == np.count_nonzero(cover.team_known) / cover.total  # kept count
        assert float(gained.sum()) == pytest.approx(area - previous, abs=1e-9)
        previous = area
    grids = [sim.grid(k) for k in range(2)]
    for k in range(2):
        assert cover.robot_fraction(k) == pytest.approx(
            coverage(world, grids[k], sim.start_poses[k]), abs=EXACT
        )
    assert cover.robot_fractions().tolist() == [cover.robot_fraction(k) for k in range(2)]
    union = known_in_world(world, grids[0], sim.start_poses[0]) | known_in_world(
        world, grids[1], sim.start_poses[1]
    )
    np.testing.assert_array_equal(cover.known_mask(), union & world.explorable)
    assert total_area == pytest.approx(previous, abs=1e-9)


def test_session_merges_on_schedule_and_repeats_with_its_seed(world: World) -> None:
    config = TeamConfig(merge_interval=10)
    runs = []
    for _ in range(2):
        session = TeamSession(world, robots=2, config=config, rng=4)
        steps = []
        for step in range(25):
            turn = math.sin(step / 5)
            if session.step([[0.7, turn], [0.7, -turn]]) is not None:
                steps.append(session.steps)
        runs.append((steps, session.coverage.fraction, session.simulation.true_poses))
    assert runs[0][0] == [10, 20]
    assert runs[0][1] == runs[1][1]
    np.testing.assert_array_equal(runs[0][2], runs[1][2])
    quiet = TeamSession(world, robots=2, config=TeamConfig(merge=False), rng=4)
    assert all(quiet.step([[0.5, 0.0], [0.5, 0.0]]) is None for _ in range(12))
    assert quiet.merger is None and quiet.best_map(0) is quiet.grids()[0]


def test_best_crops_are_each_robots_best_crop(world: World) -> None:
    # Oracle merges link the maps at the first round, so the crops take teammates' cells.
    session = TeamSession(
        world, robots=3, config=TeamConfig(method=ORACLE, merge_interval=5), rng=2
    )
    for step in range(12):
        session.step([[0.8, math.sin(step)], [0.6, 0.5], [0.7, -0.4]])
    assert all(session.linked(k) for k in range(3))
    crops = np.full((3, 16, 16), 7, np.int8)
    session.best_crops(crops, pool=2)
    for k in range(3):
        np.testing.assert_array_equal(crops[k], session.best_crop(k, size=16, pool=2))
    wide = np.empty((3, 8, 8), np.int8)
    session.best_crops(wide, pool=3)
    np.testing.assert_array_equal(wide[1], session.best_crop(1, size=8, pool=3))


def test_config_rejects_bad_values() -> None:
    with pytest.raises(ValueError, match="unknown merging method 'nope'"):
        TeamConfig(method="nope")
    with pytest.raises(ValueError, match="merge_interval"):
        TeamConfig(merge_interval=0)
    with pytest.raises(ValueError, match="confirmations must be a whole number of rounds >= 1"):
        TeamConfig(confirmations=0)
    with pytest.raises(ValueError, match="merge must be True or False, got 'no'"):
        TeamConfig(merge="no")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="comms must be a CommsConfig"):
        TeamConfig(comms=5.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="keep_confidence must be a number in"):
        TrackingParams(keep_confidence=1.5)
    with pytest.raises(ValueError, match="unlinked_merge_interval must be a whole number"):
        TeamConfig(unlinked_merge_interval=0)
    with pytest.raises(ValueError, match="search_unlinked_at_once must be True or False"):
        TrackingParams(search_unlinked_at_once="yes")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="config must be a TeamConfig"):
        TeamSession(generate_floorplan(4), robots=2, config="fast")  # type: ignore[arg-type]


def test_team_coverage_refuses_grids_of_another_resolution() -> None:
    # A 0.1 m grid counted on a 0.05 m lattice scored a quarter of what it knew.
    world = generate_floorplan(4)
    coarse = OccupancyGrid(
        world.truth.data[::2, ::2].copy(), resolution=0.1, origin=world.truth.origin
    )
    counted = TeamCoverage(world, [(0.0, 0.0, 0.0)], resolution=0.05)
    with pytest.raises(ValueError, match=r"grid 0 is at 0\.1 m a cell"):
        counted.update([coarse])
    right = TeamCoverage(world, [(0.0, 0.0, 0.0)], resolution=0.1)
    right.update([coarse])
    assert right.fraction > 0.95


def test_team_coverage_refuses_a_world_no_grid_can_hold_naming_its_size() -> None:
    # A 60 x 80 map saved at 1e6 m a cell once failed with numpy's "array is too big".
    cells = np.zeros((60, 80), dtype=np.int8)
    cells[[0, -1], :] = cells[:, [0, -1]] = 100
    world = world_from_grid(OccupancyGrid(cells, resolution=1e6))
    with pytest.raises(ValueError, match=r"the world is 8e\+07 m x 6e\+07 m.*resolution"):
        TeamCoverage(world, [(1e6, 1e6, 0.0)], resolution=0.05)


@pytest.mark.parametrize("matrix", [np.diag([2.0, 2.0, 1.0]), np.diag([1.0, -1.0, 1.0])])
def test_placing_a_grid_refuses_a_matrix_that_scales_or_mirrors(matrix) -> None:
    grid = OccupancyGrid(np.zeros((4, 4), dtype=np.int8), resolution=0.05)
    with pytest.raises(ValueError, match="must be rigid"):
        place_grid(grid, matrix)
    moved = place_grid(grid, pose_matrix((1.0, 2.0, 0.5)))
    assert moved.origin == pytest.approx((1.0, 2.0, 0.5))


def test_pairs_are_listed_by_their_robots_numbers() -> None:
    # With ten robots or more, text order put r0-r10 before r0-r2.
    from tomosim.commands.explore_report import summarise_pairs
    from tomosim.team import pair_order

    names = ["r0-r10", "r10-r11", "r0-r2", "r1-r2", "odd"]
    assert sorted(names, key=pair_order) == ["r0-r2", "r0-r10", "r1-r2", "r10-r11", "odd"]
    rows = [(name, True, True, 0.1, 0.01) for name in names[:4]]
    assert [p.name for p in summarise_pairs(rows)] == ["r0-r2", "r0-r10", "r1-r2", "r10-r11"]
