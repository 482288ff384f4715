"""RLlib (new API stack): the exploration environment as a multi-agent env, and PPO set up for it.

* :class:`ExplorationMultiAgentEnv` is the parallel environment of
  :mod:`envs.multi_robot_exploration_v0` as an RLlib ``MultiAgentEnv``,
  registered under :data:`ENV_NAME` by :func:`register`; its ``env_config``
  holds the parallel environment's arguments, with
  ``observation_format="normalised"`` unless it says otherwise;
* :class:`ExplorationMetricsCallback` logs each finished episode's figures
  (:mod:`envs.learning_metrics`) through the env runners' ``MetricsLogger``,
  so that they appear in every training result under
  ``env_runners/exploration/`` (and in TensorBoard, through Tune's logger or
  ``scripts/train_rllib.py``);
* :func:`ppo_config` puts them together: a ``PPOConfig`` with one
  :class:`~envs.rllib_module.ExplorationModule` (a CNN on the map image)
  shared by every robot, or one per robot.

::

    import math

    from envs import multi_robot_exploration_v0 as exploration
    from envs.rllib import ppo_config

    config = ppo_config(
        {"robots": 3, "max_cycles": 300, "floors": exploration.TRAINING_FLOORS}
    ).training(train_batch_size_per_learner=256, minibatch_size=256, num_epochs=4)
    algo = config.env_runners(num_env_runners=2).build_algo()
    result = algo.train()
    # Absent, or NaN, in an iteration in which no episode ended.
    result["env_runners"].get("exploration", {}).get("team_coverage", math.nan)

(the guide, ``docs/learning.md``, runs it for ten iterations.)

Why not RLlib's own ``ParallelPettingZooEnv``: it lists the agents and spaces
from a ``set``, so their order changes between processes; it resets the
environment unseeded in its constructor (building a whole episode for
nothing); its ``agents`` never change during an episode; and its ``render``
passes an argument the PettingZoo API no longer has. Each of these is pinned
by a test of this adapter.

Importing this module needs ``ray[rllib]`` and torch (the ``rllib`` extra).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from envs.learning_metrics import episode_scalars
from envs.multi_robot_exploration_v0 import MultiRobotExplorationEnv, parallel_env

RLLIB_INSTALL = 'pip install -e ".[rllib]"'
"""The command that installs RLlib and torch (docs/learning.md: the CPU build first)."""

try:
    import torch
    from gymnasium import spaces
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.callbacks.callbacks import RLlibCallback
    from ray.rllib.core.columns import Columns
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.rllib.env.multi_agent_env import MultiAgentEnv
    from ray.rllib.utils.typing import AgentID
    from ray.tune.registry import register_env

    from envs.rllib_module import ExplorationModule
except ImportError as error:
    raise ImportError(
        f"the RLlib adapter needs ray[rllib] and torch: {RLLIB_INSTALL} (docs/learning.md "
        "says how to get the CPU build of torch)"
    ) from error

ENV_NAME = "tomosim/multi_robot_exploration_v0"
"""The name :func:`register` gives the environment in RLlib's (Tune's) registry."""
METRICS_KEY = "exploration"
"""Where the episode figures go in a result: ``result["env_runners"][METRICS_KEY]``."""
SHARED_POLICY = "shared"
"""The module id of the one policy every robot uses (``policies="shared"``)."""
POLICY_SHARING = ("shared", "per_robot")
"""The choices of :func:`ppo_config`'s ``policies``: one module for all robots, or one each."""


class ExplorationMultiAgentEnv(MultiAgentEnv):
    """The parallel exploration environment as an RLlib ``MultiAgentEnv``.

    Agents, spaces, rewards and infos are the parallel environment's; at the
    last step all robots end together, and ``"__all__"`` says whether the
    team reached its coverage target (terminated) or ran out of steps
    (truncated).

    Parameters
    ----------
    config : mapping, optional
        Arguments of :func:`envs.multi_robot_exploration_v0.parallel_env`
        (RLlib passes its ``env_config`` here); ``observation_format``
        defaults to ``"normalised"``, which :class:`ExplorationModule` reads.
    """

    def __init__(self, config: Mapping[str, Any] | None = None) -> None:
        super().__init__()
        kwargs = {"observation_format": "normalised", **dict(config or {})}
        self.env: MultiRobotExplorationEnv = parallel_env(**kwargs)
        names: list[str] = list(self.env.possible_agents)
        self.possible_agents = list(names)
        self.agents: list[AgentID] = []
        self.observation_spaces = {a: self.env.observation_space(a) for a in names}
        self.action_spaces = {a: self.env.action_space(a) for a in names}
        # The spaces of all agents, as RLlib's checks and old API stack read them.
        self.observation_space = spaces.Dict({a: self.env.observation_space(a) for a in names})
        self.action_space = spaces.Dict({a: self.env.action_space(a) for a in names})
        self.render_mode = self.env.render_mode

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> Any:  # gymnasium.Env and MultiAgentEnv type it differently
        """Start an episode: observations and infos by agent; ``seed`` reseeds the
        environment (its spec card)."""
        observations, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.env.agents)
        return observations, infos

    def step(self, action_dict: dict[Any, Any]) -> Any:  # gymnasium.Env types it otherwise
        """Step all robots: observations, rewards, terminations, truncations and infos by
        agent; adds ``"__all__"`` to the terminations and truncations."""
        observations, rewards, terminations, truncations, infos = self.env.step(action_dict)
        ended = not self.env.agents
        terminated = ended and any(terminations.values())
        terminations["__all__"] = terminated
        truncations["__all__"] = ended and not terminated
        self.agents = list(self.env.agents)
        return observations, rewards, terminations, truncations, infos

    def render(self) -> Any:
        """The parallel environment's frame (``render_mode`` in ``config``)."""
        return self.env.render()

    def close(self) -> None:
        """Release the episode."""
        self.env.close()


def register(name: str = ENV_NAME) -> str:
    """Register :class:`ExplorationMultiAgentEnv` with RLlib under ``name``; returns it.

    ``config.environment(name, env_config={...})`` then builds it in every env
    runner, local or on a cluster (each node needs tomosim installed).
    """
    register_env(name, ExplorationMultiAgentEnv)
    return name


class ExplorationMetricsCallback(RLlibCallback):
    """Logs a finished episode's figures (:func:`envs.learning_metrics.episode_scalars`).

    Each is logged as ``(METRICS_KEY, name)`` with ``reduce="mean"`` and no
    window: a training result holds their means over the episodes that
    ended in that iteration, and NaN when none did.
    """

    def on_episode_end(
        self, *, episode: Any, metrics_logger: Any = None, **kwargs: Any
    ) -> None:  # fmt: skip
        """Read the ``episode`` info of the episode's last step and log its scalars."""
        if metrics_logger is None:
            return
        last = episode.get_infos(-1)
        summary = next((info["episode"] for info in last.values() if "episode" in info), None)
        if summary is None:  # an episode cut by RLlib, not ended by the environment
            return
        for name, value in episode_scalars(summary).items():
            metrics_logger.log_value((METRICS_KEY, name), value, reduce="mean")


def shared_policy(agent_id: Any, episode: Any = None, **kwargs: Any) -> str:
    """Policy mapping: every robot uses :data:`SHARED_POLICY`."""
    return SHARED_POLICY


def own_policy(agent_id: Any, episode: Any = None, **kwargs: Any) -> str:
    """Policy mapping: each robot uses the module named after it (``robot_0``, ...)."""
    return str(agent_id)


def deterministic_actions(
    modules: Any, observations: Mapping[str, Mapping[str, Any]], mapping: Any = shared_policy
) -> dict[str, Any]:
    """The trained policies' deterministic actions (the Gaussians' means) for the robots.

    Parameters
    ----------
    modules : MultiRLModule or mapping of module id to RLModule
        E.g. ``MultiRLModule.from_checkpoint(path / "learner_group" / "learner" /
        "rl_module")`` of a saved algorithm.
    observations : mapping
        The parallel environment's observations, by agent (the normalised format).
    mapping : callable
        The policy mapping of training: :func:`shared_policy` or :func:`own_policy`.

    Returns
    -------
    dict
        ``(2,) float32`` action per agent of ``observations``, in ``[-1, 1]``.
    """
    by_module: dict[str, list[str]] = {}
    for agent in observations:
        by_module.setdefault(mapping(agent), []).append(agent)
    actions: dict[str, Any] = {}
    with torch.no_grad():
        for module_id, agents in by_module.items():
            module = modules[module_id]
            batch = {
                key: torch.from_numpy(np.stack([observations[a][key] for a in agents]))
                for key in observations[agents[0]]
            }
            inputs = module.forward_inference({Columns.OBS: batch})[Columns.ACTION_DIST_INPUTS]
            distribution = module.get_inference_action_dist_cls().from_logits(inputs)
            chosen = distribution.to_deterministic().sample().numpy().clip(-1.0, 1.0)
            actions.update(zip(agents, chosen.astype(np.float32), strict=True))
    return actions


def ppo_config(
    env_config: Mapping[str, Any] | None = None,
    *,
    policies: str = "shared",
    model_config: Mapping[str, Any] | None = None,
) -> PPOConfig:
    """A ``PPOConfig`` for the exploration environment (module docstring).

    Parameters
    ----------
    env_config : mapping, optional
        Arguments of the parallel environment (:class:`ExplorationMultiAgentEnv`).
    policies : {"shared", "per_robot"}
        One :class:`~envs.rllib_module.ExplorationModule` for all robots
        (parameter sharing), or one per robot, named after it.
    model_config : mapping, optional
        Overrides of :data:`envs.rllib_module.DEFAULT_MODEL_CONFIG`.

    Returns
    -------
    ray.rllib.algorithms.ppo.PPOConfig
        The environment, modules, policy mapping and metrics callback set; env
        runners, training settings and resources left for the caller.
    """
    if policies not in POLICY_SHARING:
        raise ValueError(f"policies must be one of {POLICY_SHARING}, got {policies!r}")
    env_config = dict(env_config or {})
    robots = ExplorationMultiAgentEnv(env_config).env.possible_agents  # checks the arguments
    modules = [SHARED_POLICY] if policies == "shared" else list(robots)

    def spec() -> RLModuleSpec:
        return RLModuleSpec(module_class=ExplorationModule, model_config=dict(model_config or {}))

    return (
        PPOConfig()
        .environment(register(), env_config=env_config)
        .multi_agent(
            policies=set(modules),
            policy_mapping_fn=shared_policy if policies == "shared" else own_policy,
        )
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={m: spec() for m in modules}))
        .callbacks(ExplorationMetricsCallback)
    )
