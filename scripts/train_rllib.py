"""Train PPO with RLlib on a local Ray or a cluster, and compare it with scripted baselines.

The robots are the agents of RLlib's multi-agent environment
(:class:`envs.rllib.ExplorationMultiAgentEnv`, ``floors=TRAINING_FLOORS``, the
normalised observation), with one policy shared by all robots or
(``--policies per_robot``) one each; each policy is a CNN on the map image
with the scan and pose beside it (:class:`envs.rllib_module.ExplorationModule`).
Sampling runs in ``--env-runners`` Ray actors (on the cluster's nodes when
``--address`` names one, each of which needs tomosim installed with the
``rllib`` extra); learning runs in this process. After training, the policy
and the baselines of ``scripts/train_ppo.py`` (random, best constant action,
frontier) run the same episodes on held-out floors.

The output folder holds ``learning_curve.csv`` (one row per training
iteration in which episodes ended: their mean return per robot, team
coverage and the other figures of :mod:`envs.learning_metrics`, written as
iterations finish), ``learning_curve.png``, ``summary.json`` (the same keys
as ``train_ppo.py``'s, and the PPO settings), ``checkpoint/`` (RLlib's
``Algorithm.save_to_path``; the policies alone are in
``checkpoint/learner_group/learner/rl_module``) and ``tensorboard/``: every
number of every training result, under the tags Tune's TensorBoard logger
gives them (``ray/tune/env_runners/episode_return_mean``,
``ray/tune/env_runners/exploration/team_coverage``, ...), against agent-steps.
A folder that already holds any of them is refused. Ctrl-C during training
keeps the curve so far and saves the checkpoint as it is.

Usage::

    pip install -e ".[rllib]"      # docs/learning.md: the CPU build of torch first
    python scripts/train_rllib.py --timesteps 100000 --out results/rllib
    python scripts/train_rllib.py --timesteps 100000 --out results/rllib \\
        --address auto --env-runners 8           # on a running Ray cluster
    python scripts/train_rllib.py --timesteps 320 --smoke --out /tmp/rllib   # two iterations
    tensorboard --logdir results/rllib/tensorboard
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from policy_comparison.evaluation import Agents, compare
from policy_comparison.report import refuse_used_folder, write_run_outputs

from envs import multi_robot_exploration_v0 as exploration
from envs.learning_metrics import EPISODE_SCALARS
from tomosim.commands.script_args import non_negative_int, positive_float, positive_int, run_script

OUTPUTS = ("learning_curve.csv", "learning_curve.png", "summary.json", "checkpoint", "tensorboard")
"""What a run writes into ``--out``; a folder holding any of them is refused."""
CURVE_FIELDS = (
    "timesteps", "seconds", "iteration", "episodes", "mean_return", *EPISODE_SCALARS[1:]
)  # fmt: skip
"""Columns of ``learning_curve.csv``: ``mean_return`` is the return per robot."""
LEARNING_RATE = 3e-4
"""Adam's step size, Stable-Baselines3's PPO default (RLlib's is 5e-5)."""
GAE_LAMBDA = 0.95
"""The advantage estimate's lambda, as Stable-Baselines3's PPO (RLlib's default is 1)."""
CLIP_PARAM = 0.2
"""PPO's clip range, as Stable-Baselines3's (RLlib's default is 0.3)."""
VALUE_CLIP = 1_000.0
"""RLlib clips each sample's value loss at this; far above any squared error of the
returns here (tens of square metres), so that the loss is not clipped, as in
Stable-Baselines3 (RLlib's default of 10 would clip most of it)."""
TENSORBOARD_PREFIX = "ray/tune"
"""Tags start as Tune's TensorBoard logger starts them, so that dashboards carry over."""


def env_config(args: argparse.Namespace) -> dict[str, Any]:
    """Arguments of every environment, training and evaluation alike (floors aside)."""
    config: dict[str, Any] = {
        "robots": args.robots,
        "max_cycles": args.max_cycles,
        "observation_format": "normalised",
    }
    if args.world_size is not None:
        config["world_size"] = tuple(args.world_size)
    return config


def build_config(args: argparse.Namespace) -> Any:
    """The PPO configuration of a run (:func:`envs.rllib.ppo_config` and the options)."""
    from envs.rllib import ppo_config

    return (
        ppo_config(
            {**env_config(args), "floors": exploration.TRAINING_FLOORS}, policies=args.policies
        )
        .env_runners(
            num_env_runners=args.env_runners,
            num_envs_per_env_runner=args.envs_per_runner,
            num_cpus_per_env_runner=1,
        )
        .training(
            lr=LEARNING_RATE,
            gamma=0.99,
            lambda_=GAE_LAMBDA,
            clip_param=CLIP_PARAM,
            vf_clip_param=VALUE_CLIP,
            train_batch_size_per_learner=args.batch_size,
            minibatch_size=args.minibatch_size,
            num_epochs=args.epochs,
        )
        .learners(num_learners=0)  # in this process, on its CPU
        .debugging(seed=args.seed, log_level="ERROR")
    )


def count(value: Any) -> int:
    """A count of a result; RLlib reports NaN for one with nothing in this iteration."""
    return int(value) if math.isfinite(float(value)) else 0


def agent_steps(result: dict[str, Any]) -> int:
    """Agent-steps sampled since the start (all robots, all env runners)."""
    per_agent = result["env_runners"].get("num_agent_steps_sampled_lifetime", {})
    return sum(count(steps) for steps in per_agent.values())


def numbers(result: dict[str, Any], prefix: str) -> dict[str, float]:
    """Every finite number in the nested ``result``, by ``prefix/key/...`` tag."""
    found: dict[str, float] = {}
    for key, value in result.items():
        tag = f"{prefix}/{key}"
        if isinstance(value, dict):
            found.update(numbers(value, tag))
        elif (
            isinstance(value, int | float | np.integer | np.floating)
            and not isinstance(value, bool)
            and math.isfinite(float(value))
        ):
            found[tag] = float(value)
    return found


def curve_row(
    result: dict[str, Any], timesteps: int, seconds: float, episodes: int
) -> list[Any] | None:
    """The learning-curve row of an iteration, or None if no episode ended in it."""
    figures = result["env_runners"].get("exploration", {})
    coverage = figures.get("team_coverage", math.nan)
    if not math.isfinite(coverage):
        return None
    values = {**figures, "mean_return": figures.get("return_per_robot", math.nan)}
    return [
        timesteps,
        round(seconds, 2),
        result["training_iteration"],
        episodes,
        *(float(values.get(name, math.nan)) for name in CURVE_FIELDS[4:]),
    ]


def train(algo: Any, args: argparse.Namespace, robots: int) -> tuple[int, float]:
    """Train until ``--timesteps`` agent-steps; returns them and the seconds taken."""
    from tensorboardX import SummaryWriter

    clock = time.perf_counter()
    timesteps = 0
    writer = SummaryWriter(str(args.out / "tensorboard"), flush_secs=30)
    with (args.out / "learning_curve.csv").open("w", newline="") as handle:
        rows = csv.writer(handle)
        rows.writerow(CURVE_FIELDS)
        try:
            while timesteps < args.timesteps:
                result = algo.train()
                timesteps = agent_steps(result)
                seconds = time.perf_counter() - clock
                for tag, value in numbers(result, TENSORBOARD_PREFIX).items():
                    writer.add_scalar(tag, value, global_step=timesteps)
                episodes = count(result["env_runners"].get("num_episodes", 0))
                row = curve_row(result, timesteps, seconds, episodes)
                if row is not None:
                    rows.writerow(row)
                    handle.flush()
                print(
                    f"iteration {result['training_iteration']}: {timesteps} agent-steps, "
                    f"{seconds:.0f} s, {episodes} episodes ended"
                    + ("" if row is None else f", team coverage {row[5]:.3f}"),
                    flush=True,
                )
        except KeyboardInterrupt:  # keep the training done so far
            algo.save_to_path(str((args.out / "checkpoint").resolve()))
            print(f"the policy after {timesteps} agent-steps is in {args.out / 'checkpoint'}",
                  file=sys.stderr)  # fmt: skip
            raise
        finally:
            writer.close()
    return timesteps, time.perf_counter() - clock


def trained_agents(checkpoint: Path, policies: str) -> Agents:
    """The trained policies, restored from the checkpoint, acting deterministically."""
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModule

    from envs.rllib import deterministic_actions, own_policy, shared_policy

    modules = MultiRLModule.from_checkpoint(
        str((checkpoint / "learner_group" / "learner" / "rl_module").resolve())
    )
    mapping = shared_policy if policies == "shared" else own_policy

    def act(env: Any, observations: dict[str, dict[str, Any]]) -> dict[str, Any]:
        return deterministic_actions(modules, observations, mapping)

    return act


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, required=True, help="agent-steps of training")
    parser.add_argument("--out", type=Path, default=Path("results/rllib"), help="output folder")
    parser.add_argument(
        "--address", default=None,
        help="a running Ray cluster ('auto', or host:port); default: start a local Ray",
    )  # fmt: skip
    parser.add_argument(
        "--env-runners", type=non_negative_int, default=1,
        help="Ray actors sampling episodes (0: sample in this process)",
    )  # fmt: skip
    parser.add_argument(
        "--envs-per-runner", type=positive_int, default=1, help="environments per env runner"
    )
    parser.add_argument("--policies", choices=("shared", "per_robot"), default="shared")
    parser.add_argument("--robots", type=positive_int, default=3)
    parser.add_argument("--max-cycles", type=positive_int, default=300, help="steps per episode")
    parser.add_argument(
        "--world-size", type=positive_float, nargs=2, default=None, metavar=("W", "H")
    )
    parser.add_argument(
        "--batch-size", type=positive_int, default=256,
        help="environment steps per training iteration (each gives one agent-step per robot)",
    )  # fmt: skip
    parser.add_argument(
        "--minibatch-size", type=positive_int, default=256, help="agent-steps per SGD minibatch"
    )
    parser.add_argument("--epochs", type=positive_int, default=4, help="PPO epochs per iteration")
    parser.add_argument("--eval-episodes", type=positive_int, default=5, help="held-out episodes")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument(
        "--smoke", action="store_true",
        help="tiny settings, for tests: 2 robots, 40-step episodes on 12 x 9 m floors, "
        "80-step iterations in minibatches of 80, 1 epoch, 1 held-out episode (these "
        "override the options of the same names)",
    )  # fmt: skip
    args = parser.parse_args()
    if args.timesteps < 1:
        parser.error(f"--timesteps must be at least 1, got {args.timesteps}")
    if args.smoke:
        args.robots, args.max_cycles, args.world_size = 2, 40, [12.0, 9.0]
        args.batch_size, args.minibatch_size, args.epochs, args.eval_episodes = 80, 80, 1, 1
    refuse_used_folder(parser, args.out, OUTPUTS)
    try:
        import envs.rllib  # noqa: F401  (without RLlib or torch, fails with the install command)
    except ImportError as error:
        sys.exit(f"train_rllib.py: {error}")
    import ray
    import torch

    torch.set_num_threads(1)  # the env runners use the other cores
    args.out.mkdir(parents=True, exist_ok=True)
    if args.address is None:
        # "local" starts a Ray of this process's own even when a cluster started with
        # `ray start` (or one that has since died) is recorded on this machine.
        ray.init(address="local", include_dashboard=False, log_to_driver=False)
    else:
        ray.init(address=args.address, log_to_driver=False)
    try:
        algo = build_config(args).build_algo()
        try:
            timesteps, training_seconds = train(algo, args, args.robots)
            algo.save_to_path(str((args.out / "checkpoint").resolve()))
        finally:
            algo.stop()
    finally:
        ray.shutdown()
    evaluation, constants = compare(
        trained_agents(args.out / "checkpoint", args.policies),
        env_config(args),
        args.eval_episodes,
        seed=args.seed,
    )
    summary = {
        "command": " ".join(sys.argv),
        "trainer": "rllib",
        "timesteps": timesteps,
        "training_seconds": round(training_seconds, 1),
        "robots": args.robots,
        "policies": args.policies,
        "env_runners": args.env_runners,
        "envs_per_runner": args.envs_per_runner,
        "max_cycles": args.max_cycles,
        "ppo": {
            "lr": LEARNING_RATE,
            "lambda": GAE_LAMBDA,
            "clip_param": CLIP_PARAM,
            "vf_clip_param": VALUE_CLIP,
            "train_batch_size_per_learner": args.batch_size,
            "minibatch_size": args.minibatch_size,
            "num_epochs": args.epochs,
        },
        "held_out_episodes": args.eval_episodes,
        "evaluation": evaluation,
        "constant_actions": constants,
    }
    sharing = "one policy shared by" if args.policies == "shared" else "one policy for each of"
    write_run_outputs(
        args.out,
        summary,
        args.out / "learning_curve.csv",
        title=f"RLlib PPO, {sharing} {args.robots} robots, {timesteps} timesteps "
        f"({training_seconds / 60:.0f} min)",
        points="training iterations (mean of their episodes)",
    )


if __name__ == "__main__":
    run_script(main, __file__)
