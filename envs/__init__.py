"""PettingZoo environments built on the tomosim simulation core.

* :mod:`envs.multi_robot_exploration_v0`: robots explore from unknown start
  poses and merge their maps periodically (parallel API, spec card in its
  docstring);
* :mod:`envs.vector`: K of them at once (SuperSuit's vector envs, Gymnasium's
  ``AsyncVectorEnv``), and :mod:`envs.sb3`, a Stable-Baselines3 ``VecEnv``;
* :mod:`envs.rllib`: RLlib's multi-agent view, a CNN module and PPO set up
  for it (the ``rllib`` extra);
* :mod:`envs.learning_metrics`: the finished episodes' figures that
  trainers log;
* :mod:`envs.scripted_agents`: random, constant and frontier agents to compare a
  learner with.

Importing this package registers the Gymnasium single-agent view
(:mod:`envs.centralised`) as ``tomosim/MultiRobotExploration-v0``::

    import gymnasium
    import envs  # noqa: F401  (registers the id)

    team = gymnasium.make("tomosim/MultiRobotExploration-v0", robots=2)
"""

import gymnasium

from envs.centralised import ENV_ID

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="envs.centralised:CentralisedExplorationEnv")

__all__ = ["ENV_ID"]
