"""What a sweep runs: the grid of episodes and the key naming each one."""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

from merging.catalog import is_map_path
from merging.validators import SettingTypeError, one_of, whole_number
from tomosim.episode import DEFAULT_COVERAGE_TARGET, DEFAULT_WORLD_SEED, EpisodeConfig
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.team import TeamConfig, team_methods
from tomosim.team.config import for_method
from tomosim.worlds import FloorplanConfig

NO_MERGE = "none"
"""Method name standing for an episode with merging switched off."""


@dataclass(frozen=True, slots=True)
class Episode:
    """One episode of a sweep: its key (unique in the sweep) and configuration."""

    key: str
    config: EpisodeConfig


@dataclass(frozen=True, slots=True)
class SweepPlan:
    """A grid of episodes: every combination of worlds, team sizes, policies, methods and seeds.

    Every episode is an :class:`~tomosim.episode.EpisodeConfig`; what the grid
    does not vary is set once for all of them (``steps``, ``coverage_target``,
    ``world_size``, ``team``), with the episode's and the team's defaults.

    Attributes
    ----------
    worlds : tuple of str
        Generated floor-plan seeds (``"0"``) or map_server YAML paths, kept as
        their absolute paths (:func:`world_name`: episodes are found by them
        when a sweep resumes).
    robots : tuple of int
        Team sizes.
    policies : tuple of str
        Exploration policies (:func:`~tomosim.exploration.chooser_names`).
    methods : tuple of str
        Merging methods (:func:`merging.available_methods`, or ``"oracle"``:
        the true start poses), or ``"none"`` for merging switched off; each
        episode's team merges with its own (``team.merge`` and ``team.method``
        are set from it).
    seeds : tuple of int
        Episode seeds.
    steps : int
        Most steps per episode, as :class:`~tomosim.episode.EpisodeConfig`.
    coverage_target : float
        Team coverage at which an episode ends.
    world_size : (float, float) or None
        Size in metres of generated floor plans (None: the default 30 x 20).
    team : TeamConfig
        Every other setting of the teams: merge interval, communication range,
        confirmation, tracking, simulation.
    record_dir : Path or None
        Folder for one ``.rrd`` recording per episode (None: no recordings).
    """

    worlds: tuple[str, ...] = (str(DEFAULT_WORLD_SEED),)
    robots: tuple[int, ...] = (EpisodeConfig.robots,)
    policies: tuple[str, ...] = (DEFAULT_POLICY,)
    methods: tuple[str, ...] = (TeamConfig.method,)
    seeds: tuple[int, ...] = (EpisodeConfig.seed,)
    steps: int = EpisodeConfig.steps
    coverage_target: float = DEFAULT_COVERAGE_TARGET
    world_size: tuple[float, float] | None = None
    team: TeamConfig = field(default_factory=TeamConfig)
    record_dir: Path | None = None

    def __post_init__(self) -> None:
        for name in ("worlds", "robots", "policies", "methods", "seeds"):
            values = getattr(self, name)
            if isinstance(values, str | bytes) or not isinstance(values, tuple | list):
                raise ValueError(f"{name} must be a tuple of values, got {values!r}")
            if len(values) == 0:
                raise ValueError(f"a sweep needs at least one value of {name}")
        object.__setattr__(self, "worlds", tuple(world_name(world) for world in self.worlds))
        for k, world in enumerate(self.worlds):
            if world.startswith("-") and world[1:].isdigit():
                raise ValueError(
                    f"worlds[{k}] must be a floor plan's seed (a whole number >= 0) or a map, "
                    f"got {world}"
                )
        for name, least in (("robots", 1), ("seeds", 0)):
            for k, value in enumerate(getattr(self, name)):
                whole_number(value, f"{name}[{k}]", minimum=least)
        if not isinstance(self.team, TeamConfig):
            raise SettingTypeError(f"team must be a TeamConfig, got {type(self.team).__name__}")
        # What every episode shares is checked as the episodes will check it.
        EpisodeConfig(
            steps=self.steps,
            coverage_target=self.coverage_target,
            world_size=self.world_size,
            team=self.team,
        )
        if self.world_size is not None:
            width, height = self.world_size
            try:  # a floor plan's own limits, checked before any episode runs
                FloorplanConfig(width=float(width), height=float(height))
            except ValueError as exc:
                raise ValueError(f"world_size {width:g} x {height:g} m: {exc}") from None
        for method in self.methods:
            one_of(method, (*team_methods(), NO_MERGE), what="merging method")
        for policy in self.policies:
            one_of(policy, chooser_names(), what="exploration policy")
        for name in ("robots", "seeds", "policies", "methods", "worlds"):
            values = getattr(self, name)
            if len(set(values)) != len(values):
                raise ValueError(f"{name} lists a value twice: {list(values)}")

    def settings(self) -> dict[str, object]:
        """What every episode shares, by results-file column; a results file is tied to these."""
        comms = self.team.comms
        return {
            "steps_limit": self.steps,
            "merge_interval": self.team.merge_interval,
            "coverage_target": self.coverage_target,
            "world_size": "default"
            if self.world_size is None
            else "x".join(f"{v:g}" for v in self.world_size),
            "comm_range": "unlimited"
            if comms.range is None
            else f"{comms.range:g}" + (" los" if comms.line_of_sight else ""),
        }

    def episodes(self) -> list[Episode]:
        """Every episode, in a fixed order (worlds, robots, policies, methods, seeds)."""
        return [
            self.episode(world, robots, policy, method, seed)
            for world in self.worlds
            for robots in self.robots
            for policy in self.policies
            for method in self.methods
            for seed in self.seeds
        ]

    def team_of(self, method: str) -> TeamConfig:
        """The team of the plan's episodes that merge with ``method`` (:data:`NO_MERGE`:
        merging off), keeping only that method's own settings
        (:func:`tomosim.team.config.for_method`)."""
        merge = method != NO_MERGE
        return for_method(self.team, method if merge else TeamConfig.method, merge=merge)

    def episode(self, world: str, robots: int, policy: str, method: str, seed: int) -> Episode:
        """One episode of the grid (any values, not only the plan's own)."""
        key = episode_key(world, robots, policy, method, seed)
        config = EpisodeConfig(
            world=world,
            world_size=self.world_size,
            robots=robots,
            policy=policy,
            steps=self.steps,
            coverage_target=self.coverage_target,
            seed=seed,
            team=self.team_of(method),
        )
        if self.record_dir is not None:
            config = replace(config, record=self.record_dir / recording_name(key))
        return Episode(key, config)


def world_name(world: object) -> str:
    """How a sweep names a world: a seed as its number, a map by its name, a map file by
    its absolute path.

    A resumed sweep finds its episodes by name, so one map must have one name
    however it was typed (``odd/a.yaml``, ``./odd/a.yaml`` or ``a.yaml`` from
    ``odd/``), and two maps of one file name in two folders two names. A map of
    the maps path named by its name (``aces3``) keeps the name, which means the
    same map on every machine that has it (:mod:`merging.catalog`).
    """
    text = str(world)
    if text.strip().lstrip("+-").isdigit():
        return str(int(text))
    if isinstance(world, str) and not is_map_path(world) and not Path(text).suffix:
        return text.strip("/")
    return os.path.abspath(os.path.expanduser(text))


def episode_key(world: str, robots: int, policy: str, method: str, seed: int) -> str:
    """``world|robots|policy|method|seed``: names an episode within a sweep."""
    return f"{world}|{robots}|{policy}|{method}|{seed}"


def recording_name(key: str) -> str:
    """The file name of an episode's recording: its key made file-safe, a map named by
    its file's stem and a short hash of its path (a whole path could pass the 255-byte
    limit on file names, and two maps of one name in two folders must not share one)."""
    world, sep, rest = key.partition("|")
    if not world.isdigit():
        digest = hashlib.sha1(world.encode()).hexdigest()[:8]
        world = f"{Path(world).stem}-{digest}"
    return f"{_file_safe(world + sep + rest)}.rrd"


def _file_safe(key: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", key).strip("_")
