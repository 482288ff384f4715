"""What a learner meets: normalised observations, floors per episode, final figures,
the vector envs, the SB3 adapter, the baselines and a few PPO iterations."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from envs import multi_robot_exploration_v0 as exploration
from envs.observations import CHANNEL_ON
from envs.scripted_agents import ConstantBaseline, FrontierBaseline, RandomBaseline
from envs.vector import RL_INSTALL

SMALL = {"world_size": (12.0, 9.0), "robots": 2}
"""A small floor with two robots: quick to step."""
ROOT = Path(__file__).resolve().parents[2]
HAVE_RL = all(
    importlib.util.find_spec(name)
    for name in ("torch", "stable_baselines3", "supersuit", "tensorboard")
)
needs_rl = pytest.mark.skipif(not HAVE_RL, reason=f"needs the rl extra: {RL_INSTALL}")


def still(env: Any) -> dict[str, np.ndarray]:
    return {a: np.zeros(2, np.float32) for a in env.agents}


def test_normalised_observations_are_images_and_unit_ranges() -> None:
    env = exploration.parallel_env(**SMALL, observation_format="normalised")
    observations, _ = env.reset(seed=3)
    for _ in range(4):  # four passes make the robot's own cell free
        observations, *_ = env.step(still(env))
    metric = exploration.parallel_env(**SMALL)
    reference, _ = metric.reset(seed=3)
    for _ in range(4):
        reference, *_ = metric.step(still(metric))
    space = env.observation_space("robot_0")
    for agent in env.agents:
        obs, ref = observations[agent], reference[agent]
        assert space.contains(obs)
        image = obs["map"]
        assert image.dtype == np.uint8 and image.shape == (3, 64, 64)
        # Each cell is in at most one class, and the classes follow the ROS codes.
        assert np.all((image == CHANNEL_ON).sum(axis=0) <= 1)
        np.testing.assert_array_equal(image[2] == CHANNEL_ON, ref["map"] < 0)
        np.testing.assert_array_equal(image[1] == CHANNEL_ON, ref["map"] >= 65)
        assert image[0, 32, 32] == CHANNEL_ON  # the robot stands on free space
        np.testing.assert_allclose(obs["scan"], ref["scan"] / 8.0, rtol=1e-6)
        theta = float(ref["pose"][2])
        np.testing.assert_allclose(obs["pose"][2:], [np.cos(theta), np.sin(theta)], atol=1e-6)


@pytest.mark.slow
def test_floors_draw_a_world_per_episode_from_the_seed() -> None:
    env = exploration.parallel_env(**SMALL, floors=exploration.TRAINING_FLOORS)
    worlds = []
    for seed in (1, 2, 1):
        env.reset(seed=seed)
        worlds.append(env.world.name)
    assert worlds[0] == worlds[2] != worlds[1]
    env.reset()  # continues from the generator: another floor
    assert env.world.name not in worlds[:2]
    assert not set(exploration.TRAINING_FLOORS) & set(exploration.HELD_OUT_FLOORS)
    with pytest.raises(ValueError, match="either world or floors"):
        exploration.parallel_env(world=3, floors=exploration.HELD_OUT_FLOORS)
    with pytest.raises(ValueError, match="observation_format"):
        exploration.parallel_env(observation_format="pixels")


def test_the_last_step_keeps_the_episode_s_figures() -> None:
    env = exploration.parallel_env(**SMALL, max_cycles=12)
    env.reset(seed=4)
    total = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        _, rewards, _, truncations, infos = env.step(
            {a: np.array([0.8, 0.3], np.float32) for a in env.agents}
        )
        for agent, reward in rewards.items():
            total[agent] += reward
    assert all(truncations.values())
    for agent, info in infos.items():
        episode = info["episode"]
        assert episode["r"] == pytest.approx(total[agent]) and episode["l"] == 12
        assert episode["team_coverage"] == info["team_coverage"] and episode["truncated"]
        assert episode["coverage"] == info["coverage"]
    record = env.last_episode
    _, reset_infos = env.reset(seed=5)
    assert env.last_episode is record  # a reset does not forget it
    assert all("episode" not in info for info in reset_infos.values())


@pytest.mark.slow
def test_baselines_act_for_every_live_agent() -> None:
    coverage = {}
    for name, agents in (
        ("still", ConstantBaseline((0.0, 0.0))),
        ("random", RandomBaseline(rng=0)),
        ("frontier", FrontierBaseline()),
    ):
        env = exploration.parallel_env(**SMALL, max_cycles=150)
        env.reset(seed=6)
        while env.agents:
            env.step(agents(env))
        assert env.last_episode is not None
        coverage[name] = env.last_episode["team_coverage"]
    assert coverage["frontier"] > coverage["random"] > coverage["still"]
    with pytest.raises(ValueError, match="two numbers in"):
        ConstantBaseline((2.0, 0.0))


@needs_rl
def test_supersuit_vector_env_steps_every_robot_of_every_env() -> None:
    from envs.vector import make_supersuit_vector_env

    venv = make_supersuit_vector_env(2, **SMALL)
    observations, _ = venv.reset(seed=7)
    assert venv.num_envs == 4 and observations["scan"].shape == (4, 360)
    single = exploration.parallel_env(**SMALL)
    alone, _ = single.reset(seed=8)  # environment 1 of the vector gets seed + 1
    np.testing.assert_array_equal(observations["scan"][2], alone["robot_0"]["scan"])
    venv.close()


@pytest.mark.slow
@needs_rl
def test_environments_in_processes_get_their_own_seeds_and_let_python_exit() -> None:
    # SuperSuit seeded process p's k-th environment with s + p + k: with two processes
    # of two, environments 1 and 2 both got s + 1 and ran the same episode. And its
    # workers are not daemons: a script that did not close the vector env never exited.
    script = (
        "import numpy as np\n"
        "from envs import multi_robot_exploration_v0 as exploration\n"
        "from envs.vector import make_supersuit_vector_env\n"
        f"small = {SMALL!r}\n"
        "venv = make_supersuit_vector_env(4, processes=2, **small)\n"
        "observations, infos = venv.reset(seed=7)\n"
        "assert len(infos) == venv.num_envs and all(isinstance(i, dict) for i in infos)\n"
        "for e in range(4):\n"
        "    alone, _ = exploration.parallel_env(**small).reset(seed=7 + e)\n"
        "    robots = len(alone)\n"
        "    assert np.array_equal(observations['scan'][e * robots], alone['robot_0']['scan']), e\n"
        "print('seeded')\n"
    )
    run = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip() == "seeded"


@pytest.mark.slow
@needs_rl
def test_sb3_adapter_seeds_marks_truncation_and_keeps_final_infos() -> None:
    from envs.vector import make_sb3_vector_env

    def rollout() -> tuple[list[Any], list[Any]]:
        venv = make_sb3_vector_env(1, **SMALL, max_cycles=10)
        venv.seed(11)  # SuperSuit's own SB3 wrapper fails here
        first = venv.reset()
        steps = [venv.step(np.full((2, 2), 0.5, np.float32)) for _ in range(10)]
        venv.close()
        return [first], steps

    (first,), steps = rollout()
    (again,), steps_again = rollout()
    np.testing.assert_array_equal(first["scan"], again["scan"])
    np.testing.assert_array_equal(steps[-1][0]["map"], steps_again[-1][0]["map"])
    *_, dones, infos = steps[-1]
    assert dones.all() and all(info["TimeLimit.truncated"] for info in infos)
    reference = exploration.parallel_env(**SMALL, max_cycles=10)
    reference.reset(seed=11)
    for _ in range(10):
        *_, truth = reference.step({a: np.full(2, 0.5, np.float32) for a in reference.agents})
    final = truth["robot_0"]["team_coverage"]
    assert infos[0]["final_info"]["team_coverage"] == final
    assert infos[0]["team_coverage"] != final  # the reset's value, as SuperSuit merges it


@pytest.mark.slow
@needs_rl
def test_sb3_adapter_names_each_entry_s_seed_and_renders() -> None:
    from envs.vector import make_sb3_vector_env

    venv = make_sb3_vector_env(2, **SMALL, render_mode="rgb_array")
    try:
        assert list(venv.seed(10)) == [10, 10, 11, 11]  # two robots in each environment
        venv.reset()
        frame = venv.render()
        assert frame is not None and frame.ndim == 3 and frame.shape[2] == 3
        np.testing.assert_array_equal(frame, venv.get_images()[0])
    finally:
        venv.close()


@pytest.mark.slow
@needs_rl
def test_ppo_trains_a_few_iterations_and_reports(tmp_path: Path) -> None:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    out, board = tmp_path / "ppo", tmp_path / "board"
    subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "train_ppo.py"), "--smoke", "--timesteps", "128",
         "--envs", "1", "--out", str(out), "--tensorboard", str(board)],
        check=True, cwd=tmp_path, capture_output=True, text=True,
    )  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timesteps"] >= 128
    for name in ("trained", "random", "best_constant", "frontier"):
        assert 0.0 < summary["evaluation"][name]["team_coverage"] <= 1.0
    assert summary["evaluation"]["frontier"]["privileged"]
    rows = (out / "learning_curve.csv").read_text().splitlines()
    assert rows[0].startswith("timesteps,") and len(rows) >= 2  # 40-step episodes ended
    assert (out / "learning_curve.png").stat().st_size > 0 and (out / "model.zip").exists()
    events = EventAccumulator(str(board / "PPO_1"))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert "rollout/ep_rew_mean" in tags  # the episode return, from the episode info
    for name in ("team_coverage", "path_length_m", "overlap_rate", "pairs_accepted"):
        assert f"exploration/{name}" in tags
    coverage = events.Scalars("exploration/team_coverage")
    assert coverage and all(0.0 < point.value <= 1.0 for point in coverage)
    assert coverage[-1].step <= summary["timesteps"]  # against agent-steps


@pytest.mark.slow
@needs_rl
def test_sb3_adapter_refuses_what_supersuit_hides_and_says_what_to_do() -> None:
    from envs.vector import make_sb3_vector_env

    venv = make_sb3_vector_env(1, **SMALL, max_cycles=10)
    try:
        assert venv.env_is_wrapped(object) == [False, False]
        with pytest.raises(NotImplementedError, match=r"set_attr\('max_cycles'\).*make_sb3"):
            venv.set_attr("max_cycles", 5)
        with pytest.raises(NotImplementedError, match=r"env_method\('reset'\).*parallel_env"):
            venv.env_method("reset")
    finally:
        venv.close()
