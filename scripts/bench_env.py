"""Benchmark the exploration environment: robot-steps per second under random actions.

A robot-step is one robot advanced by one ``env.step``: its share of the
physics, its lidar scan and map update, the team coverage and reward, its
observation (scan, map window, pose) and its share of the merge rounds
(every ``merge_interval`` steps, all pairs) and of the teammate-map refreshes.
This is what a learner pays per agent-step, unlike ``scripts/bench_simulation.py``,
which times the simulator alone.

Three tables:

1. one ``parallel_env()`` with its defaults (3 robots, 360 beams, merging every
   50 steps) and with 8 robots, under uniformly random actions; each
   configuration is run ``--repeats`` times from a fresh ``reset(seed=r)``
   for ``--steps`` timed steps (episodes that end are reset and continue);
2. ``K`` environments stepped in lock step by SuperSuit's vector env over
   ``K`` processes, and all in this process (``--vector 1 2``; needs the
   ``rl`` extra), total robot-steps per second;
3. ``K`` centralised views in Gymnasium's ``AsyncVectorEnv`` (``K`` processes).

The tables give the median and the spread (min..max) over the repeats, of
rates by the wall clock and, for one environment, by CPU time (``cpu``
columns). The global merge searches run in a worker process
(:mod:`tomosim.team.worker`); when a round needs searches the worker has not
started, the environment's process runs them itself rather than wait idle.
The ``cpu`` rate divides by the process's CPU time less those searches: the
environment's own cost, comparable between versions and steadier than the
wall clock on a machine loaded by other work; ``searches here`` is the share
of the process's CPU time that went to searches. The wall clock includes
every wait for the worker: on a machine with no idle core for it, it reads
low. To compare with another checkout, run this script with
``PYTHONPATH=/path/to/that/checkout``.

Each timed run waits until the search worker is ready (it warms up for about
a second after it starts), as it waits for compiled code with its untimed
warm-up steps: a learner's millions of steps see the worker ready.

Measured on this 2-core machine with nothing else running, 11 times over an
hour (medians of 9 runs of 300 steps, wall clock): 3 robots 3753 to 6673
robot-steps/s (median 5676), 8 robots 2473 to 4298 (median 3563), following
the host's speed, which the ``cpu`` column shows falling alike; against the
version before, run by run, 1.11 times as fast with 3 robots (geometric
mean of six pairs; README, "The environment: robot-steps per second").

Usage::

    python scripts/bench_env.py [--robots 3 8] [--steps 300] [--repeats 9]
    python scripts/bench_env.py --vector 1 2 --steps 200 --repeats 3
    python scripts/bench_env.py --profile 600   # cProfile of one run, top functions
"""

from __future__ import annotations

import argparse
import cProfile
import importlib.util
import inspect
import pstats
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from envs import multi_robot_exploration_v0 as exploration
from tomosim.commands.script_args import non_negative_int, positive_int, run_script

try:
    from tomosim.team.worker import WorkerSearches
except ImportError:  # a checkout from before the search worker, timed with PYTHONPATH
    WorkerSearches = None

WARMUP_STEPS = 20
"""Untimed steps before each timed run (first-call and compilation costs)."""
WORKER_READY_SECONDS = 60.0
"""How long a run waits for the search worker to warm up before its timed steps."""
VECTOR_WARMUP_SECONDS = 2.0
"""Untimed stepping of a vector env before its timed steps (its processes' search
workers warm up meanwhile)."""
ACTION_SEED_OFFSET = 1000
"""Offset between a run's reset seed and the seed of its action sampler."""


def merging_off() -> dict[str, Any]:
    """Environment arguments that switch merging off: ``team=TeamConfig(merge=False)``, or
    ``merge=False`` for a checkout from before the ``team`` argument, timed with
    ``PYTHONPATH``."""
    if "team" in inspect.signature(exploration.MultiRobotExplorationEnv).parameters:
        from tomosim.team import TeamConfig

        return {"team": TeamConfig(merge=False)}
    return {"merge": False}


def random_actions(env: Any, generator: np.random.Generator) -> dict[str, Any]:
    """Uniform actions in ``[-1, 1]^2`` for every live agent."""
    return {agent: generator.uniform(-1.0, 1.0, 2).astype(np.float32) for agent in env.agents}


def searches_here() -> float:
    """CPU seconds this process has spent on merge searches it took back from the worker
    (0 for a checkout whose environment never does that, timed with ``PYTHONPATH``)."""
    return float(getattr(WorkerSearches, "cpu_seconds_here", 0.0))


def wait_for_worker() -> None:
    """Wait until the search worker is warmed up (a second or so after it starts).

    Until then an environment runs its searches itself; a learner's millions of
    steps see the worker ready, so the timed steps should too. For an older
    checkout timed with ``PYTHONPATH``, whose searches have no ``wait_ready``,
    this polls its worker's flag; a checkout without a worker is not waited for.
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


def bench_single(
    robots: int, steps: int, repeats: int, **kwargs: Any
) -> tuple[list[float], list[float], list[float]]:
    """Robot-steps per second of ``repeats`` fresh runs of one environment, by the wall
    clock and by CPU time without merge searches, and the share of the process's CPU
    time spent on merge searches."""
    wall, cpu, shares = [], [], []
    for repeat in range(repeats):
        env = exploration.parallel_env(robots=robots, **kwargs)
        env.reset(seed=repeat)
        wait_for_worker()
        generator = np.random.default_rng(ACTION_SEED_OFFSET + repeat)
        run_steps(env, WARMUP_STEPS, generator, repeat)
        seconds, cpu_seconds, search_seconds = run_steps(env, steps, generator, repeat)
        wall.append(robots * steps / seconds)
        cpu.append(robots * steps / max(cpu_seconds - search_seconds, 1e-9))
        shares.append(search_seconds / max(cpu_seconds, 1e-9))
        env.close()
    return wall, cpu, shares


def advance_vector(venv: Any, steps: int, actions: Callable[[], Any]) -> float:
    """Step a vector env ``steps`` times under ``actions()``; returns the seconds taken."""
    start = time.perf_counter()
    for _ in range(steps):
        venv.step(np.asarray(actions(), dtype=np.float32))
    return time.perf_counter() - start


def warm_up_vector(venv: Any, actions: Callable[[], Any]) -> None:
    """Untimed steps: at least ``WARMUP_STEPS``, and for ``VECTOR_WARMUP_SECONDS``.

    Environments in worker processes each start their own search worker, which
    this process cannot wait for; stepping a couple of seconds covers its warm-up
    (about a second), as :func:`wait_for_worker` does for one environment.
    """
    start = time.perf_counter()
    advance_vector(venv, WARMUP_STEPS, actions)
    while time.perf_counter() - start < VECTOR_WARMUP_SECONDS:
        advance_vector(venv, WARMUP_STEPS, actions)


def bench_supersuit(
    envs: int, robots: int, steps: int, repeats: int, *, processes: int
) -> list[float]:
    """Robot-steps per second of ``envs`` environments stepped by SuperSuit's vector env,
    in ``processes`` worker processes (0: all in this process, sharing its search worker)."""
    from envs.vector import make_supersuit_vector_env

    rates = []
    for repeat in range(repeats):
        venv = make_supersuit_vector_env(envs, processes=processes, robots=robots)
        venv.reset(seed=repeat)
        if processes == 0:
            wait_for_worker()
        generator = np.random.default_rng(ACTION_SEED_OFFSET + repeat)
        count = venv.num_envs  # agents over all environments
        warm_up_vector(venv, lambda n=count, g=generator: g.uniform(-1, 1, (n, 2)))
        seconds = advance_vector(venv, steps, lambda n=count, g=generator: g.uniform(-1, 1, (n, 2)))
        rates.append(count * steps / seconds)
        venv.close()
    return rates


def bench_gymnasium(envs: int, robots: int, steps: int, repeats: int) -> list[float]:
    """Robot-steps per second of ``envs`` centralised views in Gymnasium's AsyncVectorEnv."""
    from envs.vector import make_gymnasium_vector_env

    rates = []
    for repeat in range(repeats):
        venv = make_gymnasium_vector_env(envs, robots=robots)
        venv.reset(seed=repeat)
        venv.action_space.seed(ACTION_SEED_OFFSET + repeat)
        warm_up_vector(venv, venv.action_space.sample)
        seconds = advance_vector(venv, steps, venv.action_space.sample)
        rates.append(envs * robots * steps / seconds)
        venv.close()
    return rates


def row(
    label: str,
    rates: list[float],
    cpu: list[float] | None = None,
    shares: list[float] | None = None,
) -> str:
    """One table row: label, median, min, max (and the same by CPU time, and the
    median share of searches)."""
    text = f"{label:<28} {statistics.median(rates):>8.0f} {min(rates):>8.0f} {max(rates):>8.0f}"
    if cpu is not None:
        text += f" {statistics.median(cpu):>10.0f} {min(cpu):>8.0f} {max(cpu):>8.0f}"
    if shares is not None:
        text += f" {100 * statistics.median(shares):>13.0f}%"
    return text


def header(title: str, cpu: bool = False) -> str:
    """A table's title and column names."""
    names = f"{'configuration':<28} {'median':>8} {'min':>8} {'max':>8}"
    if cpu:
        names += f" {'cpu median':>10} {'min':>8} {'max':>8} {'searches here':>14}"
    return f"\n{title}\n{names}"


def profile(steps: int, top: int) -> None:
    """Print the ``top`` functions by cumulative time of one default run of ``steps`` steps."""
    env = exploration.parallel_env()
    env.reset(seed=0)
    wait_for_worker()
    generator = np.random.default_rng(ACTION_SEED_OFFSET)
    run_steps(env, WARMUP_STEPS, generator, 0)
    profiler = cProfile.Profile()
    profiler.enable()
    run_steps(env, steps, generator, 0)
    profiler.disable()
    pstats.Stats(profiler).sort_stats("cumulative").print_stats(top)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=positive_int, nargs="+", default=[3, 8])
    parser.add_argument("--steps", type=positive_int, default=300, help="timed joint steps per run")
    parser.add_argument("--repeats", type=positive_int, default=9, help="runs per configuration")
    parser.add_argument(
        "--vector",
        type=positive_int,
        nargs="*",
        default=[],
        help="numbers K of environments to step in parallel (needs the rl extra)",
    )
    parser.add_argument("--no-merge", action="store_true", help="also time merging off")
    parser.add_argument(
        "--profile", type=non_negative_int, default=0, help="profile this many steps"
    )
    parser.add_argument("--top", type=positive_int, default=40, help="functions the profile lists")
    args = parser.parse_args()
    if args.vector and importlib.util.find_spec("supersuit") is None:  # before the long tables
        parser.error('--vector needs the rl extra: python -m pip install -e ".[rl]"')
    if args.profile:
        profile(args.profile, args.top)
        return
    print(f"{args.steps} timed steps x {args.repeats} repeats, random actions, robot-steps/s")
    print(header("one environment, parallel_env() defaults", cpu=True))
    for robots in args.robots:
        print(row(f"{robots} robots", *bench_single(robots, args.steps, args.repeats)), flush=True)
        if args.no_merge:
            rates = bench_single(robots, args.steps, args.repeats, **merging_off())
            print(row(f"{robots} robots, no merging", *rates), flush=True)
    if args.vector:
        print(header("K environments, SuperSuit vector env (3 robots each)"))
        for count in args.vector:
            for processes, where in ((count, f"{count} processes"), (0, "this process")):
                rates = bench_supersuit(count, 3, args.steps, args.repeats, processes=processes)
                print(row(f"K = {count}, {where}", rates), flush=True)
        print(header("K centralised views, Gymnasium AsyncVectorEnv (3 robots each)"))
        for count in args.vector:
            rates = bench_gymnasium(count, 3, args.steps, args.repeats)
            print(row(f"K = {count}", rates), flush=True)


if __name__ == "__main__":
    run_script(main, __file__)
