"""What a sweep runs: the grid of episodes and the key naming each one."""

from __future__ import annotations

import hashlib
import math
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from merging.catalog import is_map_path
from tomosim.episode import EpisodeConfig
from tomosim.exploration import DEFAULT_POLICY, chooser_names
from tomosim.team import CommsConfig, team_methods
from tomosim.worlds import FloorplanConfig

NO_MERGE = "none"
"""Method name standing for an episode with merging switched off."""


def _whole(value: object) -> bool:
    """Whether ``value`` is a whole number (an int, not a bool)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


@dataclass(frozen=True, slots=True)
class Episode:
    """One episode of a sweep: its key (unique in the sweep) and configuration."""

    key: str
    config: EpisodeConfig


@dataclass(frozen=True, slots=True)
class SweepPlan:
    """A grid of episodes: every combination of worlds, team sizes, policies, methods and seeds.

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
        the true start poses), or ``"none"`` for merging switched off.
    seeds : tuple of int
        Episode seeds.
    steps, merge_interval : int
        Per episode, as :class:`~tomosim.episode.EpisodeConfig`.
    coverage_target : float
        Team coverage at which an episode ends.
    world_size : (float, float) or None
        Size in metres of generated floor plans (None: the default 30 x 20).
    comm_range : float or None
        Metres over which robots can talk (None: unlimited).
    line_of_sight : bool
        Whether walls block communication.
    record_dir : Path or None
        Folder for one ``.rrd`` recording per episode (None: no recordings).
    """

    worlds: tuple[str, ...] = ("0",)
    robots: tuple[int, ...] = (3,)
    policies: tuple[str, ...] = (DEFAULT_POLICY,)
    methods: tuple[str, ...] = ("tomographic",)
    seeds: tuple[int, ...] = (0,)
    steps: int = EpisodeConfig.steps
    merge_interval: int = 50
    coverage_target: float = 0.9
    world_size: tuple[float, float] | None = None
    comm_range: float | None = None
    line_of_sight: bool = False
    record_dir: Path | None = None

    def __post_init__(self) -> None:
        for name in ("worlds", "robots", "policies", "methods", "seeds"):
            values = getattr(self, name)
            if isinstance(values, str | bytes) or not isinstance(values, tuple | list):
                raise ValueError(f"{name} must be a tuple of values, got {values!r}")
            if len(values) == 0:
                raise ValueError(f"a sweep needs at least one value of {name}")
        object.__setattr__(self, "worlds", tuple(world_name(world) for world in self.worlds))
        for name, least in (("robots", 1), ("seeds", 0)):
            bad = [v for v in getattr(self, name) if not _whole(v) or v < least]
            if bad:
                raise ValueError(f"{name} must be whole numbers >= {least}, got {bad[0]!r}")
        for name in ("steps", "merge_interval"):
            value = getattr(self, name)
            if not _whole(value) or value < 1:
                raise ValueError(f"{name} must be a whole number >= 1, got {value!r}")
        target = self.coverage_target
        if isinstance(target, bool) or not isinstance(target, int | float) or not 0 < target <= 1:
            raise ValueError(f"coverage_target must be a number in (0, 1], got {target!r}")
        if self.world_size is not None and (
            len(self.world_size) != 2
            or not all(
                isinstance(v, int | float) and math.isfinite(v) and v > 0 for v in self.world_size
            )
        ):
            raise ValueError(f"world_size must be two positive metres, got {self.world_size!r}")
        if self.world_size is not None:
            width, height = self.world_size
            try:  # a floor plan's own limits, checked before any episode runs
                FloorplanConfig(width=float(width), height=float(height))
            except ValueError as exc:
                raise ValueError(f"world_size {width:g} x {height:g} m: {exc}") from None
        unknown = [m for m in self.methods if m != NO_MERGE and m not in team_methods()]
        if unknown:
            choices = ", ".join([*team_methods(), NO_MERGE])
            raise ValueError(f"unknown merging method {unknown[0]!r}; choose from: {choices}")
        strange = [p for p in self.policies if p not in chooser_names()]
        if strange:
            raise ValueError(
                f"unknown exploration policy {strange[0]!r}; choose from: "
                f"{', '.join(chooser_names())}"
            )
        CommsConfig(self.comm_range, self.line_of_sight)  # validates the range
        for name in ("robots", "seeds", "policies", "methods", "worlds"):
            values = getattr(self, name)
            if len(set(values)) != len(values):
                raise ValueError(f"{name} lists a value twice: {list(values)}")

    def settings(self) -> dict[str, object]:
        """What every episode shares, by results-file column; a results file is tied to these."""
        return {
            "steps_limit": self.steps,
            "merge_interval": self.merge_interval,
            "coverage_target": self.coverage_target,
            "world_size": "default"
            if self.world_size is None
            else "x".join(f"{v:g}" for v in self.world_size),
            "comm_range": "unlimited"
            if self.comm_range is None
            else f"{self.comm_range:g}" + (" los" if self.line_of_sight else ""),
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

    def episode(self, world: str, robots: int, policy: str, method: str, seed: int) -> Episode:
        """One episode of the grid (any values, not only the plan's own)."""
        key = episode_key(world, robots, policy, method, seed)
        merge = method != NO_MERGE
        config = EpisodeConfig(
            world=world,
            world_size=self.world_size,
            robots=robots,
            policy=policy,
            steps=self.steps,
            merge=merge,
            merge_interval=self.merge_interval,
            method=method if merge else EpisodeConfig.method,
            coverage_target=self.coverage_target,
            comm_range=self.comm_range,
            line_of_sight=self.line_of_sight,
            seed=seed,
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
