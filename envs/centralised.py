"""A Gymnasium single-agent view: one controller drives the whole team.

``gymnasium.make("tomosim/MultiRobotExploration-v0")`` (after ``import envs``, or
with the id ``"envs:tomosim/MultiRobotExploration-v0"``) builds a
:class:`CentralisedExplorationEnv` around the PettingZoo environment of
:mod:`envs.multi_robot_exploration_v0` with the same arguments.

=====================  =============================================================
Action space           ``Box(-1, 1, (N, 2), float32)``: row ``k`` drives robot ``k``
Observation space      ``Dict(scan (N, 360) float32, map (N, 64, 64) int8,
                       pose (N, 3) float32)``: the robots' observations stacked in
                       agent order (their meaning is in the parallel environment)
Reward                 the sum of the robots' rewards: square metres of free space
                       the team saw for the first time
Episode end            termination: team coverage >= ``coverage_target``;
                       truncation: ``max_cycles`` steps
Info                   the parallel environment's infos by agent id under ``agents``
=====================  =============================================================

Seeding follows Gymnasium: ``reset(seed=...)`` reseeds ``self.np_random``,
the one generator every draw comes from; ``reset()`` continues with it.
"""

from __future__ import annotations

from typing import Any, cast

import gymnasium
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from envs.multi_robot_exploration_v0 import MultiRobotExplorationEnv, parallel_env

ENV_ID = "tomosim/MultiRobotExploration-v0"
"""The Gymnasium id this view is registered under (in :mod:`envs`)."""


class CentralisedExplorationEnv(gymnasium.Env[dict[str, Any], NDArray[np.float32]]):
    """The whole team as one Gymnasium agent (module docstring).

    Parameters
    ----------
    render_mode : str or None
        None, ``"rgb_array"`` or ``"human"`` (a matplotlib window).
    **kwargs
        Arguments of :class:`~envs.multi_robot_exploration_v0.MultiRobotExplorationEnv`.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}  # noqa: RUF012  # Gymnasium API

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        self.team: MultiRobotExplorationEnv = parallel_env(render_mode=render_mode, **kwargs)
        self.render_mode = render_mode
        count = len(self.team.possible_agents)
        single = self.team.observation_space(self.team.possible_agents[0])
        assert isinstance(single, spaces.Dict)  # the parallel environment's own space
        stacked: dict[str, spaces.Space[Any]] = {}
        for key, box in single.spaces.items():
            assert isinstance(box, spaces.Box)
            stacked[key] = spaces.Box(
                np.broadcast_to(box.low, (count, *box.shape)),
                np.broadcast_to(box.high, (count, *box.shape)),
                dtype=cast(Any, box.dtype),  # Gymnasium 1.2 types it as a scalar type
            )
        self.observation_space = spaces.Dict(stacked)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(count, 2), dtype=np.float32)

    def _stack(self, observations: dict[str, dict[str, NDArray[Any]]]) -> dict[str, NDArray[Any]]:
        agents = self.team.possible_agents
        return {
            key: np.stack([observations[a][key] for a in agents]) for key in observations[agents[0]]
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode; ``seed`` reseeds :attr:`np_random`."""
        super().reset(seed=seed)
        observations, infos = self.team.start(self.np_random)
        return self._stack(observations), {"agents": infos}

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Drive robot ``k`` with ``action[k]``."""
        agents = self.team.possible_agents
        moves = np.asarray(action, dtype=np.float64)
        if moves.shape != (len(agents), 2):
            raise ValueError(f"action must have shape ({len(agents)}, 2), got {moves.shape}")
        if not self.team.agents:
            raise RuntimeError("the episode has ended; call reset()")
        observations, rewards, terminations, truncations, infos = self.team.step(
            {agent: moves[k] for k, agent in enumerate(agents)}
        )
        terminated = any(terminations.values())
        truncated = any(truncations.values()) and not terminated
        reward = float(sum(rewards.values()))
        return self._stack(observations), reward, terminated, truncated, {"agents": infos}

    def render(self) -> Any:  # Gymnasium 1.2 types Env.render with a type variable
        """The frame of the parallel environment's ``render``: a ``(rows, cols, 3)`` uint8
        array, or None."""
        return self.team.render()

    def close(self) -> None:
        """Release the episode (safe to call twice)."""
        self.team.close()
