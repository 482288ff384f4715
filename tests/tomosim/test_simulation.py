"""The simulation: determinism, frames, odometry drift, robots seeing each other."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from merging.evaluation.metrics import acceptance_index, matching_index
from merging.grid import OccupancyGrid
from tomosim.evaluation import coverage, known_in_world
from tomosim.frames import place_grid, pose_matrix
from tomosim.odometry import Odometry, OdometryConfig, compose, relative_motion
from tomosim.physics import PhysicsConfig
from tomosim.simulation import Simulation, SimulationConfig
from tomosim.worlds import World, generate_floorplan

NOISELESS = SimulationConfig(
    odometry=OdometryConfig(translation_noise=0.0, rotation_noise=0.0, drift_per_metre=0.0)
)


@pytest.fixture(scope="module")
def world() -> World:
    return generate_floorplan(21, width=15.0, height=10.0)


def drive(sim: Simulation, steps: int, seed: int) -> None:
    """Smooth random driving."""
    rng = np.random.default_rng(seed)
    commands = np.zeros((sim.count, 2))
    for step in range(steps):
        if step % 10 == 0:
            commands = np.column_stack(
                [rng.uniform(0.2, 1.0, sim.count), rng.uniform(-1.0, 1.0, sim.count)]
            )
        sim.step(commands)


def test_same_seed_gives_the_same_run(world: World) -> None:
    runs = []
    for _ in range(2):
        sim = Simulation(world, robots=3, rng=7)
        drive(sim, 60, seed=1)
        runs.append(sim)
    a, b = runs
    np.testing.assert_array_equal(a.true_poses, b.true_poses)
    np.testing.assert_array_equal(a.odometry_poses, b.odometry_poses)
    for i in range(3):
        np.testing.assert_array_equal(a.scans[i].ranges, b.scans[i].ranges)
        np.testing.assert_array_equal(a.grid(i).data, b.grid(i).data)
    other = Simulation(world, robots=3, rng=8)
    drive(other, 60, seed=1)
    assert not np.array_equal(other.true_poses, a.true_poses)


def test_random_start_poses_are_free_and_apart(world: World) -> None:
    sim = Simulation(world, robots=4, rng=3)
    start = sim.start_poses
    assert start.shape == (4, 3)
    radius = sim.config.physics.robot_radius
    assert np.all(world.clearance_at(start[:, :2]) >= radius)
    gaps = np.hypot(*(start[:, None, :2] - start[None, :, :2]).transpose(2, 0, 1))
    assert np.min(gaps[np.triu_indices(4, 1)]) >= 4 * radius
    np.testing.assert_array_equal(sim.odometry_poses, np.zeros((4, 3)))


def test_noiseless_odometry_is_the_true_motion_in_the_start_frame(world: World) -> None:
    sim = Simulation(world, robots=2, config=NOISELESS, rng=2)
    drive(sim, 80, seed=4)
    for i in range(2):
        expected = relative_motion(sim.start_poses[i], sim.true_poses[i])
        np.testing.assert_allclose(sim.odometry_poses[i], expected, atol=1e-9)


def test_default_odometry_drifts_a_little(world: World) -> None:
    sim = Simulation(world, robots=1, rng=2)
    drive(sim, 150, seed=4)
    truth = relative_motion(sim.start_poses[0], sim.true_poses[0])
    error = np.hypot(*(sim.odometry_poses[0, :2] - truth[:2]))
    travelled = 150 * sim.config.dt * sim.config.physics.max_linear_speed
    assert 0.0 < error < 0.05 * travelled


def test_odometry_noise_scales_with_motion() -> None:
    config = OdometryConfig(translation_noise=0.1, rotation_noise=0.0, drift_per_metre=0.0)
    odometry = Odometry(config, (0.0, 0.0, 0.0), np.random.default_rng(0))
    errors = []
    for step in range(1, 2001):
        estimate = odometry.update((0.01 * step, 0.0, 0.0))
        errors.append(estimate[1])
    # 2000 steps of 1 cm with 10 % lateral noise: a random walk of sigma 1 mm per step
    # (heading stays exact): final lateral error ~ N(0, 1 mm * sqrt(2000)) = 4.5 cm.
    assert abs(errors[-1]) < 4 * 0.001 * np.sqrt(2000)
    still = Odometry(config, (1.0, 2.0, 0.3), np.random.default_rng(0))
    np.testing.assert_array_equal(still.update((1.0, 2.0, 0.3)), np.zeros(3))


def test_compose_inverts_relative_motion() -> None:
    a, b = np.array([1.0, -2.0, 2.5]), np.array([-0.5, 3.0, -2.9])
    np.testing.assert_allclose(compose(a, relative_motion(a, b)), b, atol=1e-12)


def test_odometry_update_is_the_noisy_relative_motion_composed() -> None:
    config = OdometryConfig(translation_noise=0.05, rotation_noise=0.02, drift_per_metre=0.01)
    rng = np.random.default_rng(3)
    path = np.cumsum(rng.normal(0.0, 0.1, (40, 3)), axis=0) + np.array([1.0, -2.0, 3.0])
    odometry = Odometry(config, path[0], np.random.default_rng(9))
    draws = np.random.default_rng(9)  # the same stream, for the array formulas
    pose = np.zeros(3)
    for before, after in itertools.pairwise(path):
        dx, dy, dtheta = relative_motion(before, after)
        distance = np.hypot(dx, dy)
        sigma = np.array([0.05 * distance, 0.05 * distance, 0.02 * abs(dtheta) + 0.01 * distance])
        pose = compose(pose, np.array([dx, dy, dtheta]) + sigma * draws.standard_normal(3))
        np.testing.assert_array_equal(odometry.update(after), pose)  # the same numbers


def test_maps_are_in_each_robots_start_frame(world: World) -> None:
    sim = Simulation(world, robots=2, config=NOISELESS, rng=5)
    drive(sim, 100, seed=2)
    truth = world.truth
    for i in range(2):
        grid = sim.grid(i)
        # Placed in the world by the true start pose, the map lines up with the truth.
        in_world = place_grid(grid, pose_matrix(sim.start_poses[i]))
        cells_to_truth = (
            np.linalg.inv(truth.cell_to_world_matrix()) @ in_world.cell_to_world_matrix()
        )
        assert acceptance_index(truth.data, grid.data, cells_to_truth) > 0.95
        assert matching_index(truth.data, grid.data, cells_to_truth) > 0.6  # 0.72 measured
        # Placed with a heading 3 degrees off, its walls miss the true ones.
        wrong = pose_matrix(sim.start_poses[i] + np.array([0.0, 0.0, 0.05]))
        wrong_cells = (
            np.linalg.inv(truth.cell_to_world_matrix())
            @ place_grid(grid, wrong).cell_to_world_matrix()
        )
        assert matching_index(truth.data, grid.data, wrong_cells) < 0.4  # 0.29 measured
        assert 0.0 < coverage(world, grid, sim.start_poses[i]) < 1.0


def test_robots_see_each_other() -> None:
    world = generate_floorplan(2)
    poses = world.sample_free_poses(1, clearance=1.5, rng=0)
    x, y, _ = poses[0]
    pair = np.array([[x - 0.6, y, 0.0], [x + 0.6, y, np.pi]])
    config = dataclasses.replace(
        NOISELESS,
        lidar=dataclasses.replace(NOISELESS.lidar, range_noise_std=0.0, dropout_probability=0.0),
    )
    sim = Simulation(world, poses=pair, config=config, rng=0)
    ahead = sim.scans[0].angles.size // 2  # beam straight ahead
    radius = config.physics.robot_radius
    for scan in sim.scans:
        assert scan.ranges[ahead] == pytest.approx(1.2 - radius, abs=1e-9)


def test_commands_are_validated(world: World) -> None:
    sim = Simulation(world, robots=2, rng=0)
    with pytest.raises(ValueError, match="shape"):
        sim.step(np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"\[-1, 1\]"):
        sim.step(np.array([[2.0, 0.0], [0.0, 0.0]]))
    with pytest.raises(TypeError, match="World"):
        Simulation("office", robots=1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="dt"):
        SimulationConfig(dt=0.0)
    with pytest.raises(ValueError, match="poses"):
        Simulation(world, poses=np.zeros((3, 2)))


def test_a_step_the_physics_cannot_take_in_time_is_refused() -> None:
    # It asked pymunk for some 2e9 substeps a step and ran for hours.
    with pytest.raises(ValueError, match="physics substeps"):
        SimulationConfig(physics=PhysicsConfig(max_linear_speed=1e9))
    with pytest.raises(ValueError, match="solver_iterations must be a whole number"):
        PhysicsConfig(solver_iterations=2.5)  # type: ignore[arg-type]


def test_given_poses_must_leave_each_robot_room(world: World) -> None:
    # A disc across a wall or another robot put the lidar inside an obstacle: it read
    # zero and negative ranges, which the map took for walls around the robot.
    ((x, y, _),) = world.sample_free_poses(1, clearance=1.0, rng=0)
    with pytest.raises(ValueError, match=r"poses\[0\] and poses\[1\] are 0.10 m apart"):
        Simulation(world, poses=[[x, y, 0.0], [x + 0.1, y, 0.0]])
    with pytest.raises(ValueError, match=r"poses\[0\] at .* has 0.00 m of free space"):
        Simulation(world, poses=[[-50.0, -50.0, 0.0]])
    sim = Simulation(world, poses=[[x - 0.3, y, 0.0], [x + 0.3, y, 0.0]], rng=0)
    assert all(np.all(np.isnan(scan.ranges) | (scan.ranges > 0)) for scan in sim.scans)


def test_known_cells_cover_what_the_robot_saw(world: World) -> None:
    sim = Simulation(world, robots=1, config=NOISELESS, rng=9)
    known = known_in_world(world, sim.grid(0), sim.start_poses[0])
    x, y = sim.start_poses[0, :2]
    cell = np.rint(world.truth.world_to_cell([[x, y]])[0]).astype(int)
    assert known[cell[1], cell[0]]
    assert not known[0, 0]  # the grid's corner lies outside the building


def test_a_given_pose_whose_disc_reaches_into_a_wall_cell_is_refused() -> None:
    # Clearance runs between cell centres: a robot 0.21 m from a wall cell's centre,
    # 0.185 m from its face, read 0.2 m of room and was taken with its 0.2 m radius.
    from tomosim.worlds import world_from_grid

    cells = np.full((80, 80), 100, dtype=np.int8)
    cells[1:-1, 1:-1] = 0  # one room, 3.9 m across, walled by the border cells
    world = world_from_grid(OccupancyGrid(cells, resolution=0.05), name="room")
    wall = world.truth.cell_to_world_matrix() @ np.array([0.0, 40.0, 1.0])
    radius = SimulationConfig().physics.robot_radius
    with pytest.raises(ValueError, match="free space"):
        Simulation(world, poses=[[wall[0] + radius + 0.01, wall[1], 0.0]])
    Simulation(world, poses=[[wall[0] + radius + 0.1, wall[1], 0.0]])
