"""Physics: differential drive, collisions, and no tunnelling through walls."""

from __future__ import annotations

import numpy as np
import pytest

from merging.grid import OccupancyGrid
from tomosim.physics import MAX_SUBSTEP_TRAVEL, Physics, PhysicsConfig
from tomosim.ray_geometry import distance_to_segments
from tomosim.worlds import World, world_from_map

SETTLED_OVERLAP = 0.01
"""Metres a robot pressed against a wall or another robot may overlap it once
contacts have settled: a few times pymunk's collision slop (2 mm)."""


def hall_with_thin_wall() -> World:
    """A 10 m x 6 m hall split at x = 5 m by a wall one 0.05 m cell thick."""
    occupied = np.zeros((120, 200), dtype=bool)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    occupied[:, 100] = True
    return world_from_map(OccupancyGrid.from_bool(occupied, resolution=0.05))


def test_robot_drives_straight_and_turns_at_the_commanded_rates() -> None:
    world = hall_with_thin_wall()
    config = PhysicsConfig()
    physics = Physics(world.walls, [[1.0, 3.0, 0.0]], config)
    for _ in range(10):  # reach cruising speed
        physics.step([0.5], [0.0], 0.1)
    start = physics.poses()[0]
    for _ in range(20):
        physics.step([0.5], [0.0], 0.1)
    end = physics.poses()[0]
    assert end[0] - start[0] == pytest.approx(1.0, rel=0.02)
    assert end[1] == pytest.approx(start[1], abs=1e-6)
    for _ in range(10):
        physics.step([0.0], [1.0], 0.1)
    turn_start = physics.poses()[0, 2]
    for _ in range(5):
        physics.step([0.0], [1.0], 0.1)
    assert physics.poses()[0, 2] - turn_start == pytest.approx(0.5, rel=0.02)


@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_robots_driven_at_a_thin_wall_never_pass_it(speed: float) -> None:
    world = hall_with_thin_wall()
    config = PhysicsConfig(max_linear_speed=speed)
    wall_x = 5.0 + 0.025  # the wall cell's centre; its faces are 2.5 cm either side
    # Three robots head straight at the wall, one at 45 degrees, one pushes another.
    poses = np.array(
        [[1.0, 1.0, 0.0], [2.0, 2.5, 0.0], [1.0, 4.0, np.pi / 4], [3.5, 5.0, 0.0], [2.5, 5.0, 0.0]]
    )
    physics = Physics(world.walls, poses, config)
    radius = config.robot_radius
    # On impact a robot may sink into a wall by what it travels in one
    # substep, never by its radius: its centre stays on its side.
    impact = MAX_SUBSTEP_TRAVEL * radius + SETTLED_OVERLAP
    for _ in range(600):  # a minute at full speed
        physics.step(np.full(5, speed), np.zeros(5), 0.1)
        now = physics.poses()
        assert np.all(now[:, 0] < wall_x - radius + impact)
        assert np.all(distance_to_segments(now[:, :2], world.walls) >= radius - impact)
    clear = distance_to_segments(now[:, :2], world.walls)
    assert np.all(clear >= radius - SETTLED_OVERLAP)
    gaps = np.hypot(*(now[:, None, :2] - now[None, :, :2]).transpose(2, 0, 1))
    gaps[np.diag_indices(5)] = np.inf
    assert np.all(gaps >= 2 * radius - SETTLED_OVERLAP)
    # Four robots end pressed against the wall, the pusher against the fourth.
    assert np.all(physics.in_contact())
    assert np.sum(clear <= radius + SETTLED_OVERLAP) == 4


def test_substeps_keep_travel_per_substep_small() -> None:
    config = PhysicsConfig(robot_radius=0.2, max_linear_speed=4.0)
    # 0.4 m per 0.1 s step, at most a quarter radius (0.05 m) per substep.
    assert config.substeps(0.1) == 8
    assert PhysicsConfig().substeps(0.1) == 2


def test_same_inputs_give_the_same_motion() -> None:
    world = hall_with_thin_wall()
    poses = [[1.0, 1.0, 0.3], [1.6, 1.2, 2.0]]
    runs = []
    for _ in range(2):
        physics = Physics(world.walls, poses, PhysicsConfig())
        for k in range(100):
            physics.step([1.0, 0.7], [np.sin(k / 7.0), -0.5], 0.1)
        runs.append(physics.poses())
    np.testing.assert_array_equal(runs[0], runs[1])


def test_invalid_input_is_rejected() -> None:
    world = hall_with_thin_wall()
    with pytest.raises(ValueError, match="poses"):
        Physics(world.walls, [[1.0, 2.0]], PhysicsConfig())
    physics = Physics(world.walls, [[1.0, 1.0, 0.0]], PhysicsConfig())
    with pytest.raises(ValueError, match="shape"):
        physics.step([1.0, 1.0], [0.0, 0.0], 0.1)
    with pytest.raises(ValueError, match="dt"):
        physics.step([1.0], [0.0], 0.0)
    with pytest.raises(ValueError, match="collision_slop"):
        PhysicsConfig(collision_slop=0.1)
