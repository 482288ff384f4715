"""Running a sweep's episodes on a local process pool or on Ray.

Both executors ship the same pure function, :func:`~tomosim.sweep.rows.run_one`,
so the same plan gives the same rows whichever runs it (all but the timing
columns). Rows are appended in the order episodes finish.

While episodes run, their workers report each episode's step and coverage
every :data:`REPORT_INTERVAL_S` seconds (through a queue), so a long episode
shows progress before it ends.

A sweep holds its results file's lock from start to end
(:meth:`~tomosim.sweep.rows.ResultsFile.locked`): a second sweep on the same
file refuses. Local workers end with their parent, however it ends: they
ignore Ctrl-C (the parent stops them), are terminated when the parent stops,
and end by themselves within :data:`ORPHAN_CHECK_S` seconds of the parent's
death (SIGKILL included).
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import queue
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tomosim.episode import EpisodeConfig
from tomosim.episode.config import other_team_settings
from tomosim.sweep.plan import NO_MERGE, Episode, SweepPlan, world_name
from tomosim.sweep.rows import ResultsFile, run_one, team_text
from tomosim.team import team_methods

EXECUTORS = ("process", "ray")
"""Names accepted by :func:`run_sweep`."""
RAY_INSTALL = 'pip install "tomosim[ray]"'
"""The command that installs the optional Ray executor."""
REPORT_INTERVAL_S = 1.0
"""Seconds between two progress reports of one running episode."""
POLL_S = 0.25
"""Seconds the parent waits for a finished episode before passing on progress reports."""
ORPHAN_CHECK_S = 1.0
"""Seconds between a worker's checks that its parent is alive."""
STARTED = -1
"""The step of a worker's first report of an episode, whose value is the worker's pid."""
PR_SET_PDEATHSIG = 1
"""Linux ``prctl`` option: the signal a process gets when its parent dies."""

Progress = Callable[[dict[str, Any]], None]
"""``progress(row)``, called after each finished episode."""
Start = Callable[[int, int], None]
"""``on_start(planned, skipped)``, called once before the first episode runs."""
Step = Callable[[str, int, float], None]
"""``on_step(key, step, team_coverage)``, called as running episodes report."""


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
    on_step: Step | None = None,
) -> SweepOutcome:
    """Run every episode of ``plan`` not yet in ``out``, appending a row for each.

    Parameters
    ----------
    plan : SweepPlan
        The episodes.
    out : str or Path
        The CSV results file; its folder must exist.
    executor : {"process", "ray"}
        A local process pool, or Ray (``ray_address`` names a running cluster;
        None starts a local Ray).
    workers : int, optional
        Processes of the local pool (default: the number of cores).
    resume : bool
        Keep the rows already in ``out`` and run only the missing episodes;
        without it an existing non-empty ``out`` is an error, so that no
        results are overwritten by accident.
    progress, on_start, on_step : callable, optional
        Told of each finished episode's row, of the episodes planned and
        skipped, and of running episodes' steps.

    Raises
    ------
    ValueError
        For an unknown executor, an existing results file without ``resume``,
        a results file written by a sweep with other shared settings, or one
        another sweep is writing (:class:`~tomosim.sweep.rows.SweepLockedError`).
    FileNotFoundError
        If the folder of ``out`` does not exist.
    ImportError
        For ``executor="ray"`` when Ray is not installed (with the command
        that installs it).
    """
    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {executor!r}")
    results = ResultsFile(out)
    if not results.path.absolute().parent.is_dir():
        raise FileNotFoundError(
            f"cannot write {results.path}: folder {results.path.absolute().parent} does not exist"
        )
    existed = results.path.exists()
    had_rows = results.path.is_file() and results.path.stat().st_size > 0
    try:
        with results.locked():
            if had_rows and not resume:
                # Another kind of file, or another sweep's: --resume would not help.
                results.check_columns()
                _done_keys(results, plan)
                raise ValueError(
                    f"{results.path} already holds results; pass --resume or choose --out"
                )
            results.repair()
            return _sweep(
                plan, results, executor, workers, ray_address, progress, on_start, on_step
            )
    finally:
        # A sweep that failed before its first row leaves no empty file of its own behind.
        if not existed and results.path.is_file() and results.path.stat().st_size == 0:
            results.path.unlink()


def _sweep(
    plan: SweepPlan,
    results: ResultsFile,
    executor: str,
    workers: int | None,
    ray_address: str | None,
    progress: Progress | None,
    on_start: Start | None,
    on_step: Step | None,
) -> SweepOutcome:
    """The body of :func:`run_sweep`, with the results file locked and checked."""
    shared = plan.settings()
    done = _done_keys(results, plan)
    episodes = plan.episodes()
    pending = [e for e in episodes if e.key not in done]
    if plan.record_dir is not None:
        plan.record_dir.mkdir(exist_ok=True)
    if on_start is not None:
        on_start(len(episodes), len(episodes) - len(pending))
    run = _run_on_ray if executor == "ray" else _run_in_processes
    ran = 0
    for row in run(pending, shared, workers=workers, ray_address=ray_address, on_step=on_step):
        results.append(row)
        ran += 1
        if progress is not None:
            progress(row)
    return SweepOutcome(len(episodes), len(episodes) - len(pending), ran, results.path)


def _done_keys(results: ResultsFile, plan: SweepPlan) -> set[str]:
    """Keys already in the file, after checking that they come from the same sweep: the
    settings every episode shares, and the team settings of each row's method (in files
    that record them; a file of an earlier version that does not is resumed with a
    warning that they cannot be checked)."""
    shared = plan.settings()
    teams: dict[str, str] = {}
    done: set[str] = set()
    rows = results.rows()
    if rows and "team_settings" not in results.columns():
        warnings.warn(
            f"{results.path} was written by an earlier version that did not record the team "
            "settings its rows ran with; they cannot be checked against this sweep's "
            "(resume it only with the --team settings it was started with)",
            UserWarning,
            stacklevel=4,
        )
    for row in rows:
        for name, value in shared.items():
            if row[name] != str(value):
                raise ValueError(
                    f"{results.path} was written by a sweep with {name}={row[name]}, "
                    f"not {value}; choose another --out"
                )
        # A row of a method no team runs (a file that is not a sweep's) is not judged here.
        method = row.get("method", "")
        if "team_settings" in row and (method in team_methods() or method == NO_MERGE):
            if method not in teams:
                teams[method] = team_text(other_team_settings(plan.team_of(method)))
            if row["team_settings"] != teams[method]:
                raise ValueError(
                    f"{results.path} holds {method} episodes run with team settings "
                    f"{row['team_settings'] or 'the defaults'}, not "
                    f"{teams[method] or 'the defaults'}; choose another --out"
                )
        done.add(_named_as_now(row["key"]))
    return done


def _named_as_now(key: str) -> str:
    """``key`` with its world named as :func:`~tomosim.sweep.plan.world_name` names it.

    Files written before worlds were named by absolute path hold the path as it
    was typed; read from the folder the sweep runs in, as a resume then did.
    """
    world, sep, rest = key.partition("|")
    return world_name(world) + sep + rest


class _Reporter:
    """A running episode's ``progress`` callback: at most one report a second, to a queue."""

    __slots__ = ("key", "last", "sink")

    def __init__(self, key: str, sink: Any) -> None:
        self.key = key
        self.sink = sink
        self.last = -math.inf  # the first report goes at once

    def __call__(self, step: int, coverage: float) -> None:
        now = time.monotonic()
        if now - self.last < REPORT_INTERVAL_S:
            return
        self.last = now
        # A full or closed queue costs a report, never the episode.
        with contextlib.suppress(Exception):
            self.sink.put_nowait((self.key, int(step), float(coverage)))


_REPORTS: Any = None
"""The worker process's report queue, set by :func:`_start_worker`."""


def _die_with_parent(parent: int) -> None:
    """End this process when ``parent`` dies: at once on Linux, else within a second."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):  # no prctl: the watchdog below does the job
            pass

    def watch() -> None:
        while True:
            if os.getppid() != parent:
                os._exit(1)
            time.sleep(ORPHAN_CHECK_S)

    if os.getppid() != parent:  # the parent died before the watch began
        os._exit(1)
    threading.Thread(target=watch, name="orphan-watch", daemon=True).start()


def _start_worker(reports: Any, parent: int) -> None:
    """Set up a pool worker: reports queue, Ctrl-C left to the parent, death with the parent."""
    global _REPORTS
    _REPORTS = reports
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent)


def _pool_task(task: tuple[str, EpisodeConfig, dict[str, Any]]) -> dict[str, Any]:
    key, config, shared = task
    _REPORTS.put((key, STARTED, os.getpid()))  # which process runs it, should it die
    return run_one(key, config, shared, _Reporter(key, _REPORTS))


class WorkerDied(RuntimeError):
    """A pool process died while running an episode (killed, out of memory, ...)."""


def _drain(reports: Any, on_step: Step | None, running: dict[str, int]) -> None:
    """Pass every queued progress report to ``on_step``; note in ``running`` which
    process started which episode."""
    while True:
        try:
            key, step, value = reports.get_nowait()
        except queue.Empty:
            return
        if step == STARTED:
            running[key] = int(value)
        elif on_step is not None:
            on_step(key, step, value)


def _check_alive(running: dict[str, int]) -> None:
    """Raise :class:`WorkerDied` if the process of a running episode is gone.

    A pool replaces a dead process but never hands back its task, so without
    this the sweep would wait for that episode for ever.
    """
    for key, pid in running.items():
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            raise WorkerDied(
                f"the process running episode {key} (pid {pid}) died, killed or out of "
                "memory; the rows written so far are kept: run the sweep again with "
                "--resume to go on"
            ) from None
        except PermissionError:  # alive, under another user: not ours to judge
            pass


def _run_in_processes(
    episodes: list[Episode],
    shared: dict[str, Any],
    *,
    workers: int | None,
    ray_address: str | None,
    on_step: Step | None,
) -> Iterator[dict[str, Any]]:
    if not episodes:
        return
    count = max(1, min(workers or os.cpu_count() or 1, len(episodes)))
    # Fresh interpreters: a forked copy of a parent holding a recording or a
    # physics space is not something to rely on.
    context = multiprocessing.get_context("spawn")
    reports = context.Queue()
    pool = context.Pool(count, initializer=_start_worker, initargs=(reports, os.getpid()))
    try:
        finished = pool.imap_unordered(_pool_task, [(e.key, e.config, shared) for e in episodes])
        running: dict[str, int] = {}  # episode -> the process that started it
        done: set[str] = set()
        while True:
            try:
                row = finished.next(timeout=POLL_S)
            except multiprocessing.TimeoutError:
                _drain(reports, on_step, running)
                for key in done & running.keys():
                    del running[key]
                _check_alive(running)
                continue
            except StopIteration:
                break
            _drain(reports, on_step, running)
            done.add(row["key"])
            running.pop(row["key"], None)
            yield row
    finally:
        # Also on Ctrl-C, SIGTERM or an error: running episodes are stopped, not awaited.
        pool.terminate()
        pool.join()
        reports.close()


def _run_on_ray(
    episodes: list[Episode],
    shared: dict[str, Any],
    *,
    workers: int | None,
    ray_address: str | None,
    on_step: Step | None,
) -> Iterator[dict[str, Any]]:
    try:
        import ray
        from ray.util.queue import Queue as RayQueue
    except ImportError as exc:
        raise ImportError(f"the Ray executor needs Ray: {RAY_INSTALL}") from exc
    if not episodes:
        return
    started = not ray.is_initialized()
    if started:
        # None: a Ray of this process's own, even when a cluster started with `ray start`
        # (or one that has since died) is recorded on this machine.
        options: dict[str, Any] = {"address": ray_address or "local", "log_to_driver": False}
        if ray_address is None:
            options.update(include_dashboard=False, num_cpus=workers)
        ray.init(**options)
    try:
        reports = RayQueue()
        remote = ray.remote(_ray_task)
        pending = [remote.remote(e.key, e.config, shared, reports) for e in episodes]
        while pending:
            finished, pending = ray.wait(pending, num_returns=1, timeout=POLL_S)
            _drain_ray(reports, on_step)
            for ref in finished:
                yield ray.get(ref)
    finally:
        if started:
            ray.shutdown()


def _ray_task(
    key: str, config: EpisodeConfig, shared: dict[str, Any], reports: Any
) -> dict[str, Any]:
    return run_one(key, config, shared, _Reporter(key, reports))


def _drain_ray(reports: Any, on_step: Step | None) -> None:
    """Pass every queued report of a Ray queue to ``on_step``."""
    size = reports.qsize()
    if size and on_step is not None:
        for key, step, coverage in reports.get_nowait_batch(size):
            on_step(key, step, coverage)
