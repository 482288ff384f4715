"""The exploration figures of the last step's ``episode`` info, and their scalars."""

from __future__ import annotations

import math

import numpy as np
import pytest

from envs import multi_robot_exploration_v0 as exploration
from envs.learning_metrics import EPISODE_SCALARS, episode_scalars
from tomosim.team import TeamConfig

SMALL = {"world_size": (12.0, 9.0), "robots": 2}
"""A small floor with two robots: quick to step."""
TURN = np.array([0.8, 0.3], np.float32)
"""Forward on a left arc: the robots move and see new space."""


def run(env: exploration.MultiRobotExplorationEnv, action: np.ndarray, seed: int) -> list:
    """One episode with ``action`` for every robot; each step's infos and true positions."""
    env.reset(seed=seed)
    assert env.session is not None
    steps = [(None, env.session.simulation.true_poses[:, :2].copy())]
    while env.agents:
        *_, infos = env.step(dict.fromkeys(env.agents, action))
        steps.append((infos, env.session.simulation.true_poses[:, :2].copy()))
    return steps


def test_episode_figures_add_up_from_the_steps() -> None:
    env = exploration.parallel_env(**SMALL, max_cycles=60, team=TeamConfig(merge_interval=10))
    steps = run(env, TURN, seed=3)
    positions = np.array([p for _, p in steps])
    travelled = np.hypot(*np.diff(positions, axis=0).transpose(2, 0, 1)).sum()
    final = steps[-1][0]
    episode = final["robot_0"]["episode"]
    assert episode["path_length_m"] == pytest.approx(travelled, rel=1e-9)
    assert 0 < episode["path_length_m"] <= 2 * 60 * 0.1  # at most 1 m/s for each robot
    coverages = [final[a]["coverage"] for a in env.possible_agents]
    team = final["robot_0"]["team_coverage"]
    assert episode["overlap_rate"] == pytest.approx(sum(coverages) / team - 1)
    rounds = [infos["robot_0"]["merge"] for infos, _ in steps[1:] if infos["robot_0"]["merged_now"]]
    assert episode["merge_rounds"] == len(rounds) == 6
    accepted = [p for r in rounds for p in r["pairs"].values() if p["accepted"]]
    assert episode["pairs_accepted"] == len(accepted)
    assert episode["pairs_confirmed"] == sum(p["confirmed"] for p in accepted)
    assert episode["steps_to_target"] is None and episode["truncated"]


def test_steps_to_target_is_the_first_step_at_the_target() -> None:
    env = exploration.parallel_env(**SMALL, max_cycles=300, coverage_target=0.75)
    steps = run(env, TURN, seed=4)
    episode = steps[-1][0]["robot_0"]["episode"]
    assert episode["terminated"] and episode["steps_to_target"] == episode["l"] == len(steps) - 1
    assert steps[-2][0]["robot_0"]["team_coverage"] < 0.75 <= episode["team_coverage"]
    scalars = episode_scalars(episode)
    assert list(scalars) == list(EPISODE_SCALARS)
    assert scalars["target_reached"] == 1.0 and scalars["steps_to_target"] == episode["l"]
    assert scalars["return_per_robot"] == pytest.approx(np.mean(list(episode["returns"].values())))


def test_robots_that_stand_still_travel_nothing_and_reach_nothing() -> None:
    env = exploration.parallel_env(**SMALL, max_cycles=5)
    steps = run(env, np.zeros(2, np.float32), seed=5)
    scalars = episode_scalars(steps[-1][0]["robot_1"]["episode"])
    assert scalars["path_length_m"] == pytest.approx(0.0, abs=1e-6)
    assert "steps_to_target" not in scalars and scalars["target_reached"] == 0.0
    assert all(math.isfinite(v) for v in scalars.values())
    with pytest.raises(ValueError, match="info\\['episode'\\]"):
        episode_scalars({"team_coverage": 0.5})
