"""A trained policy and three baselines on the same held-out episodes.

After training, the policy and three baselines run the same episodes on
held-out floors (``HELD_OUT_FLOORS``, never drawn in training):

* ``random``: uniform random actions;
* ``best_constant``: the constant action (of a grid of forward arcs) with
  the highest mean coverage on these very episodes, the strongest
  observation-blind policy;
* ``frontier``: frontier exploration on the robots' whole best maps
  (**privileged**: it reads more than the observation).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from envs import multi_robot_exploration_v0 as exploration
from envs.scripted_agents import ConstantBaseline, FrontierBaseline, RandomBaseline

EVALUATION_SEED = 10_000
"""Evaluation episode ``e`` is ``reset(seed=EVALUATION_SEED + e)`` on held-out floors."""
CONSTANT_ACTIONS = [(linear, angular) for linear in (0.5, 1.0) for angular in (0.0, 0.2, 0.4, 0.7)]
"""Forward arcs tried for the best constant action (a turn's sign does not matter
on random floors, so only left turns are tried)."""
POLICIES = ("trained", "best_constant", "random", "frontier")
"""The policies of a comparison, in the order reports list them."""

Agents = Callable[[Any, dict[str, dict[str, Any]]], dict[str, Any]]
"""``agents(env, observations) -> actions`` of the live agents."""


def run_episode(env: Any, agents: Agents, seed: int) -> dict[str, Any]:
    """One episode of ``agents``; its mean return per robot, final team coverage and
    the exploration figures of the environment's ``episode`` record."""
    observations, _ = env.reset(seed=seed)
    while env.agents:
        observations, *_ = env.step(agents(env, observations))
    record = env.last_episode
    return {
        "world": record["world"],
        "steps": record["l"],
        "mean_return": float(np.mean(list(record["returns"].values()))),
        "team_coverage": record["team_coverage"],
        "steps_to_target": record["steps_to_target"],
        "path_length_m": record["path_length_m"],
        "overlap_rate": record["overlap_rate"],
    }


def evaluate(agents: Agents, env_kwargs: dict[str, Any], episodes: int) -> dict[str, Any]:
    """``agents`` on ``episodes`` held-out episodes (the same for every policy)."""
    env = exploration.parallel_env(floors=exploration.HELD_OUT_FLOORS, **env_kwargs)
    runs = [run_episode(env, agents, EVALUATION_SEED + e) for e in range(episodes)]
    return {
        "mean_return": float(np.mean([e["mean_return"] for e in runs])),
        "team_coverage": float(np.mean([e["team_coverage"] for e in runs])),
        "episodes": runs,
    }


def blind(baseline: Callable[[Any], dict[str, Any]]) -> Agents:
    """A baseline that ignores the observation, as an :data:`Agents`."""
    return lambda env, _observations: baseline(env)


def compare(
    trained: Agents, env_kwargs: dict[str, Any], episodes: int, *, seed: int
) -> tuple[dict[str, Any], dict[str, float]]:
    """The trained policy and the baselines on the same held-out episodes.

    Returns
    -------
    evaluation : dict
        Per policy of :data:`POLICIES`, :func:`evaluate`'s figures; ``frontier``
        is marked ``privileged`` and ``best_constant`` names its ``action``.
    constant_actions : dict
        Mean final team coverage of every constant action tried.
    """
    evaluation = {
        "trained": evaluate(trained, env_kwargs, episodes),
        "random": evaluate(blind(RandomBaseline(rng=seed)), env_kwargs, episodes),
        "frontier": {
            **evaluate(blind(FrontierBaseline()), env_kwargs, episodes),
            "privileged": True,
        },
    }
    constants = {
        f"{linear:+.1f},{angular:+.1f}": evaluate(
            blind(ConstantBaseline((linear, angular))), env_kwargs, episodes
        )
        for linear, angular in CONSTANT_ACTIONS
    }
    best = max(constants, key=lambda name: constants[name]["team_coverage"])
    evaluation["best_constant"] = {**constants[best], "action": [float(v) for v in best.split(",")]}
    return evaluation, {k: v["team_coverage"] for k, v in constants.items()}


def print_comparison(summary: dict[str, Any]) -> None:
    """The comparison's figures, one line per policy."""
    for name in POLICIES:
        result = summary["evaluation"][name]
        print(
            f"  {name:<14} coverage {result['team_coverage']:.3f}  "
            f"return per robot {result['mean_return']:.2f} m²"
        )
