"""What defines an episode: the world it explores and its settings.

A world is named by a generated floor plan's seed or a ``map_server`` YAML
file (:func:`load_world`); :class:`EpisodeConfig` holds everything else.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from merging.api import DEFAULT_METHOD
from merging.catalog import find_map
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.simulation import SimulationConfig
from tomosim.team.comms import CommsConfig
from tomosim.team.oracle import check_team_method
from tomosim.worlds import World, generate_floorplan, world_from_map

DEFAULT_WORLD_SEED = 0
"""Seed of the generated floor plan explored by default."""


def load_world(spec: int | str | Path, *, size: tuple[float, float] | None = None) -> World:
    """The world named by ``spec``: a generated floor plan's seed, a map's name or its YAML file.

    Parameters
    ----------
    spec : int, str or Path
        A non-negative integer (or a string of digits) is the seed of
        :func:`~tomosim.worlds.generate_floorplan`; a name such as ``"aces3"``
        is a map of the maps path (:func:`merging.catalog.find_map`; ``tomosim
        maps`` lists them); a path is a ``map_server`` YAML file
        (:func:`~tomosim.worlds.world_from_map`).
    size : (float, float), optional
        Width and height in metres of a generated floor plan (default 30 x 20).

    Raises
    ------
    FileNotFoundError
        If the map file does not exist, or no folder of the maps path holds a
        map of that name (the message lists the folders searched).
    ValueError
        If the seed is negative or the map file cannot be read.
    """
    if isinstance(spec, str) and spec.strip().lstrip("+-").isdigit():
        spec = int(spec)
    if isinstance(spec, int | np.integer) and not isinstance(spec, bool):
        if spec < 0:
            raise ValueError(f"a world seed must be a non-negative integer, got {spec}")
        width, height = size if size is not None else (None, None)
        return generate_floorplan(int(spec), width=width, height=height)
    if not isinstance(spec, str | Path):
        raise TypeError(
            f"world must be a seed, a map name or a map file path, got {type(spec).__name__}"
        )
    path = find_map(spec)
    if not path.is_file():
        raise FileNotFoundError(f"map file not found: {path}")
    return world_from_map(path)


@dataclass(frozen=True)
class EpisodeConfig:
    """Everything that defines an episode.

    Attributes
    ----------
    world : int, str or Path
        A generated floor plan's seed or a map_server YAML file (:func:`load_world`).
    world_size : (float, float) or None
        Width and height in metres of a generated floor plan (None: 30 x 20).
    robots : int
        Number of robots.
    policy : str
        Exploration policy: how robots choose frontiers
        (:func:`~tomosim.exploration.chooser_names`).
    steps : int
        Most steps to run (``simulation.dt`` of simulated time each, 0.1 s by
        default). The default, 200 s simulated, lets four robots explore 90 %
        of ``aces3`` (1120 m²).
    merge : bool
        Whether the robots' maps are merged.
    merge_interval : int
        Steps between merge rounds.
    method : str
        Merging method, or ``"oracle"`` (the true start poses;
        :mod:`tomosim.team.oracle`).
    coverage_target : float
        Fraction of the free space at which the episode ends.
    comm_range : float or None
        Metres over which robots can talk (None: unlimited; :mod:`tomosim.team.comms`).
    line_of_sight : bool
        Whether walls block communication (needs ``comm_range``).
    seed : int
        Seed of everything random in the episode (start poses, sensors, merging).
    record : Path or None
        ``.rrd`` file to record the episode to (None: no recording).
    simulation : SimulationConfig
        Robots, lidar, odometry and mapping (defaults as documented there).
    """

    world: int | str | Path = DEFAULT_WORLD_SEED
    world_size: tuple[float, float] | None = None
    robots: int = 3
    policy: str = DEFAULT_POLICY
    steps: int = 2000
    merge: bool = True
    merge_interval: int = 50
    method: str = DEFAULT_METHOD
    coverage_target: float = 0.9
    comm_range: float | None = None
    line_of_sight: bool = False
    seed: int = 0
    record: Path | None = None
    simulation: SimulationConfig = field(default_factory=SimulationConfig)

    def __post_init__(self) -> None:
        for name in ("robots", "steps", "merge_interval"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (isinstance(value, int | np.integer) and value >= 1):
                raise ValueError(f"{name} must be a whole number >= 1, got {value!r}")
        if isinstance(self.seed, bool) or not (
            isinstance(self.seed, int | np.integer) and self.seed >= 0
        ):
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}")
        target = self.coverage_target
        if isinstance(target, bool) or not isinstance(target, numbers.Real):
            raise TypeError(f"coverage_target must be a number in (0, 1], got {target!r}")
        if not (0.0 < target <= 1.0):
            raise ValueError(f"coverage_target must be in (0, 1], got {target}")
        world = self.world
        if isinstance(world, bool) or not isinstance(world, int | np.integer | str | Path):
            raise TypeError(
                f"world must be a seed or a map file path, got {type(self.world).__name__}"
            )
        if self.world_size is not None:
            sides = tuple(self.world_size)
            if len(sides) != 2 or not all(
                isinstance(side, numbers.Real)
                and not isinstance(side, bool)
                and math.isfinite(side)
                and side > 0
                for side in sides
            ):
                raise ValueError(
                    f"world_size must be (width, height), two positive numbers of metres, "
                    f"got {self.world_size!r}"
                )
        if self.policy not in chooser_names():
            choices = ", ".join(chooser_names())
            raise ValueError(
                f"unknown exploration policy {self.policy!r}; choose one of: {choices}"
            )
        check_team_method(self.method)
        self.comms()  # validates the range

    def comms(self) -> CommsConfig:
        """The team's communication settings."""
        return CommsConfig(self.comm_range, self.line_of_sight)

    def settings(self, world: World) -> dict[str, Any]:
        """Plain values describing the episode (recorded with it and printed in reports)."""
        return {
            "world": world.name,
            "world_spec": str(self.world),
            "robots": int(self.robots),
            "policy": self.policy,
            "steps": int(self.steps),
            "merge": bool(self.merge),
            "merge_interval": int(self.merge_interval),
            "method": self.method,
            "coverage_target": float(self.coverage_target),
            "comm_range": None if self.comm_range is None else float(self.comm_range),
            "line_of_sight": bool(self.line_of_sight),
            "seed": int(self.seed),
            "dt": float(self.simulation.dt),
        }
