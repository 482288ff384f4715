"""The frontier explorer as the environment's scripted baseline."""

from __future__ import annotations

import pytest

from envs import multi_robot_exploration_v0
from envs.scripted_agents import FrontierBaseline
from tomosim.exploration import DEFAULT_POLICY, TeamExplorer
from tomosim.team import TeamConfig

COVERAGE_GAIN = 0.2
"""Fraction of the small floor two robots must add in 120 steps (12 simulated seconds;
they add more than twice that; robots that stand still add nothing)."""


@pytest.mark.slow
def test_the_team_explorer_drives_the_environment_as_a_scripted_baseline() -> None:
    env = multi_robot_exploration_v0.parallel_env(
        world=4,
        world_size=(15.0, 10.0),
        robots=2,
        max_cycles=120,
        team=TeamConfig(merge_interval=40),
    )
    env.reset(seed=1)
    assert env.session is not None
    explorer = TeamExplorer(2, policy=DEFAULT_POLICY)
    start = env.session.coverage.fraction
    while env.agents:
        commands = explorer.act(env.session)
        env.step({agent: commands[k] for k, agent in enumerate(env.possible_agents)})
    assert env.session.coverage.fraction > start + COVERAGE_GAIN


@pytest.mark.slow
def test_the_frontier_baseline_coordinates_with_the_default_policy() -> None:
    baseline = FrontierBaseline()
    assert baseline.policy == DEFAULT_POLICY
    env = multi_robot_exploration_v0.parallel_env(
        world=4,
        world_size=(15.0, 10.0),
        robots=2,
        max_cycles=30,
        team=TeamConfig(merge_interval=40),
    )
    env.reset(seed=1)
    assert env.session is not None
    mirror = TeamExplorer(2, policy=DEFAULT_POLICY)
    # The baseline's first actions are the team explorer's on the same session.
    expected = mirror.act(env.session)
    actions = baseline(env)
    for k, agent in enumerate(env.possible_agents):
        assert actions[agent] == pytest.approx(expected[k].astype("float32"))
