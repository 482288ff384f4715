"""A Stable-Baselines3 ``VecEnv`` over SuperSuit's vector env of the robots.

SuperSuit's own ``concat_vec_envs_v1(..., base_class="stable_baselines3")``
has three gaps this adapter closes (each pinned by a test):

1. seeding: ``PPO(..., seed=0)`` calls ``VecEnv.seed``, which SuperSuit
   forwards to its ``ConcatVecEnv``, which has none (``'ConcatVecEnv' object
   has no attribute 'seed'``); here ``seed(s)`` is kept for the next
   ``reset``, which passes it on (environment ``e`` gets ``s + e``);
2. truncation: it reports ``done`` for a ``max_cycles`` cut-off without
   ``TimeLimit.truncated``, so PPO takes the cut-off for a true end and does
   not bootstrap from the final observation; here every truncated, not
   terminated, entry is marked;
3. final infos: its auto-reset merges the reset's infos into the final
   step's, so keys such as ``team_coverage`` belong to the next episode; the
   environment's ``episode`` info, which no reset writes, survives, and here
   each finished entry also gets ``final_info``, the final step's figures
   (``episode`` without the per-agent ``returns``).

:class:`ExplorationMetricsCallback` logs the finished episodes' figures
(:mod:`envs.learning_metrics`) through Stable-Baselines3's logger, and so to
TensorBoard when the model has a ``tensorboard_log`` folder.

Importing this module needs Stable-Baselines3 (the ``rl`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnv

from envs.learning_metrics import episode_scalars
from merging.validators import whole_number

METRICS_PREFIX = "exploration"
"""The logger's section of the episode figures: ``exploration/team_coverage``, ..."""


class SB3VectorEnv(VecEnv):
    """Stable-Baselines3's ``VecEnv`` interface over a Gymnasium vector env of robots.

    Parameters
    ----------
    venv : gymnasium.vector.VectorEnv
        From :func:`envs.vector.make_supersuit_vector_env`.
    envs : int
        The environments behind it (its entries are their robots, in order).
    """

    def __init__(self, venv: Any, envs: int) -> None:
        whole_number(envs, "envs", minimum=1)
        if venv.num_envs % envs:
            raise ValueError(
                f"envs must be a whole number >= 1 dividing the {venv.num_envs} robot "
                f"entries, got {envs!r}"
            )
        self.venv = venv
        self.envs = envs
        self.render_mode = venv.render_mode  # read by VecEnv's constructor
        super().__init__(venv.num_envs, venv.observation_space, venv.action_space)
        self._actions: NDArray[Any] | None = None

    def reset(self) -> Any:
        """Reset every environment; with the seed of the last :meth:`seed` call, if any."""
        seed = self._seeds[0]
        observations, infos = self.venv.reset(seed=seed)
        self.reset_infos = list(infos)
        self._reset_seeds()
        return observations

    def step_async(self, actions: NDArray[Any]) -> None:
        """Keep the actions for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> tuple[Any, NDArray[np.float32], NDArray[np.bool_], list[dict[str, Any]]]:
        """Step all environments; marks truncation and keeps the final infos (module docstring)."""
        assert self._actions is not None  # step_async came first
        observations, rewards, terminations, truncations, infos = self.venv.step(self._actions)
        terminated = np.asarray(terminations, dtype=bool)
        truncated = np.asarray(truncations, dtype=bool)
        infos = [dict(info) for info in infos]
        for index, info in enumerate(infos):
            if terminated[index] or truncated[index]:
                info["TimeLimit.truncated"] = bool(truncated[index] and not terminated[index])
                episode = info.get("episode")
                if episode is not None:
                    info["final_info"] = {k: v for k, v in episode.items() if k != "returns"}
        return observations, np.asarray(rewards, dtype=np.float32), terminated | truncated, infos

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed the next :meth:`reset`: environment ``e`` gets ``seed + e``.

        Returns each entry's seed: that of the environment its robot is in.
        """
        if seed is None:
            return [None] * self.num_envs
        robots = self.num_envs // self.envs
        self._seeds = [seed + index // robots for index in range(self.num_envs)]
        return self._seeds

    def get_images(self) -> Sequence[NDArray[np.uint8] | None]:
        """One frame, of the first environment (SuperSuit draws that one), not one per
        entry as ``VecEnv`` has it: the image ``render()`` returns (tiling one image is
        that image), and what ``VecVideoRecorder`` records."""
        if self.render_mode != "rgb_array":
            raise ValueError(
                f"images need render_mode='rgb_array' when the vector env is made, "
                f"got {self.render_mode!r}"
            )
        return [self.venv.render()]

    def close(self) -> None:
        """Close the vector env and its processes."""
        self.venv.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The attribute from this adapter for every entry (the environments live behind
        SuperSuit, which does not expose theirs)."""
        return [getattr(self, attr_name)] * len(list(self._get_indices(indices)))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Not supported: the environments live behind SuperSuit."""
        raise NotImplementedError(
            f"set_attr({attr_name!r}) is not supported through SuperSuit's vector env: "
            "pass the setting to envs.vector.make_sb3_vector_env when making it"
        )

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        """Not supported: the environments live behind SuperSuit."""
        raise NotImplementedError(
            f"env_method({method_name!r}) is not supported through SuperSuit's vector env: "
            "the robots share environments; call the method on an environment made with "
            "envs.multi_robot_exploration_v0.parallel_env instead"
        )

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """No entry is wrapped in a Gymnasium wrapper (they are robots, not envs)."""
        return [False] * len(list(self._get_indices(indices)))


class ExplorationMetricsCallback(BaseCallback):
    """Records each finished episode's figures (:func:`envs.learning_metrics.episode_scalars`).

    They go to Stable-Baselines3's logger as ``exploration/<name>`` with
    ``record_mean``: what it writes at the end of a rollout (to TensorBoard
    with ``PPO(..., tensorboard_log=DIR)``) is their mean over the episodes
    that ended in it.

    Parameters
    ----------
    robots : int
        Robots per environment: the entries of one environment share an
        episode, which is counted once (from its first robot's entry).
    """

    def __init__(self, robots: int) -> None:
        if not (isinstance(robots, int) and robots >= 1):
            raise ValueError(f"robots must be a whole number >= 1, got {robots!r}")
        super().__init__()
        self.robots = robots

    def _on_step(self) -> bool:
        for index, info in enumerate(self.locals["infos"]):
            episode = info.get("episode")
            if index % self.robots or episode is None:
                continue
            for name, value in episode_scalars(episode).items():
                self.logger.record_mean(f"{METRICS_PREFIX}/{name}", value)
        return True
