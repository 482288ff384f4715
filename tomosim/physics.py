"""Rigid-body physics with pymunk: static walls and differential-drive robots.

Each robot is a dynamic disc driven through a kinematic *control body*, as in
pymunk's top-down tank demo: a pivot joint makes the disc's velocity follow
the control body's, a gear joint its angular velocity, both with their
position correction switched off and their forces capped so that they act
like wheel friction. Contacts with walls and other robots are hard
constraints that the capped drive cannot overpower, so a robot stops at a
wall instead of pushing through it.

Units are SI (metres, kilograms, seconds, radians). Tunnelling is prevented
by splitting each step into substeps in which no robot moves more than
:data:`MAX_SUBSTEP_TRAVEL` of its radius, and by a collision slop of
millimetres (pymunk's default of 0.1 assumes pixels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import pymunk
from numpy.typing import ArrayLike, NDArray

from merging.validators import real_number, whole_number
from tomosim.ray_geometry import distance_to_segments
from tomosim.robot import ROBOT_RADIUS_M
from tomosim.worlds.world import as_segments

MAX_SUBSTEP_TRAVEL = 0.25
"""Largest fraction of its radius a robot may travel in one physics substep;
far below 1, so a disc never gets its centre past a zero-thickness wall."""
MAX_SUBSTEPS = 10_000
"""Most physics substeps one step may need (the default needs 2): a speed or step
length that needs more is refused instead of stepping for hours."""
CONTACT_TOLERANCE = 0.01
"""Metres within which :meth:`Physics.in_contact` counts a robot as touching:
above the collision slop, below any gap a robot would drive through."""
ROBOT_GROUP_OFFSET = 1
"""Robot ``i``'s shapes are in pymunk group ``i + ROBOT_GROUP_OFFSET`` (group 0 means none)."""
SET_VELOCITY = cast(Any, pymunk.Body.velocity).fset  # pymunk types it as a method
"""The setter of a body's velocity (:meth:`Physics.drive` calls it directly)."""
SET_ANGULAR_VELOCITY = cast(Any, pymunk.Body.angular_velocity).fset
"""The setter of a body's angular velocity (:meth:`Physics.drive` calls it directly)."""
GET_ANGLE = cast(Any, pymunk.Body.angle).fget
"""The getter of a body's angle (:meth:`Physics.drive` calls it directly)."""


@dataclass(frozen=True)
class PhysicsConfig:
    """Robot body and drive parameters (SI units).

    Attributes
    ----------
    robot_radius : float
        Radius of the robot disc, metres.
    robot_mass : float
        Kilograms.
    max_linear_speed, max_angular_speed : float
        Speeds that a normalised command of 1 asks for (m/s, rad/s).
    max_linear_acceleration, max_angular_acceleration : float
        What the drive can achieve (m/s^2, rad/s^2); they cap the joint forces.
    collision_slop : float
        Overlap pymunk tolerates between shapes, metres.
    solver_iterations : int
        pymunk solver iterations per substep.
    """

    robot_radius: float = ROBOT_RADIUS_M
    robot_mass: float = 10.0
    max_linear_speed: float = 1.0
    max_angular_speed: float = 2.0
    max_linear_acceleration: float = 5.0
    max_angular_acceleration: float = 20.0
    collision_slop: float = 0.002
    solver_iterations: int = 10

    def __post_init__(self) -> None:
        for name in (
            "robot_radius",
            "robot_mass",
            "max_linear_speed",
            "max_angular_speed",
            "max_linear_acceleration",
            "max_angular_acceleration",
            "collision_slop",
        ):
            real_number(getattr(self, name), name, low=0.0, low_open=True)
        if self.collision_slop >= 0.1 * self.robot_radius:
            raise ValueError(
                f"collision_slop ({self.collision_slop} m) must be well below the "
                f"robot radius ({self.robot_radius} m)"
            )
        whole_number(self.solver_iterations, "solver_iterations", minimum=1)

    def substeps(self, dt: float) -> int:
        """Substeps per step of ``dt`` seconds that keep travel below
        :data:`MAX_SUBSTEP_TRAVEL` radii per substep."""
        travel = self.max_linear_speed * dt
        count = max(1, math.ceil(travel / (MAX_SUBSTEP_TRAVEL * self.robot_radius)))
        if count > MAX_SUBSTEPS:
            raise ValueError(
                f"a step of {dt:g} s at {self.max_linear_speed:g} m/s needs {count} physics "
                f"substeps (more than {MAX_SUBSTEPS}); lower dt or max_linear_speed"
            )
        return count


def build_space(walls: ArrayLike, *, collision_slop: float = 0.002) -> pymunk.Space:
    """A pymunk space holding ``walls`` as static zero-radius segments (metres)."""
    segments = as_segments(walls)
    space = pymunk.Space()
    space.gravity = (0.0, 0.0)
    space.collision_slop = collision_slop
    shapes = []
    for (x0, y0), (x1, y1) in segments:
        shape = pymunk.Segment(space.static_body, (x0, y0), (x1, y1), 0.0)
        shape.friction = 0.0
        shape.elasticity = 0.0
        shapes.append(shape)
    space.add(*shapes)
    return space


class Physics:
    """A pymunk world of static walls and differential-drive robots.

    Parameters
    ----------
    walls : (W, 2, 2) float ndarray
        Wall segments, metres.
    poses : (N, 3) float ndarray
        Initial robot poses ``(x, y, theta)``.
    config : PhysicsConfig
        Robot and drive parameters.
    """

    __slots__ = ("bodies", "config", "controls", "space", "walls")

    def __init__(self, walls: ArrayLike, poses: ArrayLike, config: PhysicsConfig) -> None:
        if not isinstance(config, PhysicsConfig):
            raise TypeError(f"config must be a PhysicsConfig, got {type(config).__name__}")
        start = np.asarray(poses, dtype=float)
        if start.ndim != 2 or start.shape[1] != 3 or not np.all(np.isfinite(start)):
            raise ValueError(
                f"poses must be a finite (N, 3) array of (x, y, theta), got shape {start.shape}"
            )
        self.config = config
        self.walls = as_segments(walls)
        self.space = build_space(self.walls, collision_slop=config.collision_slop)
        self.space.iterations = config.solver_iterations
        radius, mass = config.robot_radius, config.robot_mass
        moment = pymunk.moment_for_circle(mass, 0.0, radius)
        self.bodies: list[pymunk.Body] = []
        self.controls: list[pymunk.Body] = []
        for index, (x, y, theta) in enumerate(start):
            body = pymunk.Body(mass, moment)
            body.position = (float(x), float(y))
            body.angle = float(theta)
            shape = pymunk.Circle(body, radius)
            shape.friction = 0.0
            shape.elasticity = 0.0
            shape.filter = pymunk.ShapeFilter(group=index + ROBOT_GROUP_OFFSET)
            control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            control.position = body.position
            control.angle = body.angle
            pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
            pivot.max_bias = 0.0  # follow the control body's velocity, not its position
            pivot.max_force = mass * config.max_linear_acceleration
            gear = pymunk.GearJoint(control, body, 0.0, 1.0)
            gear.max_bias = 0.0  # follow its angular velocity, not its angle
            gear.max_force = moment * config.max_angular_acceleration
            self.space.add(body, shape, control, pivot, gear)
            self.bodies.append(body)
            self.controls.append(control)

    @property
    def count(self) -> int:
        """Number of robots."""
        return len(self.bodies)

    def poses(self) -> NDArray[np.float64]:
        """``(N, 3)`` true poses ``(x, y, theta)``, ``theta`` wrapped to ``[-pi, pi)``."""
        turn = 2 * math.pi
        # Python's float modulo is numpy's (np.mod): the sign of the divisor, exactly.
        rows = [(*b.position, (b.angle + math.pi) % turn - math.pi) for b in self.bodies]
        return np.array(rows, dtype=np.float64).reshape(-1, 3)

    def in_contact(self, *, tolerance: float = CONTACT_TOLERANCE) -> NDArray[np.bool_]:
        """``(N,)`` whether each robot is within ``tolerance`` metres of touching a
        wall or another robot."""
        poses = self.poses()
        reach = self.config.robot_radius + tolerance
        touching = distance_to_segments(poses[:, :2], self.walls) <= reach
        gaps = np.hypot(*(poses[:, None, :2] - poses[None, :, :2]).transpose(2, 0, 1))
        np.fill_diagonal(gaps, np.inf)
        touching |= np.any(gaps <= 2 * self.config.robot_radius + tolerance, axis=1)
        return touching

    def step(self, linear: ArrayLike, angular: ArrayLike, dt: float) -> None:
        """Drive every robot for ``dt`` seconds.

        Parameters
        ----------
        linear : (N,) float array_like
            Forward speeds asked for, m/s (clipped to ``max_linear_speed``).
        angular : (N,) float array_like
            Turn rates asked for, rad/s, counter-clockwise (clipped to
            ``max_angular_speed``).
        dt : float
            Seconds; split into :meth:`PhysicsConfig.substeps` substeps.
        """
        cfg = self.config
        v = np.asarray(linear, dtype=float)
        w = np.asarray(angular, dtype=float)
        if v.shape != (self.count,) or w.shape != (self.count,):
            raise ValueError(
                f"linear and angular must have shape ({self.count},), got {v.shape} and {w.shape}"
            )
        speeds, turns = v.tolist(), w.tolist()
        if not all(math.isfinite(value) for value in speeds + turns):
            raise ValueError("linear and angular speeds must be finite")
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt}")
        top_speed, top_turn = cfg.max_linear_speed, cfg.max_angular_speed
        speeds = [min(max(value, -top_speed), top_speed) for value in speeds]
        turns = [min(max(value, -top_turn), top_turn) for value in turns]
        self.drive(speeds, turns, dt)

    def drive(self, speeds: list[float], turns: list[float], dt: float) -> None:
        """:meth:`step` with its arguments checked: one finite speed (m/s) and turn rate
        (rad/s) per robot within the limits, and ``dt > 0`` seconds."""
        substeps = self.config.substeps(dt)
        h = dt / substeps
        # The properties' own setters and getter, called directly: pymunk routes every
        # attribute access through a generic __setattr__ that doubles a setter's cost.
        set_velocity, set_turn = SET_VELOCITY, SET_ANGULAR_VELOCITY
        # A turn rate is the control body's own; nothing else changes it (a kinematic
        # body's velocity is only what it is set to): set once a step.
        for control, turn in zip(self.controls, turns, strict=True):
            set_turn(control, turn)
        for _ in range(substeps):
            for body, control, speed in zip(self.bodies, self.controls, speeds, strict=True):
                heading = GET_ANGLE(body)
                set_velocity(control, (speed * math.cos(heading), speed * math.sin(heading)))
            self.space.step(h)
