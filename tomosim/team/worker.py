"""Where global merge searches run: a worker process, or inline with the same results.

A global search (:func:`merging.estimate_transform`) costs tens to hundreds
of milliseconds, as long as dozens of simulation steps. The transform
tracker (:mod:`tomosim.team.tracking`) submits each search when a round
needs it and collects the result at the pair's *next* round, a fixed later
step; in between, the search runs in a worker process on another core.
Because the result is collected at a fixed step, whether it ran in the
worker or inline (:class:`InlineSearches`, computed at once and held back
until then) does not change the run.

The worker is a fresh interpreter running :mod:`tomosim.search_worker`
(which imports ``merging`` alone), fed pickled jobs on its standard input and
answering on its standard output. It is not a ``multiprocessing`` child on purpose:
those re-import the user's main script (``spawn``, ``forkserver``), or copy
a process that may be a pool's worker itself, with its queues and threads
(``fork``), and a pool's worker waits at exit for children it did not
start. One worker serves every session of a process; it is started on first
use and ends when its input closes (when this process exits).
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import threading
from concurrent.futures import Future
from typing import Any, Protocol

from merging import estimate_transform
from merging.grid import OccupancyGrid
from merging.result import MergeResult


class Searches(Protocol):
    """Something that runs global searches and hands back their results later."""

    def submit(
        self, first: OccupancyGrid, second: OccupancyGrid, *, method: str, seed: int
    ) -> Future[MergeResult]:
        """Start ``estimate_transform(first, second, method=method, rng=seed)``."""
        ...


class InlineSearches:
    """Runs each search at once, in this process; the result waits in a done future."""

    def submit(
        self, first: OccupancyGrid, second: OccupancyGrid, *, method: str, seed: int
    ) -> Future[MergeResult]:
        """Run the search now (see :class:`Searches`)."""
        future: Future[MergeResult] = Future()
        future.set_result(estimate_transform(first, second, method=method, rng=seed))
        return future


class _Worker:
    """The worker process of this process, and a thread that reads its answers."""

    def __init__(self) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tomosim.search_worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        self.pid = os.getpid()
        self.lock = threading.Lock()
        self.futures: dict[int, Future[MergeResult]] = {}
        self.next_job = 0
        reader = threading.Thread(target=self._read, name="merge-search-results", daemon=True)
        reader.start()

    def submit(self, job: tuple[Any, ...]) -> Future[MergeResult]:
        future: Future[MergeResult] = Future()
        stdin = self.process.stdin
        assert stdin is not None  # opened as a pipe
        with self.lock:
            number = self.next_job
            self.next_job += 1
            self.futures[number] = future
            pickle.dump((number, *job), stdin, protocol=pickle.HIGHEST_PROTOCOL)
            stdin.flush()
        return future

    def _read(self) -> None:
        stdout = self.process.stdout
        assert stdout is not None  # opened as a pipe
        while True:
            try:
                number, ok, value = pickle.load(stdout)
            except (EOFError, OSError, pickle.UnpicklingError):
                error = RuntimeError(
                    f"the merge search worker ended (exit status {self.process.poll()})"
                )
                with self.lock:
                    for future in self.futures.values():
                        future.set_exception(error)
                    self.futures.clear()
                return
            with self.lock:
                future = self.futures.pop(number)
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)


class WorkerSearches:
    """Runs searches in this process's worker process (module docstring)."""

    _worker: _Worker | None = None

    @classmethod
    def worker(cls) -> _Worker:
        """The worker, started on first use in this process (a forked child starts its own)."""
        if cls._worker is None or cls._worker.pid != os.getpid():
            cls._worker = _Worker()
        return cls._worker

    def submit(
        self, first: OccupancyGrid, second: OccupancyGrid, *, method: str, seed: int
    ) -> Future[MergeResult]:
        """Queue the search in the worker (see :class:`Searches`)."""
        return self.worker().submit((first, second, method, seed))


def searches(*, worker: bool) -> Searches:
    """Worker searches when asked for, else inline ones (the same results either way).

    The worker is started here if it is not running yet, so that its start (a
    second or so) falls on the session's construction, not on a step.
    """
    if not worker:
        return InlineSearches()
    WorkerSearches.worker()
    return WorkerSearches()
