"""Time one checkout's exploration environment: the timed runs of ``bench_env.py``.

A timed run builds ``parallel_env(robots=N)``, resets it with a seed, waits
for the merge search worker to be ready (as for compiled code, with
untimed warm-up steps: a learner's millions of steps see both ready), and
steps it under uniformly random actions, resetting episodes that end.

``bench_env.py`` runs these functions in its own process, and, to compare
checkouts (``--against PATH``), runs this file as a child process per
checkout with ``PYTHONPATH`` set to that checkout, so that each child imports
that checkout's code. This file therefore imports nothing of the project but
what every version of the environment has (``envs.multi_robot_exploration_v0``,
and the search worker where there is one). As a child it speaks one JSON
object per line: it first says which file it imported the environment from,
then answers each request ``{"robots", "steps", "seed"}`` with the run's
``{"wall", "cpu", "searches"}`` seconds (the first of each number of
robots after an untimed run, :func:`warm_up`).

Usage (by ``bench_env.py``)::

    PYTHONPATH=/path/to/checkout python scripts/bench_env_runner.py
"""

from __future__ import annotations

import inspect
import json
import sys
import time
from typing import Any

import numpy as np

from envs import multi_robot_exploration_v0 as exploration

WorkerSearches: Any
try:
    from tomosim.team.worker import WorkerSearches
except ImportError:  # a checkout from before the search worker
    WorkerSearches = None

WARMUP_STEPS = 20
"""Untimed steps before each timed run (first-call and compilation costs)."""
WORKER_READY_SECONDS = 60.0
"""How long a run waits for the search worker to warm up before its timed steps."""
ACTION_SEED_OFFSET = 1000
"""Offset between a run's reset seed and the seed of its action sampler."""
WARMUP_RUN_STEPS = 120
"""Steps of the untimed run a process makes before its first timed one: two merge rounds
at the default interval (50), whose compiled code is loaded on first use."""
WARMUP_SEED = 10_000
"""Seed of that untimed run (no timed run uses it)."""


def random_actions(env: Any, generator: np.random.Generator) -> dict[str, Any]:
    """Uniform actions in ``[-1, 1]^2`` for every live agent."""
    return {agent: generator.uniform(-1.0, 1.0, 2).astype(np.float32) for agent in env.agents}


def searches_here() -> float:
    """CPU seconds this process has spent on merge searches it took back from the worker
    (0 for a checkout whose environment never does that)."""
    return float(getattr(WorkerSearches, "cpu_seconds_here", 0.0))


def wait_for_worker() -> None:
    """Wait until the search worker is warmed up (a second or so after it starts).

    Until then an environment runs its searches itself. For an older checkout
    whose searches have no ``wait_ready``, this polls its worker's flag; a
    checkout without a worker is not waited for.
    """
    if WorkerSearches is None:
        return
    wait_ready = getattr(WorkerSearches, "wait_ready", None)
    if wait_ready is None:
        worker = WorkerSearches.worker()
        deadline = time.monotonic() + WORKER_READY_SECONDS
        while not getattr(worker, "ready", True) and time.monotonic() < deadline:
            time.sleep(0.01)
        return
    if not wait_ready(WORKER_READY_SECONDS):
        raise RuntimeError(
            f"the merge search worker was not ready within {WORKER_READY_SECONDS} s; "
            "check that `python -m tomosim.search_worker` starts in this environment"
        )


def run_steps(
    env: Any, steps: int, generator: np.random.Generator, seed: int
) -> tuple[float, float, float]:
    """Step ``env`` ``steps`` times under random actions, resetting ended episodes;
    returns the wall-clock and CPU seconds taken, and the CPU seconds of merge
    searches this process ran itself (taken back from the worker)."""
    start, cpu = time.perf_counter(), time.process_time()
    searches = searches_here()
    for _ in range(steps):
        if not env.agents:
            seed += 1
            env.reset(seed=seed)
        env.step(random_actions(env, generator))
    return (
        time.perf_counter() - start,
        time.process_time() - cpu,
        searches_here() - searches,
    )


def merging_off() -> dict[str, Any]:
    """Environment arguments that switch merging off: ``team=TeamConfig(merge=False)``, or
    ``merge=False`` for a checkout from before the ``team`` argument."""
    if "team" in inspect.signature(exploration.MultiRobotExplorationEnv).parameters:
        from tomosim.team import TeamConfig

        return {"team": TeamConfig(merge=False)}
    return {"merge": False}


def timed_run(robots: int, steps: int, seed: int, **kwargs: Any) -> tuple[float, float, float]:
    """One timed run (module docstring) of a fresh environment reset with ``seed``;
    returns what :func:`run_steps` does for its timed steps."""
    env = exploration.parallel_env(robots=robots, **kwargs)
    env.reset(seed=seed)
    wait_for_worker()
    generator = np.random.default_rng(ACTION_SEED_OFFSET + seed)
    run_steps(env, WARMUP_STEPS, generator, seed)
    timing = run_steps(env, steps, generator, seed)
    env.close()
    return timing


_warmed_up: set[int] = set()


def warm_up(robots: int) -> None:
    """One untimed run of :data:`WARMUP_RUN_STEPS` steps with ``robots`` robots, so that no
    timed run pays for loading compiled code (once per process and number of robots)."""
    if robots not in _warmed_up:
        timed_run(robots, WARMUP_RUN_STEPS, WARMUP_SEED)
        _warmed_up.add(robots)


def serve() -> None:
    """The child's side of ``bench_env.py --against`` (module docstring)."""
    print(json.dumps({"module": exploration.__file__}), flush=True)
    for line in sys.stdin:
        request = json.loads(line)
        warm_up(request["robots"])
        wall, cpu, searches = timed_run(request["robots"], request["steps"], request["seed"])
        print(json.dumps({"wall": wall, "cpu": cpu, "searches": searches}), flush=True)


if __name__ == "__main__":
    serve()
