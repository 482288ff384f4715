"""Observations built for the whole team at once equal each robot's built alone."""

from __future__ import annotations

import numpy as np
import pytest

from envs import multi_robot_exploration_v0 as exploration
from envs.observations import normalise, observe
from tomosim.team import TeamConfig

SMALL = {"world_size": (12.0, 9.0), "robots": 3}
"""A small floor with three robots: quick to step."""
STEPS = 60
"""Steps compared: past the merge rounds that link the maps (every 20 steps, merging with
the true start poses, below) and teammate-map refreshes."""


@pytest.mark.parametrize("observation_format", ["metric", "normalised"])
def test_team_observations_equal_each_robot_s_own(observation_format: str) -> None:
    env = exploration.parallel_env(
        **SMALL,
        team=TeamConfig(merge_interval=20, method="oracle"),
        observation_format=observation_format,
    )
    observations, _ = env.reset(seed=4)
    generator = np.random.default_rng(5)
    for _ in range(STEPS):
        assert env.session is not None
        for k, agent in enumerate(env.possible_agents):
            alone = observe(env.session, k, size=env.crop_size, pool=env.pool, bound=env._bound)
            if observation_format == "normalised":
                alone = normalise(alone, bound=env._bound, max_range=env._max_range)
            assert observations[agent].keys() == alone.keys()
            for key, value in alone.items():
                assert observations[agent][key].dtype == value.dtype
                np.testing.assert_array_equal(observations[agent][key], value)
        actions = {a: generator.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        observations, *_ = env.step(actions)
    assert env.session is not None and env.session.linked(0)  # teammates' cells were shown


def test_each_observation_is_its_own_memory_from_step_to_step() -> None:
    env = exploration.parallel_env(**SMALL)
    first, _ = env.reset(seed=4)
    kept = {agent: {k: v.copy() for k, v in obs.items()} for agent, obs in first.items()}
    first["robot_0"]["scan"][:] = -1.0  # a learner normalising in place
    first["robot_0"]["map"][:] = 7
    for agent in ("robot_1", "robot_2"):
        for key, value in kept[agent].items():
            np.testing.assert_array_equal(first[agent][key], value)
    second, *_ = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    for obs in second.values():
        for key, value in obs.items():
            assert not any(np.shares_memory(value, old[key]) for old in first.values())
