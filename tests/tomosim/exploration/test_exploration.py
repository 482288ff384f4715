"""Exploration: frontiers, planning, path following, and a whole exploration run."""

from __future__ import annotations

import numpy as np
import pytest

from merging.grid import OccupancyGrid
from tomosim.evaluation import coverage
from tomosim.exploration import (
    ControllerConfig,
    FrontierPolicy,
    PathFollower,
    PlannerConfig,
    Wavefront,
    coarsen,
    frontier_clusters,
    frontier_mask,
    planning_grid,
)
from tomosim.exploration.frontiers import FREE_CELL, OCCUPIED_CELL, UNKNOWN_CELL
from tomosim.frames import place_grid, pose_matrix
from tomosim.ray_geometry import distance_to_segments
from tomosim.simulation import Simulation
from tomosim.worlds import generate_floorplan

SMALL_BUDGET = 1500
"""Steps (150 s simulated) in which one robot explores a 15 m x 10 m floor."""
SMALL_COVERAGE = 0.9
DEFAULT_BUDGET = 3000
"""Steps (300 s simulated) in which one robot explores the default 30 m x 20 m floor."""
DEFAULT_COVERAGE = 0.85
WALL_OVERLAP = 0.06
"""Metres a robot may touch into a wall on impact (a quarter radius plus slop);
the policy should not even come close, so this only catches real collisions."""


def test_coarsen_keeps_walls_and_known_space() -> None:
    cells = np.full((4, 6), -1, dtype=np.int8)
    cells[0, 0] = 100  # one occupied cell makes its block occupied
    cells[0, 1] = 0
    cells[2, 2] = 0  # one free cell makes its block free
    cells[3, 5] = 50  # undecided cells are unknown
    state = coarsen(cells, 2)
    np.testing.assert_array_equal(
        state,
        [[OCCUPIED_CELL, UNKNOWN_CELL, UNKNOWN_CELL], [UNKNOWN_CELL, FREE_CELL, UNKNOWN_CELL]],
    )


def test_frontiers_are_free_cells_beside_unknown_ones() -> None:
    state = np.full((7, 7), UNKNOWN_CELL, dtype=np.uint8)
    state[1:6, 1:6] = FREE_CELL
    state[1:6, 1] = OCCUPIED_CELL  # a wall on the left
    mask = frontier_mask(state)
    expected = np.zeros((7, 7), dtype=bool)
    expected[1, 2:6] = expected[5, 2:6] = expected[1:6, 5] = True
    np.testing.assert_array_equal(mask, expected)
    clusters = frontier_clusters(state, min_size=1)
    assert [c.size for c in clusters] == [11]  # 4 + 4 + 5, two corners shared
    rows, cols = np.nonzero(expected)
    assert {tuple(c) for c in clusters[0].cells} == set(zip(cols, rows, strict=True))  # (x, y)
    assert frontier_clusters(state, min_size=12) == []


def test_wavefront_costs_are_path_lengths_and_paths_avoid_walls() -> None:
    occupied = np.zeros((60, 100), dtype=bool)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    occupied[:45, 50] = True  # a wall with a gap at the top
    grid = OccupancyGrid.from_bool(occupied, resolution=0.05)
    config = PlannerConfig(resolution=0.1, wall_penalty=0.0)
    planning = planning_grid(grid, config)
    start = (10, 10)  # (x, y)
    wave = Wavefront(planning, start)
    # Straight along a free row: one unit per planning cell.
    assert wave.costs(np.array([[20, 10]]))[0] == pytest.approx(10.0)
    # Behind the wall, the path must go round through the gap.
    goal = (40, 10)
    path = wave.path(goal)
    points = planning.to_frame(path)
    assert np.all(points[:, 1] >= 0.0)
    assert np.max(points[:, 1]) > 45 * 0.05  # through the gap above the wall
    wall = np.array([[[2.5, 0.0], [2.5, 2.25]]])
    assert np.all(distance_to_segments(points, wall) >= config.robot_radius)
    assert wave.costs(np.array([goal]))[0] > 30.0


def test_inflation_blocks_gaps_narrower_than_the_robot() -> None:
    occupied = np.zeros((40, 80), dtype=bool)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    occupied[:, 40] = True
    occupied[18:24, 40] = False  # a 0.3 m slit, narrower than a 0.4 m robot
    planning = planning_grid(OccupancyGrid.from_bool(occupied, resolution=0.05), PlannerConfig())
    wave = Wavefront(planning, (5, 10))  # (x, y)
    assert np.isinf(wave.costs(np.array([[30, 10]]))[0])
    assert np.isfinite(wave.costs(np.array([[15, 10]]))[0])


def test_follower_turns_towards_and_drives_along_its_path() -> None:
    follower = PathFollower(ControllerConfig())
    follower.set_path(np.column_stack([np.linspace(0, 3, 31), np.zeros(31)]))
    linear, angular = follower.command((0.0, 0.0, 0.0))
    assert linear > 0.5 and angular == pytest.approx(0.0)
    linear, angular = follower.command((0.0, 0.0, np.pi / 2))  # facing left of the path
    assert linear == 0.0 and angular < 0
    assert follower.done((2.9, 0.0, 0.0))


def test_place_grid_moves_the_grid_with_its_frame() -> None:
    grid = OccupancyGrid(np.zeros((3, 4), dtype=np.int8), resolution=0.5, origin=(1.0, 0.0, 0.0))
    pose = np.array([2.0, -1.0, np.pi / 2])
    placed = place_grid(grid, pose_matrix(pose))
    corner = placed.cell_to_world([[0, 0]])[0]
    expected = pose_matrix(pose) @ np.array([*grid.cell_to_world([[0, 0]])[0], 1.0])
    np.testing.assert_allclose(corner, expected[:2], atol=1e-12)


def run_exploration(
    world_seed: int, budget: int, *, width: float = 30.0, height: float = 20.0
) -> tuple[float, int, float]:
    """Explore with one robot; returns (coverage, steps used, closest approach to a wall)."""
    world = generate_floorplan(world_seed, width=width, height=height)
    sim = Simulation(world, robots=1, rng=world_seed)
    policy = FrontierPolicy()
    closest = np.inf
    steps = 0
    while steps < budget:
        steps += 1
        command = policy.act(sim.odometry_poses[0], sim.grid(0), scan=sim.scans[0])
        sim.step(command[None])
        closest = min(closest, float(distance_to_segments(sim.true_poses[:, :2], world.walls)[0]))
        if policy.finished:
            break
    return coverage(world, sim.grid(0), sim.start_poses[0]), steps, closest


@pytest.mark.slow
def test_one_robot_explores_a_small_floor() -> None:
    explored, _steps, closest = run_exploration(3, SMALL_BUDGET, width=15.0, height=10.0)
    assert explored >= SMALL_COVERAGE
    assert closest >= 0.2 - WALL_OVERLAP


@pytest.mark.slow
def test_one_robot_explores_most_of_the_default_floor() -> None:
    explored, _steps, closest = run_exploration(0, DEFAULT_BUDGET)
    assert explored >= DEFAULT_COVERAGE
    assert closest >= 0.2 - WALL_OVERLAP


def test_policy_explores_the_map_it_is_given() -> None:
    world = generate_floorplan(6, width=15.0, height=10.0)
    sim = Simulation(world, robots=1, rng=0)
    own = FrontierPolicy()
    command = own.act(sim.odometry_poses[0], sim.grid(0), scan=sim.scans[0])
    assert not own.finished and np.any(command != 0)
    # A complete map (here the truth, placed in the robot's frame) leaves
    # nothing to explore: the policy stops.
    complete = place_grid(world.truth, np.linalg.inv(pose_matrix(sim.start_poses[0])))
    given = FrontierPolicy()
    command = given.act(sim.odometry_poses[0], complete, scan=sim.scans[0])
    assert given.finished
    np.testing.assert_array_equal(command, [0.0, 0.0])
