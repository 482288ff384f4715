"""The multi-robot exploration environment: PettingZoo and Gymnasium APIs, seeding, semantics."""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from pettingzoo.test import api_test, max_cycles_test, parallel_api_test, render_test

import envs
from envs import multi_robot_exploration_v0 as exploration
from envs.multi_robot_exploration_v0 import MultiRobotExplorationEnv
from tomosim.team import CommsConfig, TeamConfig

SMALL = {"world_size": (12.0, 9.0), "robots": 2}
"""A small floor with two robots: quick to step."""
ROLLOUT_STEPS = 120
"""Steps of the same-seed rollout comparison (two merge rounds at interval 50)."""
DICT_OBSERVATION_WARNINGS = (
    "Observation space for each agent probably should be",
    "Observation is not a NumPy array",
)
"""api_test's advice against Dict observations; the observation is a Dict by design
(scan, map window, pose), so these two messages, and only these, are allowed."""


def small_env(**kwargs: Any) -> MultiRobotExplorationEnv:
    return exploration.parallel_env(**{**SMALL, **kwargs})


def test_parallel_api() -> None:
    parallel_api_test(small_env(), num_cycles=40)


@pytest.mark.slow
def test_aec_api() -> None:
    with warnings.catch_warnings():
        for message in DICT_OBSERVATION_WARNINGS:
            warnings.filterwarnings("ignore", message=message)
        api_test(exploration.env(), num_cycles=30)


def test_max_cycles() -> None:
    max_cycles_test(exploration)


@pytest.mark.slow
def test_render() -> None:
    render_test(lambda render_mode: exploration.env(**SMALL, render_mode=render_mode))


def test_human_mode_draws_each_step_into_its_figure() -> None:
    """Without a display the human window is an off-screen figure showing the latest frame."""
    env = small_env(render_mode="human", max_cycles=3)
    frames = small_env(render_mode="rgb_array", max_cycles=3)
    env.reset(seed=4)
    frames.reset(seed=4)
    actions = {agent: np.array([1.0, 0.5], np.float32) for agent in env.possible_agents}
    env.step(actions)
    frames.step(actions)
    assert env.render() is None
    window = env.window
    assert window is not None and window.figure is not None
    shown = window.figure.axes[0].images[0].get_array()
    np.testing.assert_array_equal(np.asarray(shown), frames.render())
    env.close()
    assert window.figure is None


def rollout(seed: int, steps: int) -> list[tuple[Any, ...]]:
    """Everything a seeded episode returns under seeded random actions."""
    env = small_env(team=TeamConfig(merge_interval=50))
    observations, infos = env.reset(seed=seed)
    for k, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(100 + k)
    trace: list[tuple[Any, ...]] = [(observations, infos)]
    for _ in range(steps):
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        trace.append(env.step(actions))
    return trace


@pytest.mark.slow
def test_same_seed_rollouts_match_exactly() -> None:
    first, second = rollout(8, ROLLOUT_STEPS), rollout(8, ROLLOUT_STEPS)
    assert len(first) == ROLLOUT_STEPS + 1
    for a, b in zip(first, second, strict=True):
        assert data_equivalence(a, b, exact=True)
    merged = [step[4]["robot_0"]["merged_now"] for step in first[1:]]
    assert merged.count(True) >= 2  # the comparison covers merge rounds
    other = rollout(9, 1)
    assert not data_equivalence(first[0][0], other[0][0], exact=True)


@pytest.mark.slow
def test_gymnasium_view_passes_the_checker() -> None:
    team = gymnasium.make(envs.ENV_ID, **SMALL)
    check_env(team.unwrapped)
    observation, _ = team.reset(seed=0)
    assert observation["map"].shape == (2, 64, 64)
    _, reward, terminated, truncated, info = team.step(np.zeros((2, 2), np.float32))
    assert isinstance(reward, float) and not terminated and not truncated
    assert set(info["agents"]) == {"robot_0", "robot_1"}
    team.close()


def test_observations_describe_the_robot() -> None:
    env = small_env()
    observations, _ = env.reset(seed=3)
    session = env.session
    assert session is not None
    for k, agent in enumerate(env.possible_agents):
        obs = observations[agent]
        assert env.observation_space(agent).contains(obs)
        np.testing.assert_array_equal(
            obs["pose"], session.simulation.odometry[k].pose.astype(np.float32)
        )
        assert np.all(np.isfinite(obs["scan"])) and obs["scan"].max() <= 8.0
        # The robot stands in space its first scan passed through: known, not a wall.
        assert 0 <= obs["map"][32, 32] < 65
    for _ in range(4):  # four passes make a cell free (log-odds model of tomosim.mapping)
        observations, *_ = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    for agent in env.possible_agents:
        assert 0 <= observations[agent]["map"][32, 32] <= 19


def test_rewards_are_the_team_s_new_free_area() -> None:
    env = small_env()
    env.reset(seed=5)
    session = env.session
    assert session is not None
    area = session.coverage.total * session.coverage.cell_area
    before = session.coverage.fraction
    for _ in range(15):
        _, rewards, _, _, infos = env.step(
            {a: np.array([0.8, 0.4], np.float32) for a in env.agents}
        )
        now = infos["robot_0"]["team_coverage"]
        assert sum(rewards.values()) == pytest.approx((now - before) * area, rel=1e-9, abs=1e-9)
        assert all(r >= 0 for r in rewards.values())
        before = now


def test_reaching_the_coverage_target_terminates_everyone() -> None:
    env = small_env(coverage_target=0.05)
    env.reset(seed=1)
    _, _, terminations, truncations, _ = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    assert all(terminations.values()) and not any(truncations.values())
    assert env.agents == []


def test_merge_infos_carry_truth_errors_and_unused_merges_change_nothing() -> None:
    env = small_env(team=TeamConfig(merge_interval=5))
    env.reset(seed=2)
    for _ in range(5):
        *_, infos = env.step({a: np.array([0.3, 0.5], np.float32) for a in env.agents})
    info = infos["robot_0"]
    assert info["merged_now"] and info["merge"]["step"] == 5
    pair = info["merge"]["pairs"]["robot_0-robot_1"]
    assert info["merge"]["merged_robots"] == ["robot_0"]  # nothing linked yet
    for key in ("rotation_error_deg", "translation_error_m", "confidence"):
        assert isinstance(pair[key], float)
    assert isinstance(pair["accepted"], bool) and len(pair["truth"]) == 3
    # The first round's search runs until the next round: nothing accepted, nothing scored.
    assert not pair["accepted"] and pair["matching_index"] is None
    # The first round can confirm nothing, so nobody sees a teammate's map yet.
    assert not pair["confirmed"] and info["teammates"] == []


def test_bad_arguments_are_rejected() -> None:
    with pytest.raises(ValueError, match="render_mode"):
        small_env(render_mode="ansi")
    with pytest.raises(ValueError, match="crop_resolution"):
        small_env(crop_resolution=0.07)
    # Each once failed at reset(), allocating gigabytes or more in a kernel.
    too_wide = r"crop_size 100000 at crop_resolution 0\.1 m reads 200000 "
    with pytest.raises(ValueError, match=too_wide):
        small_env(crop_size=100_000)
    with pytest.raises(ValueError, match="a smaller crop_size or a finer crop_resolution"):
        small_env(crop_resolution=1e6)
    with pytest.raises(ValueError, match="robots"):
        small_env(robots=0)
    # Once unpacked as they were: "too many values to unpack" and the like.
    for size in ((30, 20, 1), 30, "30x20"):
        with pytest.raises(ValueError, match=r"world_size must be \(width, height\)"):
            small_env(world_size=size)
    env = small_env()
    env.reset(seed=0)
    bad = (np.array([np.nan, 0.0]), "ab", {"lin": 1}, [1, [2, 3]], [1 + 2j, 0], ["0.5", "1"])
    for action in bad:
        with pytest.raises(ValueError, match="the action of robot_0 must be two finite"):
            env.step({"robot_0": action})
    with pytest.raises(TypeError, match="dict of agent name"):
        env.step([[0, 0], [0, 0]])  # type: ignore[arg-type]
    for seed in (-1, 1.5, True):
        with pytest.raises(ValueError, match="seed must be a whole number"):
            env.reset(seed=seed)  # type: ignore[arg-type]


def test_a_step_after_the_end_is_said_once_per_episode(caplog: pytest.LogCaptureFixture) -> None:
    env = small_env(max_cycles=1)
    with caplog.at_level("WARNING", logger="envs.multi_robot_exploration_v0"):
        for seed in (0, 1):
            env.reset(seed=seed)
            env.step({agent: np.zeros(2) for agent in env.agents})
            assert not env.agents
            for _ in range(3):
                assert env.step({}) == ({}, {}, {}, {}, {})
    said = [r.getMessage() for r in caplog.records if "after the episode ended" in r.getMessage()]
    assert len(said) == 2 and "reset()" in said[0]


def test_a_start_that_already_meets_the_target_is_said(caplog: pytest.LogCaptureFixture) -> None:
    env = small_env(coverage_target=1e-6)
    with caplog.at_level("WARNING", logger="envs.multi_robot_exploration_v0"):
        env.reset(seed=0)
        env.reset(seed=1)
    said = [r.getMessage() for r in caplog.records if "first scans already cover" in r.getMessage()]
    assert len(said) == 1 and "coverage_target" in said[0]  # once per environment


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("robots", True),
        ("coverage_target", "0.5"),
        ("crop_resolution", float("nan")),
        ("team", "x"),
        ("floors", [1.7]),
    ],
)
def test_options_of_the_wrong_kind_are_named(option: str, value: Any) -> None:
    # A bool is not a count, a string not a switch or a fraction: each is named, not
    # read as 1, True or a floor number.
    options = {"world": 0} if option == "floors" else {}
    with pytest.raises(ValueError, match=option):
        exploration.parallel_env(**{**options, option: value})


def test_every_team_setting_reaches_the_session_through_team() -> None:
    team = TeamConfig(
        confirmations=1,
        share_interval=3,
        tracking=False,
        merge_worker=False,
        comms=CommsConfig(5.0, line_of_sight=True),
    )
    env = small_env(team=team)
    env.reset(seed=0)
    assert env.session is not None and env.session.config is team
    assert env.session.merger is not None and env.session.merger.config.confirmations == 1
    assert env.session.shared.refresh_interval == 3
    # Without a team: the team's own defaults, with v0's merge schedule and confirmations.
    default = small_env().team_config
    assert default is exploration.V0_TEAM
    assert default.unlinked_merge_interval == default.merge_interval
    assert not default.tracker.search_unlinked_at_once
    assert default.confirm_at_once_confidence is None
    assert (
        dataclasses.replace(
            default,
            unlinked_merge_interval=TeamConfig().unlinked_merge_interval,
            confirm_at_once_confidence=TeamConfig().confirm_at_once_confidence,
            tracker=TeamConfig().tracker,
        )
        == TeamConfig()
    )


@pytest.mark.parametrize("option", ["merge", "merge_interval", "method", "simulation"])
def test_a_team_setting_given_alone_names_the_team_argument(option: str) -> None:
    value = getattr(TeamConfig(), option)
    with pytest.raises(TypeError, match=rf"pass team=tomosim.team.TeamConfig\({option}="):
        exploration.parallel_env(**{option: value})


def test_world_size_is_refused_for_a_world_with_its_own_size(tmp_path) -> None:
    with pytest.raises(ValueError, match="world_size sizes a generated floor plan"):
        exploration.parallel_env(world=str(tmp_path / "map.yaml"), world_size=(12.0, 9.0))


def test_each_agent_has_its_own_spaces() -> None:
    env = small_env()
    env.action_space("robot_0").seed(0)
    env.action_space("robot_1").seed(1)
    first = env.action_space("robot_0").sample()
    env.action_space("robot_0").seed(0)
    assert np.array_equal(first, env.action_space("robot_0").sample())
    assert env.observation_space("robot_0") is not env.observation_space("robot_1")
    assert env.action_space("robot_0") is env.action_space("robot_0")
    with pytest.raises(KeyError, match="unknown agent"):
        env.action_space("robot_9")


def test_close_leaves_no_agent_and_episode_figures_are_each_agent_s_own() -> None:
    env = small_env(coverage_target=0.05)
    env.reset(seed=1)
    *_, infos = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    infos["robot_0"]["episode"]["returns"]["robot_1"] = -1.0
    assert infos["robot_1"]["episode"]["returns"]["robot_1"] >= 0.0
    assert env.last_episode is not None and env.last_episode["returns"]["robot_1"] >= 0.0
    env.reset(seed=1)
    env.close()
    assert env.agents == []


@pytest.mark.parametrize("interrupted", [True, False])
def test_ctrl_c_inside_a_compiled_kernel_reaches_the_learner_as_itself(
    monkeypatch: pytest.MonkeyPatch, interrupted: bool
) -> None:
    # A signal handler's KeyboardInterrupt that runs while a numba kernel hands back its
    # result comes out of the dispatcher as a SystemError caused by it; a training script's
    # `except KeyboardInterrupt` must still see it. Other SystemErrors pass unchanged.
    from tomosim.team import TeamSession

    def step(self: TeamSession, commands: object) -> None:
        try:
            raise KeyboardInterrupt if interrupted else ValueError("a bug")
        except BaseException as cause:
            raise SystemError("returned a result with an exception set") from cause

    env = exploration.parallel_env(robots=2, team=TeamConfig(merge=False))
    env.reset(seed=0)
    monkeypatch.setattr(TeamSession, "step", step)
    actions = {agent: np.zeros(2, np.float32) for agent in env.agents}
    with pytest.raises(KeyboardInterrupt if interrupted else SystemError):
        env.step(actions)
