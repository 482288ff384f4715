"""The known-poses bound and limited communication."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from merging.grid import OccupancyGrid
from merging.params import DEFAULT_PARAMS
from tomosim.frames import frame_errors, pose_matrix
from tomosim.sweep import SweepPlan
from tomosim.team import (
    ORACLE,
    CommsConfig,
    SharedMaps,
    TeamConfig,
    TeamSession,
    check_team_method,
    in_range,
    oracle_estimator,
    reach_groups,
    true_relative,
)
from tomosim.team.comms import blocked
from tomosim.team.config import for_method, settings_for_other_methods
from tomosim.worlds import World, generate_floorplan

EXACT = 1e-9
"""Tolerance for results exact up to floating-point rounding."""
MERGE_INTERVAL = 5
"""Steps between merge rounds in the session tests: short, so that rounds come quickly."""


@pytest.fixture(scope="module")
def world() -> World:
    return generate_floorplan(3, width=12.0, height=9.0)


def run_session(world: World, config: TeamConfig, steps: int, *, robots: int = 3) -> TeamSession:
    """A session whose robots turn on the spot for ``steps`` steps (their maps grow)."""
    session = TeamSession(world, robots=robots, config=config, rng=4)
    for _ in range(steps):
        session.step(np.tile([0.0, 0.5], (robots, 1)))
    return session


def test_the_oracles_transforms_equal_the_truth(world: World) -> None:
    config = TeamConfig(method=ORACLE, merge_interval=MERGE_INTERVAL)
    session = run_session(world, config, 2 * MERGE_INTERVAL)
    starts = session.simulation.start_poses
    scored, merge = session.last_quality, session.last_merge
    assert scored is not None and merge is not None and merge.method == ORACLE
    for pair in merge.pairs:
        truth = true_relative(starts[pair.first], starts[pair.second])
        assert pair.accepted and pair.confirmed and pair.result.confidence == 1.0
        np.testing.assert_allclose(pair.result.matrix_metres, truth, atol=EXACT)
        # The cell matrix is the same transform between the two grids' cells.
        grids = session.grids()
        cells = (
            grids[pair.first].cell_to_world_matrix()
            @ pair.result.matrix
            @ np.linalg.inv(grids[pair.second].cell_to_world_matrix())
        )
        np.testing.assert_allclose(cells, truth, atol=EXACT)
    assert all(p.rotation_error_deg < EXACT and p.translation_error_m < EXACT for p in scored.pairs)
    # Linked through the forest, every robot's frame lands exactly where the truth puts it.
    for k in range(session.count):
        for other in range(session.count):
            relative = merge.relative(k, other)
            assert relative is not None
            np.testing.assert_allclose(
                relative, true_relative(starts[k], starts[other]), atol=EXACT
            )


def test_an_oracle_with_an_error_is_off_by_exactly_that_error(world: World) -> None:
    config = TeamConfig(
        method=ORACLE, merge_interval=MERGE_INTERVAL, oracle_error_deg=0.4, oracle_error_m=0.1
    )
    session = run_session(world, config, 2 * MERGE_INTERVAL)
    scored = session.last_quality
    assert scored is not None
    for pair in scored.pairs:
        assert pair.rotation_error_deg == pytest.approx(0.4, abs=1e-6)
        assert pair.translation_error_m == pytest.approx(0.1, abs=1e-6)
    # Fixed per pair: a second run repeats it exactly, and the pairs' errors point
    # different ways.
    merge = session.last_merge
    assert merge is not None
    again = run_session(world, config, 2 * MERGE_INTERVAL).last_merge
    assert again is not None
    directions = set()
    for pair, repeated in zip(merge.pairs, again.pairs, strict=True):
        np.testing.assert_allclose(pair.result.matrix_metres, repeated.result.matrix_metres)
        starts = session.simulation.start_poses
        truth = true_relative(starts[pair.first], starts[pair.second])
        shift = pair.result.matrix_metres[:2, 2] - truth[:2, 2]
        directions.add(round(float(np.arctan2(shift[1], shift[0])), 3))
    assert len(directions) == len(merge.pairs)


def test_the_shared_free_area_counts_free_space_both_grids_know() -> None:
    from tomosim.team.quality import shared_free_area

    first = np.full((10, 10), -1, dtype=np.int8)
    first[2:6, 2:8] = 0  # 24 free cells
    first[4, 4] = 100  # one of them a wall
    second = np.full((10, 10), -1, dtype=np.int8)
    second[0:4, 0:10] = 0
    a = OccupancyGrid(first, resolution=0.5)
    b = OccupancyGrid(second, resolution=0.5)
    # Grid b's rows 0-3 laid on a's rows 2-5: a's free block less its wall cell.
    shift = pose_matrix((0.0, 2.0, 0.0))
    assert shared_free_area(a, b, shift) == pytest.approx(23 * 0.25)
    # Laid away from a's free block, they share nothing.
    assert shared_free_area(a, b, pose_matrix((0.0, 7.0, 0.0))) == 0.0
    for bad in (np.full((3, 3), np.nan), np.eye(2)):
        with pytest.raises(ValueError, match="cells must be a finite 3x3"):
            shared_free_area(a, b, bad)


def test_an_oracle_waiting_for_overlap_refuses_pairs_that_share_too_little(
    world: World,
) -> None:
    starts = np.array([[2.0, 2.0, 0.0], [9.0, 6.5, 1.0]])
    grid = np.full((40, 40), -1, dtype=np.int8)
    grid[:, :] = 0
    lone = OccupancyGrid(np.full((40, 40), -1, dtype=np.int8), resolution=0.1)
    seen = OccupancyGrid(grid, resolution=0.1)
    strict = oracle_estimator(starts, min_shared_m2=1.0)
    refused = strict(0, 1, seen, lone)
    assert not refused.accepted and refused.confidence == 0.0
    assert "0.00 m²" in refused.reason and "1 m²" in refused.reason
    # Its answer is still the truth, which a later round accepts once the maps overlap.
    plain = oracle_estimator(starts)(0, 1, seen, lone)
    np.testing.assert_allclose(refused.matrix, plain.matrix, atol=EXACT)
    # In a session, the pairs whose maps share enough are accepted and the others not;
    # a bound no pair reaches leaves every pair unlinked.
    config = TeamConfig(method=ORACLE, merge_interval=MERGE_INTERVAL, oracle_min_shared_m2=5.0)
    session = run_session(world, config, 2 * MERGE_INTERVAL)
    merge = session.last_merge
    assert merge is not None
    shared = [p.result.evidence["shared_free_m2"] for p in merge.pairs]
    accepted = [p.accepted for p in merge.pairs]
    assert accepted == [value >= 5.0 for value in shared] and any(accepted) and not all(accepted)
    never = TeamConfig(method=ORACLE, merge_interval=MERGE_INTERVAL, oracle_min_shared_m2=1e6)
    blocked_session = run_session(world, never, 2 * MERGE_INTERVAL)
    assert blocked_session.last_merge is not None
    assert not any(p.accepted for p in blocked_session.last_merge.pairs)
    with pytest.raises(ValueError, match="oracle_min_shared_m2"):
        TeamConfig(method=ORACLE, oracle_min_shared_m2=-1.0)


def test_the_oracles_error_is_validated() -> None:
    with pytest.raises(ValueError, match="oracle_error_m"):
        TeamConfig(method=ORACLE, oracle_error_m=-0.1)
    with pytest.raises(ValueError, match="error_deg"):
        oracle_estimator(np.zeros((2, 3)), error_deg=float("nan"))


def test_the_oracles_settings_are_carried_by_any_team_and_used_by_the_oracle_only() -> None:
    # A sweep over the merger and the oracle carries both's settings in one team.
    team = TeamConfig(oracle_error_deg=0.4, oracle_min_shared_m2=5.0)
    assert settings_for_other_methods(team, ["tomographic"]) == {
        "oracle_error_deg": ORACLE,
        "oracle_min_shared_m2": ORACLE,
    }
    assert settings_for_other_methods(team, ["tomographic", ORACLE]) == {}
    assert settings_for_other_methods(TeamConfig(), ["spectral"]) == {}


def test_a_sweeps_episode_keeps_only_its_own_methods_settings() -> None:
    margin = replace(DEFAULT_PARAMS, robust=replace(DEFAULT_PARAMS.robust, margin=0.2))
    team = TeamConfig(oracle_min_shared_m2=5.0, merger=margin, confirmations=3)
    plan = SweepPlan(methods=("tomographic", ORACLE, "none"), team=team)
    teams = {
        e.config.team.method if e.config.team.merge else "none": e.config.team
        for e in plan.episodes()
    }
    assert teams["tomographic"].merger == margin and teams["tomographic"].oracle_min_shared_m2 == 0
    assert teams[ORACLE].oracle_min_shared_m2 == 5.0 and teams[ORACLE].merger == DEFAULT_PARAMS
    assert teams["none"] == replace(TeamConfig(confirmations=3), merge=False)
    assert all(t.confirmations == 3 for t in teams.values())  # every method's settings stay
    assert for_method(team, ORACLE) == replace(team, method=ORACLE, merger=DEFAULT_PARAMS)


def test_the_oracle_needs_start_poses_and_is_a_team_method() -> None:
    with pytest.raises(ValueError, match="starts must be"):
        oracle_estimator(np.zeros((2, 2)))
    assert check_team_method(ORACLE) == ORACLE
    with pytest.raises(ValueError, match="oracle"):
        check_team_method("crystal-ball")


def test_a_wall_between_two_robots_blocks_the_line_of_sight() -> None:
    wall = np.array([[[1.0, -1.0], [1.0, 1.0]]])
    starts, ends = (
        np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 2.0]]),
        np.array([[2.0, 0.0], [0.5, 0.0], [2.0, 2.0]]),
    )
    np.testing.assert_array_equal(blocked(starts, ends, wall), [True, False, False])
    # A robot standing at the wall's end point is not cut off by it ...
    assert not blocked([[0.0, 1.0]], [[1.0, 1.0]], wall)[0]
    # ... but a sight line through a wall's end point is blocked: at a corner where two
    # walls meet, nothing passes between them.
    corner = np.array([[[1.0, -1.0], [1.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]]])
    assert blocked([[0.0, 1.0]], [[2.0, -1.0]], corner)[0]
    assert blocked([[0.0, 2.0]], [[2.0, 0.0]], wall)[0]  # through its end point (1, 1)


def test_robots_reach_each_other_through_teammates_in_range() -> None:
    positions = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 0.0], [30.0, 0.0]])
    groups = reach_groups(in_range(positions, CommsConfig(6.0)))
    assert groups[0] == groups[1] == groups[2] != groups[3]  # 0 and 2 talk through 1
    assert len(set(reach_groups(in_range(positions, CommsConfig())))) == 1
    wall = np.array([[[2.5, -1.0], [2.5, 1.0]]])
    sight = reach_groups(in_range(positions, CommsConfig(6.0, line_of_sight=True), wall))
    assert sight[0] != sight[1] and sight[1] == sight[2] != sight[3]


def test_comms_config_is_validated() -> None:
    with pytest.raises(ValueError, match="positive number of metres"):
        CommsConfig(-1.0)
    with pytest.raises(ValueError, match="needs a communication range"):
        CommsConfig(line_of_sight=True)


def test_robots_out_of_range_share_nothing(world: World) -> None:
    # Robots start at least 0.8 m apart and turn on the spot: a 0.5 m range reaches nobody.
    config = TeamConfig(method=ORACLE, merge_interval=MERGE_INTERVAL, comms=CommsConfig(0.5))
    session = run_session(world, config, 3 * MERGE_INTERVAL)
    merge = session.last_merge
    assert merge is not None
    assert not any(p.accepted for p in merge.pairs)
    assert all("out of communication reach" in p.result.reason for p in merge.pairs)
    for k in range(session.count):
        assert session.contacts(k) == {} and session.shared.teammates(k) == ()
        best, own = session.best_map(k), session.grids()[k]
        assert best is own  # nothing from anyone
    # The same robots in range of each other link every map.
    linked = run_session(world, TeamConfig(method=ORACLE, merge_interval=MERGE_INTERVAL),
                         3 * MERGE_INTERVAL)  # fmt: skip
    assert all(len(linked.contacts(k)) == linked.count - 1 for k in range(linked.count))


def grid_with(cells: list[tuple[int, int]]) -> OccupancyGrid:
    """A 20 x 20 grid at 0.05 m, unknown but for free ``(row, col)`` cells."""
    data = np.full((20, 20), -1, dtype=np.int8)
    for row, col in cells:
        data[row, col] = 0
    return OccupancyGrid(data, resolution=0.05)


def test_a_robot_keeps_what_it_received_from_a_teammate_out_of_reach() -> None:
    shared = SharedMaps(2, refresh_interval=1)
    shared.set_links(0, {1: np.eye(3)})
    mine = grid_with([(0, 0)])
    shared.refresh(1, [mine, grid_with([(5, 5)])], reach=[0, 0])
    # Robot 1 maps more while out of reach: robot 0 still sees the map it received.
    shared.refresh(2, [mine, grid_with([(5, 5), (9, 9)])], reach=[0, 1])
    best = shared.best_grid(0, [mine, mine])
    assert best.data[5, 5] == 0 and best.data[9, 9] == -1
    # A merge round while out of reach keeps the link it cannot re-examine.
    shared.link(None, reach=[0, 1])
    assert shared.teammates(0) == (1,)
    shared.link(None, reach=[0, 0])  # in reach, and the round did not link them: dropped
    assert shared.teammates(0) == ()


def test_teammates_poses_reach_a_robot_only_while_it_reaches_them(world: World) -> None:
    config = TeamConfig(method=ORACLE, merge_interval=MERGE_INTERVAL)
    session = run_session(world, config, 2 * MERGE_INTERVAL)
    assert set(session.contacts(0)) == {1, 2}
    session.reach = np.array([0, 0, 1])  # robot 2 drives out of reach
    assert set(session.contacts(0)) == {1}
    starts = session.simulation.start_poses
    into_0 = session.contacts(0)[1]
    rotation, translation = frame_errors(into_0, true_relative(starts[0], starts[1]))
    assert rotation < EXACT and translation < EXACT
    assert np.allclose(pose_matrix(starts[0]) @ into_0, pose_matrix(starts[1]))
