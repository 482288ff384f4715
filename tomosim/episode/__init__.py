"""One exploration episode with the built-in policy: ``run_episode(config) -> metrics``.

* :mod:`tomosim.episode.config`: :class:`EpisodeConfig` and :func:`load_world`;
* :mod:`tomosim.episode.runner`: :func:`run_episode`, which builds the world,
  the team, the policies and (when asked) the recording from a configuration;
* :mod:`tomosim.episode.outcome`: :class:`EpisodeMetrics`, what it returns.
"""

from tomosim.episode.config import (
    DEFAULT_COVERAGE_TARGET,
    DEFAULT_ROBOTS,
    DEFAULT_WORLD_SEED,
    EpisodeConfig,
    load_world,
)
from tomosim.episode.outcome import EpisodeMetrics, MergeRound, odometry_drift
from tomosim.episode.runner import (
    STOP_FINISHED,
    STOP_STEPS,
    STOP_TARGET,
    Progress,
    run_episode,
)

__all__ = [
    "DEFAULT_COVERAGE_TARGET",
    "DEFAULT_ROBOTS",
    "DEFAULT_WORLD_SEED",
    "STOP_FINISHED",
    "STOP_STEPS",
    "STOP_TARGET",
    "EpisodeConfig",
    "EpisodeMetrics",
    "MergeRound",
    "Progress",
    "load_world",
    "odometry_drift",
    "run_episode",
]
