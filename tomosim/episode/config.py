"""What defines an episode: the world it explores and its settings.

A world is named by a generated floor plan's seed or a ``map_server`` YAML
file (:func:`load_world`); :class:`EpisodeConfig` holds everything else: the
team size, the policy, when the episode ends, its seed and, in its ``team``
(:class:`~tomosim.team.TeamConfig`), every setting of the team.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from merging.catalog import find_map
from merging.validators import SettingTypeError, one_of, real_number, whole_number
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.team.config import TeamConfig
from tomosim.team.overrides import changed_settings
from tomosim.worlds import World, generate_floorplan, world_from_map

DEFAULT_WORLD_SEED = 0
"""Seed of the generated floor plan explored by default."""
DEFAULT_ROBOTS = 3
"""Robots of a team unless told otherwise: the smallest team in which linking can check
one pair's transform against the chain through a third map (:func:`merging.link_maps`,
step 2)."""
DEFAULT_COVERAGE_TARGET = 0.9
"""Fraction of the free space at which an episode ends unless told otherwise, in the
episode runner, the environment and sweeps alike: the project's exploration figures
are times to 90 % coverage (``docs/figures/study_exploration``)."""


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
        if size is not None:
            _check_world_size(size)
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


def _check_world_size(size: tuple[float, float]) -> None:
    """Raise naming ``world_size`` unless ``size`` is two positive numbers of metres."""
    message = f"world_size must be (width, height), two positive numbers of metres, got {size!r}"
    if isinstance(size, str):
        raise ValueError(message)
    try:
        sides = tuple(size)
    except TypeError:
        raise ValueError(message) from None
    if len(sides) != 2:
        raise ValueError(message)
    for side in sides:
        try:
            real_number(side, "world_size", low=0.0, low_open=True, unit="metres")
        except ValueError:
            raise ValueError(message) from None


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
        Number of robots (:data:`DEFAULT_ROBOTS`).
    policy : str
        Exploration policy: how robots choose frontiers
        (:func:`~tomosim.exploration.chooser_names`).
    steps : int
        Most steps to run (``simulation.dt`` of simulated time each, 0.1 s by
        default). The default, 200 s simulated, lets four robots explore 90 %
        of ``aces3`` (1120 m²).
    coverage_target : float
        Fraction of the free space at which the episode ends
        (:data:`DEFAULT_COVERAGE_TARGET`).
    seed : int
        Seed of everything random in the episode (start poses, sensors, merging).
    record : Path or None
        ``.rrd`` file to record the episode to (None: no recording).
    team : TeamConfig
        Every setting of the team: merging (on or off, method, interval,
        confirmation, tracking), map sharing, communication range and the
        simulation (defaults as documented there).
    """

    world: int | str | Path = DEFAULT_WORLD_SEED
    world_size: tuple[float, float] | None = None
    robots: int = DEFAULT_ROBOTS
    policy: str = DEFAULT_POLICY
    steps: int = 2000
    coverage_target: float = DEFAULT_COVERAGE_TARGET
    seed: int = 0
    record: Path | None = None
    team: TeamConfig = field(default_factory=TeamConfig)

    def __post_init__(self) -> None:
        whole_number(self.robots, "robots", minimum=1)
        whole_number(self.steps, "steps", minimum=1)
        whole_number(self.seed, "seed", minimum=0)
        real_number(self.coverage_target, "coverage_target", low=0.0, high=1.0, low_open=True)
        world = self.world
        if isinstance(world, bool) or not isinstance(world, int | np.integer | str | Path):
            raise SettingTypeError(
                f"world must be a seed or a map file path, got {type(self.world).__name__}"
            )
        if self.world_size is not None:
            _check_world_size(self.world_size)
        one_of(self.policy, chooser_names(), what="exploration policy")
        if not isinstance(self.team, TeamConfig):
            raise SettingTypeError(f"team must be a TeamConfig, got {type(self.team).__name__}")

    def with_team(self, **changes: Any) -> EpisodeConfig:
        """A copy whose team has ``changes``: ``config.with_team(merge=False)``."""
        return replace(self, team=replace(self.team, **changes))

    def settings(self, world: World) -> dict[str, Any]:
        """Plain values describing the episode (recorded with it and printed in reports).

        The team's other settings, where they differ from the defaults, are under
        ``team`` by their dotted names (:func:`tomosim.team.overrides.changed_settings`);
        a team of defaults adds nothing.
        """
        team = self.team
        settings = {
            "world": world.name,
            "world_spec": str(self.world),
            "robots": int(self.robots),
            "policy": self.policy,
            "steps": int(self.steps),
            "merge": bool(team.merge),
            "merge_interval": int(team.merge_interval),
            "unlinked_merge_interval": int(team.unlinked_merge_interval),
            "method": team.method,
            "coverage_target": float(self.coverage_target),
            "comm_range": None if team.comms.range is None else float(team.comms.range),
            "line_of_sight": bool(team.comms.line_of_sight),
            "seed": int(self.seed),
            "dt": float(team.simulation.dt),
        }
        others = other_team_settings(team)
        if others:
            settings["team"] = others
        return settings


LISTED_TEAM_SETTINGS = (
    "merge",
    "merge_interval",
    "unlinked_merge_interval",
    "method",
    "comms.range",
    "comms.line_of_sight",
    "simulation.dt",
)
"""Team settings :meth:`EpisodeConfig.settings` names by themselves (``simulation.dt`` as
``dt``), not under ``team``."""


def other_team_settings(team: TeamConfig) -> dict[str, Any]:
    """The settings in which ``team`` differs from the defaults, by dotted name, but those
    :data:`LISTED_TEAM_SETTINGS` (``team`` in :meth:`EpisodeConfig.settings`)."""
    return {
        name: value
        for name, value in changed_settings(team).items()
        if name not in LISTED_TEAM_SETTINGS
    }
