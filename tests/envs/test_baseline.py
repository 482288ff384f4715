"""The frontier explorer as the environment's scripted baseline."""

from __future__ import annotations

from envs import multi_robot_exploration_v0
from tomosim.exploration import DEFAULT_POLICY, TeamExplorer

COVERAGE_GAIN = 0.2
"""Fraction of the small floor two robots must add in 120 steps (12 simulated seconds;
they add more than twice that; robots that stand still add nothing)."""


def test_the_team_explorer_drives_the_environment_as_a_scripted_baseline() -> None:
    env = multi_robot_exploration_v0.parallel_env(
        world=4, world_size=(15.0, 10.0), robots=2, max_cycles=120, merge_interval=40
    )
    env.reset(seed=1)
    assert env.session is not None
    explorer = TeamExplorer(2, policy=DEFAULT_POLICY)
    start = env.session.coverage.fraction
    while env.agents:
        commands = explorer.act(env.session)
        env.step({agent: commands[k] for k, agent in enumerate(env.possible_agents)})
    assert env.session.coverage.fraction > start + COVERAGE_GAIN
