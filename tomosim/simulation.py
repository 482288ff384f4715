"""The simulation: robots with lidar, odometry and a map each, in one world.

One :meth:`Simulation.step` does, for all robots in index order:

1. physics for ``config.dt`` seconds under the normalised commands;
2. odometry from the true motion (with drift);
3. a lidar scan from the true pose, other robots visible;
4. a map update at the odometry pose, in the robot's own start frame.

Only the simulator knows the true poses; each robot's pose estimate and map
live in the frame of its start pose. Everything random comes from one
generator given at construction, split into a stream per robot and purpose,
so that a seed fixes the whole run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from merging.validators import RngLike, as_generator, real_number
from tomosim.lidar import Lidar, LidarConfig, Scan
from tomosim.mapping import LogOddsMap, MappingConfig, update_maps
from tomosim.odometry import Odometry, OdometryConfig
from tomosim.physics import Physics, PhysicsConfig
from tomosim.worlds.world import NoRoomError, World

START_CLEARANCE_MARGIN = 0.15
"""Metres of free space beyond the robot radius around a random start position."""
START_SEPARATION_RADII = 4.0
"""Random start positions lie at least this many robot radii apart."""


@dataclass(frozen=True)
class SimulationConfig:
    """Everything that defines a simulation run except the world and the seed.

    Attributes
    ----------
    dt : float
        Seconds per step.
    physics : PhysicsConfig
        Robot size, speed limits (a command of 1 means the maximum) and drive.
    lidar : LidarConfig
        Beams (360), field of view, range, noise.
    odometry : OdometryConfig
        Drift of each robot's pose estimate.
    mapping : MappingConfig
        Occupancy grid resolution (0.05 m) and log-odds model.
    """

    dt: float = 0.1
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    odometry: OdometryConfig = field(default_factory=OdometryConfig)
    mapping: MappingConfig = field(default_factory=MappingConfig)

    def __post_init__(self) -> None:
        real_number(self.dt, "dt", low=0.0, low_open=True, unit="seconds")
        self.physics.substeps(self.dt)  # raises for a step the physics cannot take in time


def _check_room(world: World, poses: NDArray[np.float64], radius: float) -> None:
    """Raise ValueError unless every robot's disc (``radius``) lies in free space, apart
    from the others: a disc across a wall or another robot puts the lidar inside an
    obstacle, where it reads zero and negative ranges that the map takes for walls."""
    # Clearance runs from the centre of the cell under the pose to the nearest wall
    # cell's centre: the wall's face and the pose may each lie half a cell nearer.
    room = world.clearance_at(poses[:, :2]) - world.resolution
    for k in np.flatnonzero(room < radius):
        x, y = poses[k, :2]
        raise ValueError(
            f"poses[{k}] at ({x:g}, {y:g}) m has {max(room[k], 0.0):.2f} m of free space "
            f"around it; a robot needs its radius, {radius:g} m (off the map or in a wall "
            "has none)"
        )
    offsets = poses[:, None, :2] - poses[None, :, :2]
    gaps = np.hypot(offsets[..., 0], offsets[..., 1])
    first, second = np.nonzero(np.triu(gaps < 2 * radius, k=1))
    if len(first):
        i, j = int(first[0]), int(second[0])
        raise ValueError(
            f"poses[{i}] and poses[{j}] are {gaps[i, j]:.2f} m apart; robots of radius "
            f"{radius:g} m need {2 * radius:g} m"
        )


class Simulation:
    """Robots exploring a :class:`~tomosim.worlds.World`.

    Attributes
    ----------
    world : World
    config : SimulationConfig
    start_poses : (N, 3) float ndarray
        True start poses (read-only; for evaluation only).
    physics : Physics
    lidar : Lidar
    odometry : list of Odometry
    maps : list of LogOddsMap
        Each robot's map in its own start frame.
    ranges : (N, B) float ndarray
        The latest scans' ranges, one row a robot (``scans[k].ranges`` is row ``k``).
    steps : int
        Steps taken.

    Parameters
    ----------
    world : World
        Walls and ground truth.
    robots : int
        Number of robots (ignored when ``poses`` is given).
    poses : (N, 3) array_like, optional
        True start poses ``(x, y, theta)``; drawn at random in one connected
        free region when omitted.
    config : SimulationConfig, optional
        Defaults as documented there.
    rng : numpy.random.Generator, int or None
        The run's only source of randomness.
    """

    __slots__ = (
        "_lidar_rngs",
        "_scans",
        "_true",
        "config",
        "lidar",
        "maps",
        "odometry",
        "physics",
        "ranges",
        "start_poses",
        "steps",
        "world",
    )

    def __init__(
        self,
        world: World,
        *,
        robots: int = 1,
        poses: ArrayLike | None = None,
        config: SimulationConfig | None = None,
        rng: RngLike = None,
    ) -> None:
        if not isinstance(world, World):
            raise TypeError(f"world must be a World, got {type(world).__name__}")
        self.config = config if config is not None else SimulationConfig()
        self.world = world
        generator = as_generator(rng)
        radius = self.config.physics.robot_radius
        if poses is None:
            if robots < 1:
                raise ValueError(f"robots must be at least 1, got {robots}")
            separation = START_SEPARATION_RADII * radius
            try:
                start = world.sample_free_poses(
                    robots,
                    clearance=radius + START_CLEARANCE_MARGIN,
                    min_separation=separation,
                    rng=generator,
                )
            except NoRoomError as exc:  # its advice names sample_free_poses' own setting
                raise NoRoomError(
                    f"could only place {exc.placed} of {robots} robots {separation:g} m apart "
                    f"in {world.name!r}; use {max(exc.placed, 1)} "
                    f"robot{'s' if exc.placed > 1 else ''} or fewer, or a larger world",
                    placed=exc.placed,
                    requested=robots,
                ) from exc
        else:
            start = np.asarray(poses, dtype=float)
            if start.ndim != 2 or start.shape[1] != 3 or not np.all(np.isfinite(start)):
                raise ValueError(
                    f"poses must be a finite (N, 3) array of (x, y, theta), got shape {start.shape}"
                )
            _check_room(world, start, radius)
        if len(start) == 0:
            raise ValueError("a simulation needs at least one robot")
        self.start_poses = start.copy()
        self.start_poses.setflags(write=False)
        streams = generator.spawn(2 * len(start))
        self.physics = Physics(world.walls, start, self.config.physics)
        self.lidar = Lidar(self.config.lidar, world.walls)
        self.odometry = [
            Odometry(self.config.odometry, pose, streams[2 * i]) for i, pose in enumerate(start)
        ]
        self._lidar_rngs = streams[1::2]
        self.maps = [LogOddsMap(self.config.mapping) for _ in range(len(start))]
        self.steps = 0
        self._true = self.physics.poses()
        self._scans: list[Scan] | None = None  # made from ranges when asked for
        self.ranges = np.zeros((len(start), self.config.lidar.beams))
        self._sense()

    @property
    def count(self) -> int:
        """Number of robots."""
        return len(self.maps)

    @property
    def scans(self) -> list[Scan]:
        """The latest scan of each robot (its ranges a row of ``ranges``; the same list until
        the next step)."""
        if self._scans is None:
            angles, max_range = self.lidar.angles, self.lidar.config.max_range
            self._scans = [Scan(angles, row, max_range) for row in self.ranges]
        return self._scans

    @property
    def time(self) -> float:
        """Simulated seconds since the start."""
        return self.steps * self.config.dt

    @property
    def true_poses(self) -> NDArray[np.float64]:
        """``(N, 3)`` true poses in the world frame (for evaluation only)."""
        return self._true.copy()

    @property
    def odometry_poses(self) -> NDArray[np.float64]:
        """``(N, 3)`` pose estimates, each in its robot's start frame."""
        return np.array([odometry.pose for odometry in self.odometry])

    def grid(self, robot: int) -> OccupancyGrid:
        """Robot ``robot``'s map in its start frame, in the ROS coding."""
        return self.maps[robot].to_occupancy_grid()

    def step(self, commands: ArrayLike) -> None:
        """Advance by one step of ``config.dt`` seconds.

        Parameters
        ----------
        commands : (N, 2) array_like
            Per robot ``(linear, angular)`` in ``[-1, 1]``: fractions of the
            maximum forward speed and of the maximum counter-clockwise turn rate.
        """
        command = np.asarray(commands, dtype=float)
        if command.shape != (self.count, 2):
            raise ValueError(f"commands must have shape ({self.count}, 2), got {command.shape}")
        values = command.tolist()
        if not all(math.isfinite(v) and abs(v) <= 1.0 for pair in values for v in pair):
            raise ValueError(f"commands must be finite and within [-1, 1], got {values}")
        phys = self.config.physics
        # Commands within [-1, 1] ask for speeds within the limits: nothing to clip.
        self.physics.drive(
            [linear * phys.max_linear_speed for linear, _ in values],
            [angular * phys.max_angular_speed for _, angular in values],
            self.config.dt,
        )
        self._true = self.physics.poses()
        for odometry, pose in zip(self.odometry, self._true.tolist(), strict=True):
            odometry.update(pose)
        self.steps += 1
        self._sense()

    def _sense(self) -> None:
        """Scan from every true pose and map at every odometry pose."""
        lidar = self.lidar
        self.ranges = lidar.team_ranges(
            self._true, radius=self.config.physics.robot_radius, rngs=self._lidar_rngs
        )
        angles, max_range = lidar.angles, lidar.config.max_range
        self._scans = None
        update_maps(self.maps, self.odometry_poses, angles, self.ranges, max_range)
