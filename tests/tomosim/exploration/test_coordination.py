"""Coordinated exploration: target choosers, teammates in a robot's frame, the team explorer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from merging.grid import OccupancyGrid
from tomosim.exploration import (
    Candidate,
    FrontierPolicy,
    TeamExplorer,
    Teammate,
    chooser_names,
    make_chooser,
)
from tomosim.exploration.assignment import AssignmentChooser, claimed_cluster
from tomosim.exploration.utility import utilities, visibility
from tomosim.frames import pose_matrix
from tomosim.team import TeamConfig, TeamSession
from tomosim.worlds import generate_floorplan

RESOLUTION = 0.05
"""Metres per cell of the synthetic corridor."""
CORRIDOR = (10.0, 2.0)
"""Length and width (metres) of the corridor whose two open ends are its frontiers."""
END_TOLERANCE_M = 0.5
"""A target this close to an end of the corridor is at that end's frontier."""


def corridor() -> OccupancyGrid:
    """A known free corridor along x in [0, 10] m, walls along its sides, unknown beyond
    both ends: exactly two frontiers, at x = 0 and x = 10."""
    length, width = CORRIDOR
    rows, cols = round((width + 2.0) / RESOLUTION), round((length + 4.0) / RESOLUTION)
    cells = np.full((rows, cols), -1, dtype=np.int8)
    c0, c1 = round(2.0 / RESOLUTION), round((length + 2.0) / RESOLUTION)
    r0, r1 = round(1.0 / RESOLUTION), round((width + 1.0) / RESOLUTION)
    cells[r0:r1, c0:c1] = 0
    cells[r0 - 2 : r0, c0:c1] = 100
    cells[r1 : r1 + 2, c0:c1] = 100
    return OccupancyGrid(cells, resolution=RESOLUTION, origin=(-2.0, -1.0, 0.0))


def end_of(target: np.ndarray | None) -> str:
    """Which end of the corridor a target lies at."""
    assert target is not None
    if abs(target[0] - 0.0) <= END_TOLERANCE_M:
        return "left"
    if abs(target[0] - CORRIDOR[0]) <= END_TOLERANCE_M:
        return "right"
    raise AssertionError(f"target {target} is at neither end")


@pytest.mark.parametrize("policy", ["utility", "assignment"])
def test_two_robots_and_two_frontiers_get_different_targets(policy: str) -> None:
    grid = corridor()
    first, second = (2.0, 1.0, 0.0), (3.0, 1.0, 0.0)  # both nearer the left end
    lead = FrontierPolicy(chooser=policy)
    lead.act(first, grid)
    assert end_of(lead.target) == "left"
    told = Teammate(0, np.array(first[:2]), lead.target, lead.path_costs)
    follower = FrontierPolicy(chooser=policy)
    follower.act(second, grid, teammates=[told])
    assert end_of(follower.target) == "right"


def test_without_coordination_both_robots_take_the_nearer_frontier() -> None:
    grid = corridor()
    lead = FrontierPolicy(chooser="nearest")
    lead.act((2.0, 1.0, 0.0), grid)
    told = Teammate(0, np.array([2.0, 1.0]), lead.target, lead.path_costs)
    follower = FrontierPolicy(chooser="nearest")
    follower.act((3.0, 1.0, 0.0), grid, teammates=[told])
    assert end_of(lead.target) == end_of(follower.target) == "left"


@pytest.mark.parametrize("policy", chooser_names())
def test_a_robot_alone_chooses_as_the_nearest_policy(policy: str) -> None:
    world = generate_floorplan(4, width=15.0, height=10.0)
    session = TeamSession(world, robots=1, config=TeamConfig(merge=False), rng=2)
    grid, pose = session.best_map(0), session.simulation.odometry[0].pose
    alone = FrontierPolicy(chooser=policy)
    alone.act(pose, grid)
    nearest = FrontierPolicy(chooser="nearest")
    nearest.act(pose, grid)
    assert alone.target is not None
    np.testing.assert_array_equal(alone.target, nearest.target)


def test_a_nearer_teammate_takes_over_a_shared_target() -> None:
    grid = corridor()
    robot = FrontierPolicy(chooser="utility")
    robot.act((6.0, 1.0, 0.0), grid)
    assert end_of(robot.target) == "right"
    # A teammate already standing by the same frontier: the robot gives it up at its
    # next plan and turns to the other end.
    assert robot.target is not None
    mate = Teammate(1, np.array([9.0, 1.0]), robot.target.copy())
    for _ in range(robot.config.replan_interval):
        robot.act((6.0, 1.0, 0.0), grid, teammates=[mate])
    assert end_of(robot.target) == "left"


def test_visibility_falls_linearly_to_zero_at_the_radius() -> None:
    np.testing.assert_allclose(visibility([0.0, 1.5, 3.0, 4.0], 3.0), [1.0, 0.5, 0.0, 0.0])
    points = np.array([[0.0, 0.0], [1.0, 0.0], [10.0, 0.0]])
    targets = [np.array([0.0, 0.0]), np.array([2.0, 0.0])]
    # Each target takes P(d) off the utility of 1, so it can fall below 0 (section IV).
    np.testing.assert_allclose(utilities(points, targets, 4.0), [1 - 1 - 0.5, 1 - 0.75 - 0.75, 1])


def test_assignment_leaves_a_claimed_cluster_to_its_teammate() -> None:
    near = Candidate(np.zeros((1, 2), np.intp), np.array([[1.0, 0.0]]), np.array([1.0]), 1.0)
    far = Candidate(np.zeros((1, 2), np.intp), np.array([[9.0, 0.0]]), np.array([9.0]), 1.0)
    chooser = make_chooser("assignment")
    assert chooser.choose([near, far], [], size_bonus=0.5) == (0, 0)
    busy = Teammate(1, np.array([2.0, 0.0]), target=np.array([1.2, 0.1]))
    assert claimed_cluster([near, far], busy.target, radius=1.0) == 0  # type: ignore[arg-type]
    assert chooser.choose([near, far], [busy], size_bonus=0.5) == (1, 0)
    # The claim radius is the chooser's setting: within 0.1 m the target claims nothing.
    assert AssignmentChooser(claim_radius=0.1).choose([near, far], [busy], size_bonus=0.5) == (0, 0)
    # An idle teammate nearer to the near cluster takes it by cost; the robot the far one.
    idle = Teammate(1, np.array([0.5, 0.0]))
    assert chooser.choose([near, far], [idle], size_bonus=0.5) == (1, 0)
    # A teammate busy on a frontier the robot does not see is left out.
    away = Teammate(1, np.array([0.5, 0.0]), target=np.array([50.0, 50.0]))
    assert chooser.choose([near, far], [away], size_bonus=0.5) == (0, 0)


def test_unknown_policy_names_the_choices() -> None:
    with pytest.raises(ValueError, match="nearest, utility, assignment"):
        make_chooser("greedy")
    with pytest.raises(ValueError, match="unknown exploration policy"):
        TeamExplorer(2, policy="greedy")


def test_teammates_reach_a_robot_through_its_links_only() -> None:
    world = generate_floorplan(4, width=15.0, height=10.0)
    session = TeamSession(world, robots=3, config=TeamConfig(merge=False), rng=5)
    explorer = TeamExplorer(3, policy="utility")
    explorer.act(session)
    assert explorer.teammates(session, 0) == []  # linked to nobody: alone
    starts = session.simulation.start_poses
    truth = np.linalg.inv(pose_matrix(starts[0])) @ pose_matrix(starts[2])
    session.shared.set_links(0, {2: truth})
    mates = explorer.teammates(session, 0)
    assert [m.robot for m in mates] == [2]
    # Robot 2's pose estimate and target, carried into robot 0's frame by the link.
    pose = session.simulation.odometry[2].pose
    np.testing.assert_allclose(mates[0].position, (truth @ [pose[0], pose[1], 1.0])[:2])
    target = explorer.policies[2].target
    assert target is not None and mates[0].target is not None
    np.testing.assert_allclose(mates[0].target, (truth @ [*target, 1.0])[:2])
    # Its path costs answer in robot 0's frame: at its own position, nearly nothing.
    cost = mates[0].path_costs(mates[0].position[None])  # type: ignore[misc]
    assert math.isfinite(cost[0]) and cost[0] < 0.5
