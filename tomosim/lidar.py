"""A simulated 2-D lidar: beams, field of view, range limit, Gaussian noise and dropouts.

Scan coding (every consumer relies on it):

* ``angles`` are beam directions relative to the robot's heading, radians
  counter-clockwise; beam ``k`` points at ``first_angle + k * increment``.
  A full circle has ``increment = 2 pi / beams`` starting at ``-pi``;
  a narrower field of view ``fov`` spans ``[-fov / 2, +fov / 2]`` with both
  ends included.
* ``ranges`` are metres: finite for a return, ``inf`` when nothing lies
  within ``max_range``, ``nan`` for a dropout (the beam reported nothing).

The robot does not see itself; other robots are circles and are seen. A
scan is cast by the compiled :func:`tomosim.kernels.raycast.cast_scan`, the
algorithm of :func:`tomosim.ray_geometry.cast_segments` and
:func:`tomosim.ray_geometry.cast_circles` in one loop; the tests check it against
those and against pymunk's segment queries (:mod:`tomosim.lidar_oracle`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.validators import real_number, whole_number
from tomosim.kernels.raycast import add_noise, cast_scan, scan_team
from tomosim.worlds.world import as_segments

FULL_CIRCLE_TOLERANCE = 1e-9
"""A field of view within this many radians of ``2 pi`` is a full circle."""


@dataclass(frozen=True)
class LidarConfig:
    """Lidar parameters.

    Attributes
    ----------
    beams : int
        Number of beams per scan.
    fov : float
        Field of view in radians, ``(0, 2 pi]``.
    max_range : float
        Metres beyond which nothing is returned.
    range_noise_std : float
        Standard deviation of the Gaussian noise added to each return, metres.
    dropout_probability : float
        Chance that a beam reports nothing (``nan``).
    """

    beams: int = 360
    fov: float = 2.0 * np.pi
    max_range: float = 8.0
    range_noise_std: float = 0.01
    dropout_probability: float = 0.005

    def __post_init__(self) -> None:
        whole_number(self.beams, "beams", minimum=2)
        if not 0.0 < self.fov <= 2.0 * np.pi + FULL_CIRCLE_TOLERANCE:
            raise ValueError(f"fov must be in (0, 2 pi] radians, got {self.fov}")
        real_number(self.max_range, "max_range", low=0.0, low_open=True, unit="metres")
        real_number(self.range_noise_std, "range_noise_std", low=0.0, unit="metres")
        real_number(
            self.dropout_probability, "dropout_probability", low=0.0, high=1.0, high_open=True
        )

    @property
    def full_circle(self) -> bool:
        """Whether the beams cover the whole circle."""
        return bool(self.fov >= 2.0 * np.pi - FULL_CIRCLE_TOLERANCE)

    @property
    def increment(self) -> float:
        """Radians between consecutive beams."""
        if self.full_circle:
            return 2.0 * np.pi / self.beams
        return self.fov / (self.beams - 1)

    @property
    def first_angle(self) -> float:
        """Direction of beam 0 relative to the heading, radians."""
        return -np.pi if self.full_circle else -0.5 * self.fov

    def angles(self) -> NDArray[np.float64]:
        """``(beams,)`` beam directions relative to the heading, radians."""
        return np.asarray(self.first_angle + self.increment * np.arange(self.beams), dtype=float)


@dataclass(frozen=True, slots=True)
class Scan:
    """One lidar scan in the coding of the module docstring.

    Attributes
    ----------
    angles : (B,) float ndarray
        Beam directions relative to the heading, radians.
    ranges : (B,) float ndarray
        Metres; ``inf`` no return within ``max_range``; ``nan`` dropout.
    max_range : float
        The lidar's range limit, metres.
    """

    angles: NDArray[np.float64]
    ranges: NDArray[np.float64]
    max_range: float

    def points(self, pose: ArrayLike) -> NDArray[np.float64]:
        """``(H, 2)`` end points of the finite returns, in the frame ``pose`` is given in."""
        x, y, theta = np.asarray(pose, dtype=float)
        hit = np.isfinite(self.ranges)
        bearing = theta + self.angles[hit]
        r = self.ranges[hit]
        return np.column_stack([x + r * np.cos(bearing), y + r * np.sin(bearing)])


class Lidar:
    """Casts scans in a world of wall segments and circular robots.

    Parameters
    ----------
    config : LidarConfig
        Beams, range and noise.
    walls : (N, 2, 2) float ndarray
        Wall segments in metres.
    """

    __slots__ = ("_angles", "_flat_walls", "config", "walls")

    def __init__(self, config: LidarConfig, walls: ArrayLike) -> None:
        if not isinstance(config, LidarConfig):
            raise TypeError(f"config must be a LidarConfig, got {type(config).__name__}")
        self.config = config
        self.walls = as_segments(walls)
        self._flat_walls = np.ascontiguousarray(self.walls.reshape(-1, 4), dtype=np.float64)
        self._angles = config.angles()
        self._angles.setflags(write=False)

    @property
    def angles(self) -> NDArray[np.float64]:
        """``(B,)`` beam directions relative to the heading, radians (read-only)."""
        return self._angles

    def true_ranges(
        self,
        pose: ArrayLike,
        *,
        others: ArrayLike = (),
        other_radii: ArrayLike = (),
    ) -> NDArray[np.float64]:
        """Noise-free ``(B,)`` ranges from ``pose = (x, y, theta)``.

        ``others`` are ``(C, 2)`` centres of the other robots (never the
        scanning robot itself), ``other_radii`` their ``(C,)`` radii, metres.
        """
        x, y, theta = (float(v) for v in np.asarray(pose, dtype=float))
        cfg = self.config
        centres = np.ascontiguousarray(others, dtype=np.float64).reshape(-1, 2)
        radii = np.asarray(other_radii, dtype=np.float64)
        if radii.shape != (len(centres),):
            radii = np.ascontiguousarray(np.broadcast_to(radii, (len(centres),)))
        return cast_scan(
            x,
            y,
            theta + cfg.first_angle,
            cfg.increment,
            cfg.beams,
            self._flat_walls,
            centres,
            radii,
            cfg.max_range,
        )

    def scan(
        self,
        pose: ArrayLike,
        *,
        rng: np.random.Generator,
        others: ArrayLike = (),
        other_radii: ArrayLike = (),
    ) -> Scan:
        """A noisy :class:`Scan` from ``pose``; see :meth:`true_ranges` for the arguments.

        Every call draws the same number of random values from ``rng``
        (``beams`` normals, then ``beams`` uniforms), so that runs are
        reproducible whatever the scene.
        """
        cfg = self.config
        ranges = self.true_ranges(pose, others=others, other_radii=other_radii)
        normals = rng.normal(0.0, 1.0, cfg.beams)
        uniforms = rng.random(cfg.beams)
        add_noise(
            ranges, normals, uniforms, cfg.range_noise_std, cfg.dropout_probability, cfg.max_range
        )
        return Scan(self._angles, ranges, cfg.max_range)

    def scans(
        self, poses: NDArray[np.float64], *, radius: float, rngs: Sequence[np.random.Generator]
    ) -> list[Scan]:
        """A noisy :class:`Scan` from each of ``poses``, robots of ``radius`` metres that see
        each other.

        The same scans as :meth:`scan` from each pose in turn with the other
        robots as ``others`` (robot ``k`` drawing from ``rngs[k]``), in one
        compiled call; their ranges are the rows of :meth:`team_ranges`.

        Parameters
        ----------
        poses : (N, 3) float ndarray
            True poses ``(x, y, theta)``, metres and radians.
        radius : float
            The robots' radius, metres.
        rngs : sequence of N numpy.random.Generator
            Each robot's stream.
        """
        ranges = self.team_ranges(poses, radius=radius, rngs=rngs)
        return [Scan(self._angles, row, self.config.max_range) for row in ranges]

    def team_ranges(
        self, poses: NDArray[np.float64], *, radius: float, rngs: Sequence[np.random.Generator]
    ) -> NDArray[np.float64]:
        """``(N, B)`` ranges of the scans of :meth:`scans` (same arguments), one row a robot."""
        cfg = self.config
        beams = cfg.beams
        poses = np.ascontiguousarray(poses, dtype=np.float64)
        if poses.ndim != 2 or poses.shape[1] != 3:
            raise ValueError(f"poses must be (N, 3) rows of (x, y, theta), got shape {poses.shape}")
        robots = len(poses)
        if len(rngs) != robots:
            raise ValueError(f"need one generator per pose, got {len(rngs)} for {robots}")
        normals = np.empty((robots, beams))
        uniforms = np.empty((robots, beams))
        for k, rng in enumerate(rngs):  # per robot, the values scan() draws, in its order
            rng.standard_normal(out=normals[k])
            rng.random(out=uniforms[k])
        return scan_team(
            poses,
            cfg.first_angle,
            cfg.increment,
            beams,
            self._flat_walls,
            float(radius),
            cfg.max_range,
            normals,
            uniforms,
            cfg.range_noise_std,
            cfg.dropout_probability,
        )
