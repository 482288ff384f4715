"""Running a sweep's episodes on a local process pool or on Ray.

Both executors ship the same pure function, :func:`~tomosim.sweep.rows.run_one`,
so the same plan gives the same rows whichever runs it (all but the timing
columns). Rows are appended in the order episodes finish.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tomosim.sweep.plan import Episode, SweepPlan
from tomosim.sweep.rows import ResultsFile, run_one

EXECUTORS = ("process", "ray")
"""Names accepted by :func:`run_sweep`."""
RAY_INSTALL = 'pip install "tomosim[ray]"'
"""The command that installs the optional Ray executor."""

Progress = Callable[[dict[str, Any]], None]
"""``progress(row)``, called after each finished episode."""
Start = Callable[[int, int], None]
"""``on_start(planned, skipped)``, called once before the first episode runs."""


@dataclass(frozen=True, slots=True)
class SweepOutcome:
    """What :func:`run_sweep` did: episodes in the plan, skipped as done, and run now."""

    planned: int
    skipped: int
    ran: int
    results: Path


def run_sweep(
    plan: SweepPlan,
    out: str | Path,
    *,
    executor: str = "process",
    workers: int | None = None,
    resume: bool = False,
    ray_address: str | None = None,
    progress: Progress | None = None,
    on_start: Start | None = None,
) -> SweepOutcome:
    """Run every episode of ``plan`` not yet in ``out``, appending a row for each.

    Parameters
    ----------
    plan : SweepPlan
        The episodes.
    out : str or Path
        The CSV results file.
    executor : {"process", "ray"}
        A local process pool, or Ray (``ray_address`` names a running cluster;
        None starts a local Ray).
    workers : int, optional
        Processes of the local pool (default: the number of cores).
    resume : bool
        Keep the rows already in ``out`` and run only the missing episodes;
        without it an existing non-empty ``out`` is an error, so that no
        results are overwritten by accident.

    Raises
    ------
    ValueError
        For an unknown executor, an existing results file without ``resume``,
        or a results file written by a sweep with other shared settings.
    ImportError
        For ``executor="ray"`` when Ray is not installed (with the command
        that installs it).
    """
    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {executor!r}")
    results = ResultsFile(out)
    results.path.parent.mkdir(parents=True, exist_ok=True)
    if results.path.is_file() and results.path.stat().st_size > 0 and not resume:
        raise ValueError(f"{results.path} already holds results; pass --resume or choose --out")
    results.repair()
    shared = plan.settings()
    done = _done_keys(results, shared)
    episodes = plan.episodes()
    pending = [e for e in episodes if e.key not in done]
    if plan.record_dir is not None:
        plan.record_dir.mkdir(parents=True, exist_ok=True)
    if on_start is not None:
        on_start(len(episodes), len(episodes) - len(pending))
    run = _run_on_ray if executor == "ray" else _run_in_processes
    ran = 0
    for row in run(pending, shared, workers=workers, ray_address=ray_address):
        results.append(row)
        ran += 1
        if progress is not None:
            progress(row)
    return SweepOutcome(len(episodes), len(episodes) - len(pending), ran, results.path)


def _done_keys(results: ResultsFile, shared: dict[str, Any]) -> set[str]:
    """Keys already in the file, after checking that they come from the same sweep."""
    done: set[str] = set()
    for row in results.rows():
        for name, value in shared.items():
            if row[name] != str(value):
                raise ValueError(
                    f"{results.path} was written by a sweep with {name}={row[name]}, "
                    f"not {value}; choose another --out"
                )
        done.add(row["key"])
    return done


def _run_in_processes(
    episodes: list[Episode], shared: dict[str, Any], *, workers: int | None, ray_address: str | None
) -> Iterator[dict[str, Any]]:
    if not episodes:
        return
    count = max(1, min(workers or os.cpu_count() or 1, len(episodes)))
    # Fresh interpreters: a forked copy of a parent holding a recording or a
    # physics space is not something to rely on.
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=count, mp_context=context) as pool:
        futures: set[Future[dict[str, Any]]] = {
            pool.submit(run_one, e.key, e.config, shared) for e in episodes
        }
        while futures:
            finished, futures = wait(futures, return_when=FIRST_COMPLETED)
            for future in finished:
                yield future.result()


def _run_on_ray(
    episodes: list[Episode], shared: dict[str, Any], *, workers: int | None, ray_address: str | None
) -> Iterator[dict[str, Any]]:
    try:
        import ray
    except ImportError as exc:
        raise ImportError(f"the Ray executor needs Ray: {RAY_INSTALL}") from exc
    if not episodes:
        return
    started = not ray.is_initialized()
    if started:
        options: dict[str, Any] = {"address": ray_address, "log_to_driver": False}
        if ray_address is None:
            options.update(include_dashboard=False, num_cpus=workers)
        ray.init(**options)
    try:
        remote = ray.remote(run_one)
        pending = [remote.remote(e.key, e.config, shared) for e in episodes]
        while pending:
            finished, pending = ray.wait(pending, num_returns=1)
            for ref in finished:
                yield ray.get(ref)
    finally:
        if started:
            ray.shutdown()
