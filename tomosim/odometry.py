"""Wheel odometry with drift: each robot's pose estimate in its own start frame.

The true motion between two steps is expressed in the robot's frame at the
first of them, ``(dx, dy, dtheta)``; Gaussian noise whose standard deviation
grows with the distance travelled and the angle turned is added, and the
noisy increment is composed onto the estimate. The estimate starts at
``(0, 0, 0)``: the start pose *is* the origin of the robot's map frame. The
true pose is never used for anything but the increment.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.validators import real_number


@dataclass(frozen=True)
class OdometryConfig:
    """Drift of the odometry: each step's error, in proportion to that step's motion.

    As in the odometry motion model (Thrun, Burgard and Fox, *Probabilistic
    Robotics*, 2005, section 5.4), the standard deviation of the error of
    each step's motion grows with that step's distance and turn, and the
    errors of successive steps are independent. They add up as a random
    walk, so the drift over a path depends on the step as well as on these
    settings: over ``L`` metres in steps of ``d`` metres the position error
    from ``translation_noise`` alone is about ``translation_noise *
    sqrt(L * d)`` (the heading error adds a lever arm on top). With the
    defaults and the simulation's 0.1 s steps, a robot's estimate is a few
    centimetres and a few tenths of a degree off after 60 m (about 0.1 % of
    the distance; ``tomosim explore`` prints it); shorter steps drift less.

    The defaults stand for a pose estimate already corrected by scan matching,
    as a SLAM front end gives the maps that robots share; raw wheel odometry
    drifts several times more (about 0.01 per metre and per radian), which
    these can be raised to study.

    Attributes
    ----------
    translation_noise : float
        Standard deviation of a step's position error (along and across)
        per metre of that step.
    rotation_noise : float
        Standard deviation of a step's heading error per radian it turned.
    drift_per_metre : float
        Standard deviation of a step's heading error per metre it travelled
        (uneven wheels).
    """

    translation_noise: float = 0.003
    rotation_noise: float = 0.003
    drift_per_metre: float = 0.0005

    def __post_init__(self) -> None:
        for name in ("translation_noise", "rotation_noise", "drift_per_metre"):
            real_number(getattr(self, name), name, low=0.0)


def relative_motion(before: ArrayLike, after: ArrayLike) -> NDArray[np.float64]:
    """``(dx, dy, dtheta)``: pose ``after`` seen from pose ``before`` (both ``(x, y, theta)``)."""
    x0, y0, t0 = np.asarray(before, dtype=float)
    x1, y1, t1 = np.asarray(after, dtype=float)
    c, s = math.cos(t0), math.sin(t0)
    dx, dy = x1 - x0, y1 - y0
    dtheta = math.remainder(t1 - t0, 2 * math.pi)
    return np.array([c * dx + s * dy, -s * dx + c * dy, dtheta])


def compose(pose: ArrayLike, motion: ArrayLike) -> NDArray[np.float64]:
    """Pose reached by applying ``motion = (dx, dy, dtheta)`` (robot frame) at ``pose``."""
    x, y, theta = np.asarray(pose, dtype=float)
    dx, dy, dtheta = np.asarray(motion, dtype=float)
    c, s = math.cos(theta), math.sin(theta)
    return np.array(
        [x + c * dx - s * dy, y + s * dx + c * dy, math.remainder(theta + dtheta, 2 * math.pi)]
    )


class Odometry:
    """One robot's odometry.

    Parameters
    ----------
    config : OdometryConfig
        Noise levels.
    true_pose : (3,) array_like
        The robot's true pose at the start (world frame).
    rng : numpy.random.Generator
        This robot's own stream of randomness.
    """

    __slots__ = ("_last_true", "config", "pose", "rng")

    def __init__(
        self, config: OdometryConfig, true_pose: ArrayLike, rng: np.random.Generator
    ) -> None:
        self.config = config
        self.rng = rng
        self.pose = np.zeros(3)
        x, y, theta = (float(v) for v in np.asarray(true_pose, dtype=float))
        self._last_true = (x, y, theta)

    def update(self, true_pose: Sequence[float] | NDArray[np.float64]) -> NDArray[np.float64]:
        """Advance the estimate by the noisy motion since the last call; returns it.

        Draws exactly three normal variates per call, moving or not. The
        arithmetic is that of :func:`relative_motion` and :func:`compose`, on
        plain floats (a step costs a few numpy calls less).
        """
        x1, y1, t1 = (float(v) for v in true_pose)
        x0, y0, t0 = self._last_true
        self._last_true = (x1, y1, t1)
        # relative_motion(last, now)
        c, s = math.cos(t0), math.sin(t0)
        move_x, move_y = x1 - x0, y1 - y0
        dx = c * move_x + s * move_y
        dy = -s * move_x + c * move_y
        dtheta = math.remainder(t1 - t0, 2 * math.pi)
        cfg = self.config
        distance = math.hypot(dx, dy)
        noise = self.rng.standard_normal(3).tolist()
        sigma_xy = cfg.translation_noise * distance
        sigma_theta = cfg.rotation_noise * abs(dtheta) + cfg.drift_per_metre * distance
        step_x = dx + sigma_xy * noise[0]
        step_y = dy + sigma_xy * noise[1]
        turn = dtheta + sigma_theta * noise[2]
        # compose(pose, noisy step)
        x, y, theta = self.pose.tolist()
        c, s = math.cos(theta), math.sin(theta)
        self.pose = np.array(
            [
                x + c * step_x - s * step_y,
                y + s * step_x + c * step_y,
                math.remainder(theta + turn, 2 * math.pi),
            ]
        )
        return self.pose
