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
environment's own cost, steadier than the wall clock on a machine loaded by
other work; ``searches here`` is the share of the process's CPU time that
went to searches. The wall clock includes every wait for the worker: on a
machine with no idle core for it, it reads low.

Each timed run waits until the search worker is ready (it warms up for about
a second after it starts), as it waits for compiled code with its untimed
warm-up steps: a learner's millions of steps see the worker ready
(:mod:`bench_env_runner`, which does the timed runs).

Comparing checkouts
-------------------
The host's speed drifts by a factor of two within an hour, so versions are
compared only within one run: ``--against PATH [PATH ...]`` times this
checkout and each other one (e.g. an older commit made with ``git worktree
add --detach PATH COMMIT``) in turn, one run of each per seed, the first to
run moving round from seed to seed. Each checkout runs in its own child
process (``bench_env_runner.py`` with ``PYTHONPATH`` and the working
directory set to that checkout, under this interpreter and its packages),
which must report that it imported the environment from inside that
checkout. It prints each checkout's median and spread of robot-steps per
second by the wall clock, and for each other checkout the ratio of this
checkout's median to its median and the median and spread of the ratios of
runs with the same seed.

Usage::

    python scripts/bench_env.py [--robots 3 8] [--steps 300] [--repeats 9]
    python scripts/bench_env.py --against ../round1 ../main --robots 3 8
    python scripts/bench_env.py --vector 1 2 --steps 200 --repeats 3
    python scripts/bench_env.py --profile 600   # cProfile of one run, top functions
"""

from __future__ import annotations

import argparse
import cProfile
import importlib.util
import json
import os
import pstats
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import IO, Any

import numpy as np
from bench_env_runner import (
    ACTION_SEED_OFFSET,
    WARMUP_STEPS,
    merging_off,
    run_steps,
    timed_run,
    wait_for_worker,
    warm_up,
)

from envs import multi_robot_exploration_v0 as exploration
from tomosim.commands.script_args import non_negative_int, positive_int, run_script

VECTOR_WARMUP_SECONDS = 2.0
"""Untimed stepping of a vector env before its timed steps (its processes' search
workers warm up meanwhile)."""
RUNNER = Path(__file__).resolve().with_name("bench_env_runner.py")
"""The script that times one checkout in a child process (``--against``)."""


def bench_single(
    robots: int, steps: int, repeats: int, **kwargs: Any
) -> tuple[list[float], list[float], list[float]]:
    """Robot-steps per second of ``repeats`` fresh runs of one environment, by the wall
    clock and by CPU time without merge searches, and the share of the process's CPU
    time spent on merge searches."""
    wall, cpu, shares = [], [], []
    warm_up(robots)
    for repeat in range(repeats):
        seconds, cpu_seconds, search_seconds = timed_run(robots, steps, repeat, **kwargs)
        wall.append(robots * steps / seconds)
        cpu.append(robots * steps / max(cpu_seconds - search_seconds, 1e-9))
        shares.append(search_seconds / max(cpu_seconds, 1e-9))
    return wall, cpu, shares


class Checkout:
    """A child process that times one checkout's environment (``bench_env_runner.py``).

    The child runs with ``PYTHONPATH`` set to the checkout and its working directory
    there (the merge search worker it starts imports from it too); it must say that it
    imported the environment from inside the checkout, else this refuses it.
    """

    def __init__(self, root: Path) -> None:
        self.root = root.resolve()
        if not (self.root / "envs" / "multi_robot_exploration_v0.py").is_file():
            raise ValueError(
                f"--against {root}: no envs/multi_robot_exploration_v0.py there; give the "
                "root of a tomosim checkout (e.g. one made with git worktree add)"
            )
        self.label = f"{self.root} ({commit_of(self.root)})"
        paths = [str(self.root), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
        self.process = subprocess.Popen(
            [sys.executable, str(RUNNER)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            cwd=self.root,
            env={**os.environ, "PYTHONPATH": os.pathsep.join(paths)},
        )
        module = Path(self._answer()["module"]).resolve()
        if not module.is_relative_to(self.root):
            self.close()
            raise ValueError(
                f"timing {self.root} imported the environment from {module} instead; "
                "check that the checkout has envs/__init__.py and nothing earlier on the "
                "path shadows it"
            )

    def _answer(self) -> dict[str, Any]:
        """The child's next line, decoded."""
        assert self.process.stdout is not None  # a pipe, made in __init__
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(
                f"the timing process of {self.root} ended (exit status "
                f"{self.process.wait()}); its error is above"
            )
        answer: dict[str, Any] = json.loads(line)
        return answer

    def rate(self, robots: int, steps: int, seed: int) -> float:
        """Robot-steps per second, by the wall clock, of one timed run."""
        stdin: IO[str] | None = self.process.stdin
        assert stdin is not None  # a pipe, made in __init__
        stdin.write(json.dumps({"robots": robots, "steps": steps, "seed": seed}) + "\n")
        stdin.flush()
        return robots * steps / self._answer()["wall"]

    def close(self) -> None:
        """End the child (closing its input ends it)."""
        for stream in (self.process.stdin, self.process.stdout):
            if stream is not None:
                stream.close()
        self.process.wait()


def commit_of(root: Path) -> str:
    """The checkout's commit, abbreviated, with ``+`` when it has uncommitted changes."""
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "not a git checkout"
    return head + ("+" if dirty else "")


def compare(others: list[Path], robots_list: list[int], steps: int, repeats: int) -> None:
    """Time this checkout and ``others`` run by run, in turn, and print their rates
    and the ratios of this checkout's to each other's (module docstring)."""
    here = Path(__file__).resolve().parents[1]
    checkouts = [Checkout(root) for root in [here, *others]]
    try:
        for robots in robots_list:
            rates: list[list[float]] = [[] for _ in checkouts]
            for repeat in range(repeats):  # the first to run moves round each time
                first = repeat % len(checkouts)
                for index in [*range(first, len(checkouts)), *range(first)]:
                    rates[index].append(checkouts[index].rate(robots, steps, repeat))
            print_comparison(robots, checkouts, rates)
    finally:
        for checkout in checkouts:
            checkout.close()


def print_comparison(robots: int, checkouts: list[Checkout], rates: list[list[float]]) -> None:
    """The tables of :func:`compare` for one number of robots."""
    width = max(len(checkout.label) for checkout in checkouts) + len("this ") + 1
    print(f"\n{robots} robots, robot-steps/s by the wall clock, runs in turn")
    print(f"{'checkout':<{width}} {'median':>8} {'min':>8} {'max':>8}")
    for index, checkout in enumerate(checkouts):
        mark = "this " if index == 0 else ""
        print(
            f"{mark + checkout.label:<{width}} {statistics.median(rates[index]):>8.0f} "
            f"{min(rates[index]):>8.0f} {max(rates[index]):>8.0f}"
        )
    columns = f"{'ratio of medians':>17} {'pair ratios: median':>20} {'min':>6} {'max':>6}"
    print(f"\n{'this checkout against':<{width}} {columns}")
    for index in range(1, len(checkouts)):
        pairs = [mine / theirs for mine, theirs in zip(rates[0], rates[index], strict=True)]
        ratio = statistics.median(rates[0]) / statistics.median(rates[index])
        print(
            f"{checkouts[index].label:<{width}} {ratio:>17.2f} {statistics.median(pairs):>20.2f}"
            f" {min(pairs):>6.2f} {max(pairs):>6.2f}",
            flush=True,
        )


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
        actions = partial(generator.uniform, -1.0, 1.0, (venv.num_envs, 2))  # one per agent
        warm_up_vector(venv, actions)
        seconds = advance_vector(venv, steps, actions)
        count = venv.num_envs  # agents over all environments
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
    """Print the ``top`` functions by cumulative time of one default run of ``steps`` steps
    (after an untimed run, so that loading compiled code is not profiled)."""
    env = exploration.parallel_env()
    warm_up(len(env.possible_agents))
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
    parser.add_argument(
        "--against",
        type=Path,
        nargs="+",
        default=[],
        metavar="PATH",
        help="also time these checkouts, run by run in turn with this one, and print the ratios",
    )
    args = parser.parse_args()
    if args.vector and importlib.util.find_spec("supersuit") is None:  # before the long tables
        parser.error('--vector needs the rl extra: python -m pip install -e ".[rl]"')
    if args.profile:
        profile(args.profile, args.top)
        return
    if args.against:
        print(f"{args.steps} timed steps x {args.repeats} runs per checkout, random actions")
        compare(args.against, args.robots, args.steps, args.repeats)
        return
    print(f"{args.steps} timed steps x {args.repeats} repeats, random actions, robot-steps/s")
    print(header("one environment, parallel_env() defaults", cpu=True))
    for robots in args.robots:
        print(row(f"{robots} robots", *bench_single(robots, args.steps, args.repeats)), flush=True)
        if args.no_merge:
            off = bench_single(robots, args.steps, args.repeats, **merging_off())
            print(row(f"{robots} robots, no merging", *off), flush=True)
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
