"""The figures of a finished episode that a learner's logs show, for every trainer alike.

The parallel environment puts an ``episode`` dictionary into each agent's
info at the last step of an episode (its spec card,
:mod:`envs.multi_robot_exploration_v0`). :func:`episode_scalars` turns it
into the plain numbers that the Stable-Baselines3 TensorBoard callback
(``scripts/train_ppo.py --tensorboard``) and the RLlib callback
(:class:`envs.rllib.ExplorationMetricsCallback`) log, under the same names:

====================  =====================================================================
name                  meaning
====================  =====================================================================
return_per_robot      the episode's return, averaged over the robots (square metres)
team_coverage         fraction of the free space the team knows at the end
target_reached        1 if the team reached ``coverage_target`` (default 0.9), else 0
steps_to_target       steps until it did; left out of an episode that did not reach it,
                      so its mean is over the episodes that did (read it with
                      ``target_reached``)
path_length_m         metres the robots travelled, all together
overlap_rate          the sum of the robots' own coverages over the team's, less one
pairs_accepted        pair estimates the merger accepted, summed over the merge rounds
pairs_confirmed       those of them that the next round confirmed
====================  =====================================================================

This module imports neither a trainer nor a logger.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

EPISODE_SCALARS = (
    "return_per_robot",
    "team_coverage",
    "target_reached",
    "steps_to_target",
    "path_length_m",
    "overlap_rate",
    "pairs_accepted",
    "pairs_confirmed",
)
"""The names :func:`episode_scalars` returns, in the order of the module docstring."""


def episode_scalars(episode: Mapping[str, Any]) -> dict[str, float]:
    """The scalars of the module docstring from an agent's ``info["episode"]``.

    Parameters
    ----------
    episode : mapping
        The ``episode`` entry of the last step's info (or ``env.last_episode``).

    Returns
    -------
    dict of str to float
        Every name of :data:`EPISODE_SCALARS`, but ``steps_to_target`` only when
        the target was reached.
    """
    missing = [key for key in ("returns", "team_coverage", "steps_to_target") if key not in episode]
    if missing:
        raise ValueError(
            f"not an episode summary of the exploration environment: it lacks {missing}; "
            "pass info['episode'] of an episode's last step"
        )
    reached = episode["steps_to_target"] is not None
    scalars = {
        "return_per_robot": float(np.mean(list(episode["returns"].values()))),
        "team_coverage": float(episode["team_coverage"]),
        "target_reached": float(reached),
        "path_length_m": float(episode["path_length_m"]),
        "overlap_rate": float(episode["overlap_rate"]),
        "pairs_accepted": float(episode["pairs_accepted"]),
        "pairs_confirmed": float(episode["pairs_confirmed"]),
    }
    if reached:
        scalars["steps_to_target"] = float(episode["steps_to_target"])
    return {name: scalars[name] for name in EPISODE_SCALARS if name in scalars}
