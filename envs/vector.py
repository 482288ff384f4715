"""Many exploration environments at once: SuperSuit's vector envs and Gymnasium's.

Two ways to step ``K`` environments together:

* **one agent per robot** (a shared policy, the usual multi-agent setting):
  :func:`make_supersuit_vector_env` turns each parallel environment into a
  Gymnasium vector env of its ``N`` robots (SuperSuit's
  ``pettingzoo_env_to_vec_env_v1``) and concatenates ``K`` of them
  (``concat_vec_envs_v1``), in ``processes`` worker processes: one batch of
  ``K * N`` observations, actions and rewards per step; an environment whose
  episode ends is reset at once;
* **one agent per team**: :func:`make_gymnasium_vector_env` steps ``K``
  centralised views (:mod:`envs.centralised`) in Gymnasium's
  ``AsyncVectorEnv``, one process each.

For Stable-Baselines3, :func:`make_sb3_vector_env` wraps the first with
:class:`envs.sb3.SB3VectorEnv`, which seeds, marks truncation and keeps the
final step's infos (the gaps of SuperSuit's own SB3 wrapper).
``scripts/bench_env.py --vector 1 2`` times both ways.

SuperSuit and Stable-Baselines3 come with the ``rl`` extra
(``pip install -e ".[rl]"``).
"""

from __future__ import annotations

import atexit
import weakref
from typing import Any

import gymnasium

from envs.centralised import CentralisedExplorationEnv
from envs.multi_robot_exploration_v0 import parallel_env
from merging.validators import whole_number

RL_INSTALL = 'pip install -e ".[rl]"'
"""The command that installs SuperSuit, Stable-Baselines3 and a CPU build of torch."""


def _supersuit() -> Any:
    try:
        import supersuit
    except ImportError as error:
        raise ImportError(f"vector environments need SuperSuit: {RL_INSTALL}") from error
    return supersuit


def make_supersuit_vector_env(envs: int, *, processes: int = 0, **kwargs: Any) -> Any:
    """``envs`` parallel environments as one Gymnasium vector env of all their robots.

    Parameters
    ----------
    envs : int
        Number ``K`` of environments.
    processes : int
        Worker processes stepping them (0 or 1: all in this process).
    **kwargs
        Arguments of :func:`envs.multi_robot_exploration_v0.parallel_env`.

    Returns
    -------
    gymnasium.vector.VectorEnv
        ``num_envs = K * N``: robot ``k`` of environment ``e`` is entry ``e * N + k``.
        ``reset(seed=s)`` seeds environment ``e`` with ``s + e``, however many
        processes step them. Close it when done; worker processes left open are
        closed when the interpreter exits.
    """
    whole_number(envs, "envs", minimum=1)
    whole_number(processes, "processes", minimum=0)
    supersuit = _supersuit()
    robots = supersuit.pettingzoo_env_to_vec_env_v1(parallel_env(**kwargs))
    venv = supersuit.concat_vec_envs_v1(robots, envs, num_cpus=processes, base_class="gymnasium")
    if hasattr(venv, "pipes"):  # SuperSuit's process vector env
        _seed_per_environment(venv, robots.num_envs)
        _close_at_exit(venv)
    return venv


def _seed_per_environment(venv: Any, robots: int) -> None:
    """Give a process vector env's reset the seeds and infos of the in-process one.

    SuperSuit's ``ProcConcatVec.reset(seed=s)`` sends ``s + p`` to process
    ``p``, which seeds its ``k``-th environment with ``s + p + k``: with two
    processes of two environments each, environments 1 and 2 both got
    ``s + 1`` and ran the same episode. Here process ``p`` is sent ``s`` plus
    the index of its first environment, so environment ``e`` gets ``s + e``
    as in one process; and the reset's infos, which came back as one packed
    list per process, are one dictionary per robot, as ``step``'s are.
    """
    from supersuit.vector.multiproc_vec import decompress_info, numpy_deepcopy

    firsts = [start // robots for start in venv.idx_starts[:-1]]

    def reset(seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        for pipe, first in zip(venv.pipes, firsts, strict=True):
            pipe.send(("reset", (None if seed is None else seed + first, options)))
        compressed = venv._receive_info()  # per process: (robot, info) of non-empty infos
        infos = decompress_info(venv.num_envs, venv.idx_starts, compressed)
        return numpy_deepcopy(venv.observations_buffers), [dict(info) for info in infos]

    venv.reset = reset


def _close_at_exit(venv: Any) -> None:
    """Close ``venv``'s worker processes when the interpreter exits, if the caller has not.

    They are not daemons, so Python's exit would wait for them for ever; this
    hook runs before multiprocessing's own (exit hooks run last registered
    first), and holds only a weak reference.
    """
    alive = weakref.ref(venv)

    def close() -> None:
        still = alive()
        if still is not None:
            still.close()

    atexit.register(close)


def make_sb3_vector_env(envs: int, *, processes: int = 0, **kwargs: Any) -> Any:
    """:func:`make_supersuit_vector_env` as a Stable-Baselines3 ``VecEnv``
    (:class:`envs.sb3.SB3VectorEnv`)."""
    try:
        from envs.sb3 import SB3VectorEnv
    except ImportError as error:
        raise ImportError(f"the SB3 adapter needs Stable-Baselines3: {RL_INSTALL}") from error
    return SB3VectorEnv(make_supersuit_vector_env(envs, processes=processes, **kwargs), envs)


def _centralised(kwargs: dict[str, Any]) -> CentralisedExplorationEnv:
    return CentralisedExplorationEnv(**kwargs)


def make_gymnasium_vector_env(envs: int, **kwargs: Any) -> gymnasium.vector.AsyncVectorEnv:
    """``envs`` centralised views (one agent drives a team) in ``envs`` processes.

    ``reset(seed=s)`` seeds view ``e`` with ``s + e``; an ended episode is
    reset at the next step (Gymnasium's default autoreset).
    """
    whole_number(envs, "envs", minimum=1)
    return gymnasium.vector.AsyncVectorEnv([lambda: _centralised(kwargs) for _ in range(envs)])
