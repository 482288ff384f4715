"""Train one PPO policy shared by all robots, and compare it with scripted baselines.

The robots of ``--envs`` environments (``floors=TRAINING_FLOORS``: a new
generated floor every episode; ``observation_format="normalised"``: the map
window as a ``uint8`` image, read by a CNN) are the entries of one
Stable-Baselines3 vector env (:func:`envs.vector.make_sb3_vector_env`), so
one policy acts for every robot from its own observation. After training,
the policy and three baselines (random actions, the best constant action,
the privileged frontier policy; :mod:`policy_comparison.evaluation`) run the
same episodes on held-out floors (``HELD_OUT_FLOORS``, never drawn in training).

The output folder holds ``learning_curve.csv`` (one row per finished training
episode, written as they finish), ``learning_curve.png``, ``summary.json``
(per policy: mean episode return per robot and mean final team coverage,
with each episode's figures) and ``model.zip``. A folder that already holds
any of them is refused, so that a rerun never mixes two runs' files. Ctrl-C
during training keeps the curve so far and saves the model as it is.

``--tensorboard DIR`` also writes TensorBoard scalars into ``DIR/PPO_1``
(``PPO_2``, ... for later runs into the same folder): Stable-Baselines3's own
(``rollout/ep_rew_mean``, the episode return summed over a robot's steps;
``train/...``, the losses) and the finished episodes' figures of
:mod:`envs.learning_metrics` under ``exploration/`` (team coverage, steps to
the target, path length, overlap rate, accepted and confirmed merges), means
over the episodes of each rollout, against agent-steps.

Usage::

    pip install -e ".[rl]"
    python scripts/train_ppo.py --timesteps 200000 --out results/ppo --tensorboard results/tb
    tensorboard --logdir results/tb
    python scripts/train_ppo.py --timesteps 256 --smoke --out /tmp/ppo   # a few iterations
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from policy_comparison.evaluation import Agents, compare
from policy_comparison.report import refuse_used_folder, write_run_outputs

from envs import multi_robot_exploration_v0 as exploration
from envs.vector import RL_INSTALL, make_sb3_vector_env
from tomosim.commands.script_args import non_negative_int, positive_float, positive_int, run_script

OUTPUTS = ("learning_curve.csv", "learning_curve.png", "summary.json", "model.zip")
"""What a run writes into ``--out``; a folder holding any of them is refused."""


def env_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Arguments of every environment, training and evaluation alike (floors aside)."""
    kwargs: dict[str, Any] = {
        "robots": args.robots,
        "max_cycles": args.max_cycles,
        "observation_format": "normalised",
    }
    if args.world_size is not None:
        kwargs["world_size"] = tuple(args.world_size)
    return kwargs


def learning_callback(path: Path, robots: int) -> Any:
    """A Stable-Baselines3 callback writing one CSV row per finished training episode."""
    from stable_baselines3.common.callbacks import BaseCallback

    class LearningCurve(BaseCallback):
        def _on_training_start(self) -> None:
            self.clock = time.perf_counter()
            self.handle = path.open("w", newline="")
            self.writer = csv.writer(self.handle)
            self.writer.writerow(
                ["timesteps", "seconds", "episode", "world", "mean_return", "team_coverage"]
            )
            self.episodes = 0

        def _on_step(self) -> bool:
            for index, info in enumerate(self.locals["infos"]):
                episode = info.get("episode")
                if index % robots or episode is None:  # one row per environment's episode
                    continue
                self.episodes += 1
                self.writer.writerow(
                    [
                        self.num_timesteps,
                        round(time.perf_counter() - self.clock, 2),
                        self.episodes,
                        episode["world"],
                        float(np.mean(list(episode["returns"].values()))),
                        episode["team_coverage"],
                    ]
                )
                self.handle.flush()
            return True

        def _on_training_end(self) -> None:
            self.handle.close()

    return LearningCurve()


def model_agents(model: Any) -> Agents:
    """The trained policy, acting deterministically for each robot from its observation."""

    def act(env: Any, observations: dict[str, dict[str, Any]]) -> dict[str, Any]:
        agents = [a for a in env.possible_agents if a in observations]
        batch = {
            key: np.stack([observations[a][key] for a in agents]) for key in observations[agents[0]]
        }
        actions, _ = model.predict(batch, deterministic=True)
        return dict(zip(agents, actions, strict=True))

    return act


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, required=True, help="agent-steps of training")
    parser.add_argument("--out", type=Path, default=Path("results/ppo"), help="output folder")
    parser.add_argument(
        "--envs", type=positive_int, default=2, help="environments stepped together"
    )
    parser.add_argument(
        "--processes", type=non_negative_int, default=0, help="worker processes for them"
    )
    parser.add_argument("--robots", type=positive_int, default=3)
    parser.add_argument("--max-cycles", type=positive_int, default=300, help="steps per episode")
    parser.add_argument(
        "--world-size", type=positive_float, nargs=2, default=None, metavar=("W", "H")
    )
    parser.add_argument(
        "--n-steps", type=positive_int, default=128, help="PPO rollout steps per entry"
    )
    parser.add_argument("--batch-size", type=positive_int, default=256, help="at least 2")
    parser.add_argument("--epochs", type=positive_int, default=4, help="PPO epochs per rollout")
    parser.add_argument("--eval-episodes", type=positive_int, default=5, help="held-out episodes")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument(
        "--tensorboard", type=Path, default=None, metavar="DIR",
        help="also write TensorBoard scalars into DIR (watch with: tensorboard --logdir DIR)",
    )  # fmt: skip
    parser.add_argument(
        "--smoke", action="store_true",
        help="tiny settings, for tests: 2 robots, 40-step episodes on 12 x 9 m floors, "
        "32-step rollouts in one batch, 1 epoch, 1 held-out episode (these override "
        "the options of the same names)",
    )  # fmt: skip
    args = parser.parse_args()
    if args.timesteps < 1:
        parser.error(f"--timesteps must be at least 1, got {args.timesteps}")
    if args.smoke:
        args.robots, args.max_cycles, args.world_size = 2, 40, [12.0, 9.0]
        args.n_steps, args.batch_size, args.epochs, args.eval_episodes = 32, 32, 1, 1
    if args.batch_size < 2:  # Stable-Baselines3 asserts on it after the environments start
        parser.error(f"--batch-size must be at least 2, got {args.batch_size}")
    refuse_used_folder(parser, args.out, OUTPUTS)
    try:
        import torch
        from stable_baselines3 import PPO
    except ImportError:
        sys.exit(f"train_ppo.py needs Stable-Baselines3 and torch: {RL_INSTALL}")
    if args.tensorboard is not None and importlib.util.find_spec("tensorboard") is None:
        sys.exit(f"--tensorboard needs the tensorboard package: {RL_INSTALL}")
    from stable_baselines3.common.callbacks import CallbackList

    from envs.sb3 import ExplorationMetricsCallback

    torch.set_num_threads(1)  # the environments use the other cores
    args.out.mkdir(parents=True, exist_ok=True)
    venv = make_sb3_vector_env(
        args.envs,
        processes=args.processes,
        floors=exploration.TRAINING_FLOORS,
        **env_kwargs(args),
    )
    model = PPO(
        "MultiInputPolicy",
        venv,
        n_steps=args.n_steps,
        batch_size=args.batch_size,
        n_epochs=args.epochs,
        seed=args.seed,
        device="cpu",
        verbose=0,
        tensorboard_log=None if args.tensorboard is None else str(args.tensorboard),
    )
    curve = args.out / "learning_curve.csv"
    callbacks = [learning_callback(curve, args.robots)]
    if args.tensorboard is not None:
        callbacks.append(ExplorationMetricsCallback(args.robots))
    clock = time.perf_counter()
    try:
        model.learn(total_timesteps=args.timesteps, callback=CallbackList(callbacks))
    except KeyboardInterrupt:  # keep the training done so far
        model.save(args.out / "model.zip")
        print(f"the model after {model.num_timesteps} timesteps is in {args.out / 'model.zip'}",
              file=sys.stderr)  # fmt: skip
        raise
    finally:  # worker processes are not daemons: left open, they would keep Python alive
        venv.close()
    training_seconds = time.perf_counter() - clock
    model.save(args.out / "model.zip")
    evaluation, constants = compare(
        model_agents(model), env_kwargs(args), args.eval_episodes, seed=args.seed
    )
    summary = {
        "command": " ".join(sys.argv),
        "timesteps": int(model.num_timesteps),
        "training_seconds": round(training_seconds, 1),
        "robots": args.robots,
        "envs": args.envs,
        "max_cycles": args.max_cycles,
        "held_out_episodes": args.eval_episodes,
        "evaluation": evaluation,
        "constant_actions": constants,
    }
    write_run_outputs(
        args.out,
        summary,
        curve,
        title=f"PPO, one policy for {summary['robots']} robots, {summary['timesteps']} timesteps "
        f"({summary['training_seconds'] / 60:.0f} min)",
        points="training episodes",
    )


if __name__ == "__main__":
    run_script(main, __file__)
