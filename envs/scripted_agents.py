"""Scripted agents to compare a learner with: random, constant and frontier actions.

Each baseline is called with the parallel environment after ``reset`` or
``step`` and returns the actions of its live agents::

    env = multi_robot_exploration_v0.parallel_env()
    env.reset(seed=0)
    agents = FrontierBaseline()
    while env.agents:
        env.step(agents(env))

:class:`FrontierBaseline` is **privileged**: it plans on each robot's whole
best map (its own grid and its linked teammates'), not on the 64 x 64 window
of the observation, and coordinates through the targets of the teammates a
robot is linked to; its pose and scan are the observation's. It drives with
:class:`tomosim.exploration.TeamExplorer` and the default policy of
``tomosim explore`` (:data:`~tomosim.exploration.DEFAULT_POLICY`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from envs.multi_robot_exploration_v0 import MultiRobotExplorationEnv
from tomosim.exploration import DEFAULT_POLICY, TeamExplorer
from tomosim.team import TeamSession


class RandomBaseline:
    """Uniform random actions in ``[-1, 1]^2``, from its own generator.

    Parameters
    ----------
    rng : int or numpy.random.Generator
    """

    def __init__(self, *, rng: int | np.random.Generator) -> None:
        self.rng = np.random.default_rng(rng)

    def __call__(self, env: MultiRobotExplorationEnv) -> dict[str, NDArray[np.float32]]:
        """One random action per live agent."""
        return {a: self.rng.uniform(-1.0, 1.0, 2).astype(np.float32) for a in env.agents}


class ConstantBaseline:
    """The same ``(linear, angular)`` action for every robot at every step.

    Parameters
    ----------
    action : (2,) array_like
        In ``[-1, 1]``.
    """

    def __init__(self, action: ArrayLike) -> None:
        values = np.asarray(action, dtype=np.float32).reshape(-1)
        if values.shape != (2,) or not np.all(np.abs(values) <= 1.0):
            raise ValueError(f"action must be two numbers in [-1, 1], got {action!r}")
        self.action = values

    def __call__(self, env: MultiRobotExplorationEnv) -> dict[str, NDArray[np.float32]]:
        """The constant action for every live agent."""
        return {a: self.action.copy() for a in env.agents}


class FrontierBaseline:
    """Frontier exploration on each robot's best map (privileged; module docstring).

    Parameters
    ----------
    policy : str
        The exploration policy (default that of ``tomosim explore``).
    """

    def __init__(self, policy: str = DEFAULT_POLICY) -> None:
        self.policy = policy
        self._session: TeamSession | None = None
        self._explorer: TeamExplorer | None = None

    def __call__(self, env: MultiRobotExplorationEnv) -> dict[str, Any]:
        """One command per live agent from the team's frontier explorer."""
        session = env.session
        if session is None:
            raise RuntimeError("reset the environment before asking for actions")
        if session is not self._session or self._explorer is None:  # a new episode
            self._session = session
            self._explorer = TeamExplorer(session.count, policy=self.policy)
        commands = self._explorer.act(session).astype(np.float32)
        return {
            agent: commands[k] for k, agent in enumerate(env.possible_agents) if agent in env.agents
        }
