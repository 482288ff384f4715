"""The RLlib adapter: RLlib's env checker, the CNN module, the policy mapping, a tiny training."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from envs import multi_robot_exploration_v0 as exploration

SMALL = {"world_size": (12.0, 9.0), "robots": 2}
"""A small floor with two robots: quick to step."""
ROOT = Path(__file__).resolve().parents[2]
INSTALL = 'pip install -e ".[rllib]"'
"""As :data:`envs.rllib.RLLIB_INSTALL` (which cannot be imported without the extra)."""
HAVE_RLLIB = all(
    importlib.util.find_spec(name) for name in ("ray", "torch", "tree", "lz4", "tensorboard")
)  # ray's rllib extra brings dm_tree ("tree") and lz4; plain Ray has neither
pytestmark = pytest.mark.skipif(not HAVE_RLLIB, reason=f"needs the rllib extra: {INSTALL}")


def test_the_adapter_passes_rllib_s_own_env_checker() -> None:
    from ray.rllib.utils.pre_checks.env import check_multiagent_environments

    from envs.rllib import ExplorationMultiAgentEnv

    env = ExplorationMultiAgentEnv(SMALL)
    check_multiagent_environments(env)  # raises on any fault it finds
    observations, _ = env.reset(seed=0)
    for agent, observation in observations.items():
        assert env.get_observation_space(agent).contains(observation)
        assert observation["map"].shape == (3, 64, 64)  # the normalised format by default


def test_the_adapter_keeps_order_seeds_agents_and_renders() -> None:
    from envs.rllib import ExplorationMultiAgentEnv

    env = ExplorationMultiAgentEnv({**SMALL, "max_cycles": 3, "render_mode": "rgb_array"})
    # RLlib's ParallelPettingZooEnv lists agents from a set and resets in its constructor.
    assert env.possible_agents == ["robot_0", "robot_1"] == list(env.observation_spaces)
    assert env.env.session is None and env.agents == []
    observations, _ = env.reset(seed=7)
    reference, _ = exploration.parallel_env(**SMALL, observation_format="normalised").reset(seed=7)
    for agent in env.possible_agents:
        np.testing.assert_array_equal(observations[agent]["map"], reference[agent]["map"])
    assert env.agents == env.possible_agents
    frame = env.render()  # ParallelPettingZooEnv passes render() an argument it does not take
    assert frame is not None and frame.ndim == 3
    for _ in range(3):
        _, _, terminations, truncations, _ = env.step(
            {a: np.array([0.5, 0.2], np.float32) for a in env.agents}
        )
    assert truncations["__all__"] and not terminations["__all__"] and env.agents == []
    env.reset(seed=7)
    _, _, terminations, truncations, _ = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    assert not terminations["__all__"] and not truncations["__all__"]


def test_reaching_the_target_terminates_all() -> None:
    from envs.rllib import ExplorationMultiAgentEnv

    env = ExplorationMultiAgentEnv({**SMALL, "coverage_target": 0.75})
    env.reset(seed=4)
    while env.agents:
        *_, terminations, truncations, infos = env.step(
            {a: np.array([0.8, 0.3], np.float32) for a in env.agents}
        )
    assert terminations["__all__"] and not truncations["__all__"]
    assert infos["robot_0"]["episode"]["steps_to_target"] is not None


def test_the_module_reads_the_map_with_a_cnn() -> None:
    import torch
    from ray.rllib.core.columns import Columns
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    from envs.rllib import ExplorationMultiAgentEnv
    from envs.rllib_module import ExplorationModule

    env = ExplorationMultiAgentEnv(SMALL)
    spec = RLModuleSpec(
        module_class=ExplorationModule,
        observation_space=env.get_observation_space("robot_0"),
        action_space=env.get_action_space("robot_0"),
        model_config={"head_hiddens": [32]},
    )
    module = spec.build()
    assert isinstance(module.map_encoder[0][0], torch.nn.Conv2d)
    assert module.map_encoder[0][0].in_channels == 3  # the image, not a flattened vector
    observations, _ = env.reset(seed=1)
    batch = {
        key: torch.from_numpy(np.stack([o[key] for o in observations.values()]))
        for key in ("scan", "map", "pose")
    }
    out = module.forward_train({Columns.OBS: batch})
    assert out[Columns.ACTION_DIST_INPUTS].shape == (2, 4)  # mean and log std of 2 actions
    values = module.compute_values({Columns.OBS: batch}, embeddings=out[Columns.EMBEDDINGS])
    torch.testing.assert_close(values, module.compute_values({Columns.OBS: batch}))
    assert values.shape == (2,)
    blank = {**batch, "map": torch.zeros_like(batch["map"])}
    assert not torch.equal(module.encode(blank), module.encode(batch))  # the map matters
    with pytest.raises(ValueError, match="unknown model_config keys \\['conv_filter'\\]"):
        RLModuleSpec(
            module_class=ExplorationModule,
            observation_space=spec.observation_space,
            action_space=spec.action_space,
            model_config={"conv_filter": []},
        ).build()
    metric = exploration.parallel_env(**SMALL).observation_space("robot_0")
    with pytest.raises(ValueError, match='observation_format="normalised"'):
        RLModuleSpec(
            module_class=ExplorationModule,
            observation_space=metric,
            action_space=spec.action_space,
        ).build()


@pytest.mark.parametrize("policies", ["shared", "per_robot"])
def test_one_policy_for_all_robots_or_one_each(policies: str) -> None:
    from envs.rllib import ExplorationMultiAgentEnv, deterministic_actions, ppo_config

    config = ppo_config(SMALL, policies=policies)
    env = ExplorationMultiAgentEnv(SMALL)
    modules = config.get_multi_rl_module_spec(env=env).build()
    expected = {"shared"} if policies == "shared" else {"robot_0", "robot_1"}
    assert set(modules.keys()) == expected == set(config.policies)
    mapped = {config.policy_mapping_fn(agent, None) for agent in env.possible_agents}
    assert mapped == expected
    observations, _ = env.reset(seed=2)
    actions = deterministic_actions(modules, observations, config.policy_mapping_fn)
    assert set(actions) == set(env.possible_agents)
    for agent, action in actions.items():
        assert env.get_action_space(agent).contains(action)
    with pytest.raises(ValueError, match="policies must be one of"):
        ppo_config(SMALL, policies="per_team")


@pytest.mark.slow
def test_a_tiny_training_reports_metrics_curves_and_tensorboard(tmp_path: Path) -> None:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    out = tmp_path / "rllib"
    run = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "train_rllib.py"), "--smoke", "--timesteps",
         "320", "--env-runners", "1", "--out", str(out)],
        cwd=tmp_path, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timesteps"] >= 320 and summary["trainer"] == "rllib"
    for name in ("trained", "random", "best_constant", "frontier"):
        assert 0.0 < summary["evaluation"][name]["team_coverage"] <= 1.0
    assert summary["evaluation"]["frontier"]["privileged"]
    rows = (out / "learning_curve.csv").read_text().splitlines()
    assert rows[0].startswith("timesteps,") and len(rows) >= 2  # 40-step episodes ended
    assert (out / "learning_curve.png").stat().st_size > 0
    assert (out / "checkpoint" / "learner_group" / "learner" / "rl_module" / "shared").is_dir()
    events = EventAccumulator(str(out / "tensorboard"))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    for name in ("team_coverage", "path_length_m", "overlap_rate", "pairs_accepted"):
        assert f"ray/tune/env_runners/exploration/{name}" in tags
    assert "ray/tune/env_runners/episode_return_mean" in tags
    coverage = events.Scalars("ray/tune/env_runners/exploration/team_coverage")
    assert coverage and all(0.0 < point.value <= 1.0 for point in coverage)
    assert coverage[-1].step == summary["timesteps"]  # against agent-steps


TUNE_RUN = """
import sys
import ray
from ray import tune
from envs.rllib import ppo_config

ray.init(address="local", include_dashboard=False)  # never a cluster recorded on the machine

config = (
    ppo_config({"world_size": (12.0, 9.0), "robots": 2, "max_cycles": 40})
    .env_runners(num_env_runners=0)
    .training(train_batch_size_per_learner=80, minibatch_size=80, num_epochs=1)
)
tuner = tune.Tuner(
    config.algo_class,
    param_space=config,
    run_config=tune.RunConfig(
        storage_path=sys.argv[1], name="tiny", stop={"training_iteration": 1}, verbose=0
    ),
)
assert not tuner.fit().errors
"""
"""One iteration through Tune, as RLlib's examples run their experiments."""


@pytest.mark.slow
def test_tune_s_own_tensorboard_logger_records_the_episode_figures(tmp_path: Path) -> None:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    run = subprocess.run(
        [sys.executable, "-c", TUNE_RUN, str(tmp_path)],
        cwd=ROOT, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    (events_file,) = tmp_path.glob("tiny/*/events.out.tfevents.*")
    events = EventAccumulator(str(events_file.parent))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert "ray/tune/env_runners/exploration/team_coverage" in tags
    assert "ray/tune/env_runners/episode_return_mean" in tags
