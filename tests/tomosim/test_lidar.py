"""The lidar: numpy caster against pymunk's queries and against known geometry."""

from __future__ import annotations

import numpy as np
import pytest

from tomosim.lidar import Lidar, LidarConfig
from tomosim.lidar_oracle import cast_pymunk
from tomosim.physics import Physics, PhysicsConfig, build_space
from tomosim.ray_geometry import cast_segments
from tomosim.worlds import generate_floorplan

ORACLE_TOLERANCE = 1e-9
"""Metres by which the two casters may differ: both solve the same
intersection in double precision."""


def square_room(half: float) -> np.ndarray:
    """Walls of a square room of side ``2 * half`` centred on the origin."""
    c = [(-half, -half), (half, -half), (half, half), (-half, half)]
    return np.array([[c[i], c[(i + 1) % 4]] for i in range(4)], dtype=float)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_numpy_caster_matches_pymunk_oracle(seed: int) -> None:
    world = generate_floorplan(seed)
    poses = world.sample_free_poses(5, clearance=0.4, min_separation=1.0, rng=seed)
    physics = Physics(world.walls, poses, PhysicsConfig())
    lidar = Lidar(LidarConfig(beams=360, max_range=8.0), world.walls)
    angles = lidar.config.angles()
    radius = physics.config.robot_radius
    for index, pose in enumerate(poses):
        others = np.delete(poses[:, :2], index, axis=0)
        ours = lidar.true_ranges(pose, others=others, other_radii=radius)
        oracle = cast_pymunk(physics.space, pose, angles, 8.0, robot=index)
        np.testing.assert_array_equal(np.isfinite(ours), np.isfinite(oracle))
        both = np.isfinite(ours)
        assert np.max(np.abs(ours[both] - oracle[both])) <= ORACLE_TOLERANCE
        assert np.count_nonzero(both) > 0


def test_oracle_agrees_on_a_partial_field_of_view() -> None:
    world = generate_floorplan(4)
    config = LidarConfig(beams=181, fov=np.radians(270.0), max_range=5.0)
    lidar = Lidar(config, world.walls)
    space = build_space(world.walls)
    for pose in world.sample_free_poses(6, clearance=0.3, rng=8):
        ours = lidar.true_ranges(pose)
        oracle = cast_pymunk(space, pose, config.angles(), config.max_range)
        np.testing.assert_array_equal(np.isfinite(ours), np.isfinite(oracle))
        finite = np.isfinite(ours)
        assert np.max(np.abs(ours[finite] - oracle[finite]), initial=0.0) <= ORACLE_TOLERANCE


def test_square_room_ranges_are_exact() -> None:
    half = 2.0
    lidar = Lidar(LidarConfig(beams=360, max_range=10.0), square_room(half))
    ranges = lidar.true_ranges((0.0, 0.0, 0.3))
    bearing = 0.3 + lidar.config.angles()
    expected = half / np.maximum(np.abs(np.cos(bearing)), np.abs(np.sin(bearing)))
    np.testing.assert_allclose(ranges, expected, rtol=0, atol=1e-12)


def test_beam_through_a_shared_corner_is_not_lost() -> None:
    # Beams aimed exactly at the room's corners hit where two walls meet.
    lidar = Lidar(LidarConfig(beams=8, max_range=10.0), square_room(1.0))
    # Beam k points at pi / 4 - pi + k pi / 4: even beams at the corners.
    ranges = lidar.true_ranges((0.0, 0.0, np.pi / 4))
    np.testing.assert_allclose(ranges[0::2], np.sqrt(2.0), atol=1e-9)
    np.testing.assert_allclose(ranges[1::2], 1.0, atol=1e-9)


def test_beam_along_a_wall_line_hits_its_near_end() -> None:
    walls = np.array([[[2.0, 0.0], [3.0, 0.0]]])
    ranges = cast_segments(np.zeros(2), 0.0, np.pi / 2, 4, walls, 10.0)
    assert ranges[0] == pytest.approx(2.0)
    assert np.all(np.isinf(ranges[1:]))


def test_other_robots_are_seen_and_the_robot_itself_is_not() -> None:
    lidar = Lidar(LidarConfig(beams=360, max_range=10.0), square_room(5.0))
    radius = 0.2
    # The other robot sits 2 m straight ahead; the beam at 0 deg is index 180.
    ranges = lidar.true_ranges((0.0, 0.0, 0.0), others=[[2.0, 0.0]], other_radii=radius)
    assert ranges[180] == pytest.approx(2.0 - radius, abs=1e-12)
    # Its angular size: sin(half angle) = r / d.
    seen = np.flatnonzero(ranges < 4.0)
    half_width = np.degrees(np.arcsin(radius / 2.0))
    assert len(seen) == 2 * int(np.floor(half_width)) + 1
    # Without others every beam reaches the walls 5 m away or more.
    assert np.min(lidar.true_ranges((0.0, 0.0, 0.0))) == pytest.approx(5.0)


def test_max_range_and_partial_field_of_view() -> None:
    config = LidarConfig(beams=5, fov=np.pi, max_range=3.0)
    np.testing.assert_allclose(config.angles(), [-np.pi / 2, -np.pi / 4, 0, np.pi / 4, np.pi / 2])
    lidar = Lidar(config, square_room(2.5))
    ranges = lidar.true_ranges((0.0, 0.0, 0.0))
    # 2.5 m to the walls straight ahead and to the sides; the diagonals are
    # 3.54 m away, beyond range.
    np.testing.assert_allclose(ranges[[0, 2, 4]], 2.5)
    assert np.all(np.isinf(ranges[[1, 3]]))


def test_noise_and_dropouts_have_the_configured_statistics() -> None:
    sigma, dropout = 0.05, 0.1
    config = LidarConfig(
        beams=360, max_range=10.0, range_noise_std=sigma, dropout_probability=dropout
    )
    lidar = Lidar(config, square_room(2.0))
    truth = lidar.true_ranges((0.0, 0.0, 0.0))
    rng = np.random.default_rng(42)
    errors, dropped = [], 0
    for _ in range(50):
        scan = lidar.scan((0.0, 0.0, 0.0), rng=rng)
        valid = ~np.isnan(scan.ranges)
        dropped += int(np.count_nonzero(~valid))
        errors.append(scan.ranges[valid] - truth[valid])
    err = np.concatenate(errors)
    n = 50 * 360
    # Standard errors: sigma / sqrt(n) for the mean, sigma / sqrt(2 n) for the std.
    assert abs(np.mean(err)) < 4 * sigma / np.sqrt(n)
    assert abs(np.std(err) - sigma) < 4 * sigma / np.sqrt(2 * n)
    assert abs(dropped / n - dropout) < 4 * np.sqrt(dropout * (1 - dropout) / n)


def test_scan_draws_are_reproducible() -> None:
    lidar = Lidar(LidarConfig(), square_room(3.0))
    a = lidar.scan((0.1, 0.2, 0.3), rng=np.random.default_rng(5))
    b = lidar.scan((0.1, 0.2, 0.3), rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a.ranges, b.ranges)
    points = a.points((0.1, 0.2, 0.3))
    # Every return lies on the room's walls (within noise).
    edge = np.max(np.abs(points), axis=1)
    assert np.all(np.abs(edge - 3.0) < 6 * LidarConfig().range_noise_std)


@pytest.mark.parametrize("robots", [1, 2, 6])
def test_team_scans_are_the_scans_of_each_robot_in_turn(robots: int) -> None:
    world = generate_floorplan(4)
    poses = world.sample_free_poses(robots, clearance=0.4, min_separation=0.9, rng=robots)
    lidar = Lidar(LidarConfig(dropout_probability=0.05), world.walls)
    team = lidar.scans(poses, radius=0.2, rngs=[np.random.default_rng(k) for k in range(robots)])
    for k, pose in enumerate(poses):
        others = np.delete(poses[:, :2], k, axis=0)
        alone = lidar.scan(pose, rng=np.random.default_rng(k), others=others, other_radii=0.2)
        np.testing.assert_array_equal(team[k].ranges, alone.ranges)
    with pytest.raises(ValueError, match="one generator per pose"):
        lidar.scans(poses, radius=0.2, rngs=[])


def test_config_is_validated() -> None:
    with pytest.raises(ValueError, match="beams"):
        LidarConfig(beams=1)
    with pytest.raises(ValueError, match="fov"):
        LidarConfig(fov=7.0)
    with pytest.raises(ValueError, match="max_range"):
        LidarConfig(max_range=0.0)
    with pytest.raises(ValueError, match="dropout"):
        LidarConfig(dropout_probability=1.0)
    with pytest.raises(ValueError, match="walls"):
        Lidar(LidarConfig(), np.zeros((3, 2)))


def test_team_scans_refuse_poses_without_a_heading() -> None:
    # (N, 2) poses were read as a flat buffer: robot 0 took robot 1's x as its heading.
    square = np.array(
        [[[-5, -5], [5, -5]], [[5, -5], [5, 5]], [[5, 5], [-5, 5]], [[-5, 5], [-5, -5]]], float
    )
    lidar = Lidar(LidarConfig(), square)
    rngs = [np.random.default_rng(k) for k in range(2)]
    with pytest.raises(ValueError, match=r"poses must be \(N, 3\)"):
        lidar.scans(np.array([[0.0, 0.0], [1.5, 0.2]]), radius=0.2, rngs=rngs)
