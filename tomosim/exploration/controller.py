"""Following a path with a differential drive: pure pursuit with a lidar guard.

1. Progress along the path is tracked: the nearest path point ahead of the
   last one reached.
2. The goal is the first path point at least ``lookahead`` metres from the
   robot past that point (the path's end near the goal).
3. The turn command is proportional to the heading error; the forward
   command falls with the error and is zero above ``turn_in_place_angle``,
   so the robot turns on the spot rather than sweeping wide through a door.
4. A lidar guard stops forward motion when a return in the front sector is
   closer than ``stop_distance`` from the robot's edge.

Commands are normalised to ``[-1, 1]`` (fractions of the maximum speeds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.validators import real_number
from tomosim.lidar import Scan
from tomosim.robot import ROBOT_RADIUS_M


@dataclass(frozen=True)
class ControllerConfig:
    """Path-following gains and limits.

    Attributes
    ----------
    lookahead : float
        Metres from the robot to the point it steers at.
    heading_gain : float
        Turn command per radian of heading error.
    turn_in_place_angle : float
        Heading error (radians) above which the robot only turns.
    cruise : float
        Forward command on a straight path.
    goal_tolerance : float
        Metres from the path's end at which the path is done.
    stop_distance : float
        Free metres required ahead of the robot's edge to drive forward.
    guard_half_angle : float
        Half-width of the front sector the guard watches, radians.
    robot_radius : float
        Metres, for the guard.
    """

    lookahead: float = 0.6
    heading_gain: float = 1.5
    turn_in_place_angle: float = math.radians(60.0)
    cruise: float = 0.8
    goal_tolerance: float = 0.3
    stop_distance: float = 0.1
    guard_half_angle: float = math.radians(35.0)
    robot_radius: float = ROBOT_RADIUS_M

    def __post_init__(self) -> None:
        for name in (
            "lookahead",
            "heading_gain",
            "turn_in_place_angle",
            "goal_tolerance",
            "guard_half_angle",
            "robot_radius",
        ):
            real_number(getattr(self, name), name, low=0.0, low_open=True)
        real_number(self.cruise, "cruise", low=0.0, high=1.0, low_open=True)
        real_number(self.stop_distance, "stop_distance", low=0.0, unit="metres")


def front_clearance(scan: Scan, half_angle: float) -> float:
    """Shortest return (metres) within ``half_angle`` of straight ahead; ``inf`` if none."""
    ahead = np.abs(scan.angles) <= half_angle
    ranges = scan.ranges[ahead]
    ranges = ranges[np.isfinite(ranges)]
    return float(ranges.min()) if len(ranges) else math.inf


class PathFollower:
    """Drives along one path at a time (steps 1-4 of the module docstring).

    Parameters
    ----------
    config : ControllerConfig
        Gains and limits.
    """

    __slots__ = ("config", "path", "progress")

    def __init__(self, config: ControllerConfig | None = None) -> None:
        self.config = config if config is not None else ControllerConfig()
        self.path: NDArray[np.float64] = np.zeros((0, 2))
        self.progress = 0

    def set_path(self, path: ArrayLike) -> None:
        """Follow ``(K, 2)`` points in metres from now on."""
        points = np.asarray(path, dtype=float).reshape(-1, 2)
        self.path = points
        self.progress = 0

    def done(self, pose: ArrayLike) -> bool:
        """Whether there is no path or the robot is within tolerance of its end."""
        if len(self.path) == 0:
            return True
        x, y = np.asarray(pose, dtype=float)[:2]
        end = self.path[-1]
        return math.hypot(end[0] - x, end[1] - y) <= self.config.goal_tolerance

    def command(self, pose: ArrayLike, scan: Scan | None = None) -> NDArray[np.float64]:
        """``(linear, angular)`` command for the robot at ``pose = (x, y, theta)``."""
        cfg = self.config
        if self.done(pose):
            return np.zeros(2)
        x, y, theta = (float(v) for v in np.asarray(pose, dtype=float))
        # 1. Progress: nearest point at or after the last one reached.
        rest = self.path[self.progress :]
        distances = np.hypot(rest[:, 0] - x, rest[:, 1] - y)
        nearest = int(np.argmin(distances))
        self.progress += nearest
        distances = distances[nearest:]
        # 2. Lookahead point.
        beyond = np.flatnonzero(distances >= cfg.lookahead)
        goal = self.path[self.progress + int(beyond[0])] if len(beyond) else self.path[-1]
        # 3. Heading control.
        error = math.remainder(math.atan2(goal[1] - y, goal[0] - x) - theta, 2 * math.pi)
        angular = float(np.clip(cfg.heading_gain * error, -1.0, 1.0))
        if abs(error) >= cfg.turn_in_place_angle:
            linear = 0.0
        else:
            linear = cfg.cruise * math.cos(error * (0.5 * math.pi / cfg.turn_in_place_angle))
        # 4. Guard.
        if scan is not None and linear > 0.0:
            free = front_clearance(scan, cfg.guard_half_angle) - cfg.robot_radius
            if free < cfg.stop_distance:
                linear = 0.0
        return np.array([linear, angular])
