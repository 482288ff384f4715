"""Where global merge searches run: a worker process, or inline with the same results.

A global search (:func:`merging.estimate_transform`) costs tens to hundreds
of milliseconds, as long as dozens of simulation steps. The transform
tracker (:mod:`tomosim.team.link_tracking`) submits each search when a round
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

A search the worker has not started when its result is wanted is run by the
caller itself (:meth:`WorkerSearches.wait`), as are the other searches the
caller needs at the same round, while the worker finishes the one it has:
the caller would otherwise wait idle, and the results are the same wherever
a search runs.
"""

from __future__ import annotations

import logging
import os
import pickle
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Mapping, Sequence
from concurrent import futures
from concurrent.futures import Future
from typing import Any, Protocol

from merging import estimate_transform
from merging.grid import OccupancyGrid
from merging.result import MergeResult
from tomosim.search_worker import READY

LOG = logging.getLogger(__name__)
"""Says when the worker has ended (Python prints warnings to stderr unless told otherwise)."""
TAKE_BACK_POLL_S = 0.05
"""Seconds between looks, while the worker runs a search the caller waits for, at whether
the worker has ended and handed it back."""


class Searches(Protocol):
    """Something that runs global searches and hands back their results later."""

    def submit(
        self,
        first: OccupancyGrid,
        second: OccupancyGrid,
        *,
        method: str,
        seed: int,
        options: Mapping[str, Any] | None = None,
    ) -> Future[MergeResult]:
        """Start ``estimate_transform(first, second, method=method, rng=seed, **options)``
        (``options``: the method's settings, ``params=``)."""
        ...

    def wait(
        self, search: Future[MergeResult], others: Sequence[Future[MergeResult]]
    ) -> MergeResult:
        """The result of ``search``; ``others`` are searches the caller needs next, which
        it may run meanwhile rather than sit idle."""
        ...


def _search(
    job: tuple[OccupancyGrid, OccupancyGrid, str, int, Mapping[str, Any]],
    future: Future[MergeResult],
    *,
    as_worker: bool = False,
) -> None:
    """Run a search job ``(first, second, method, seed, options)`` here, into ``future``.

    ``as_worker``: under the worker's warning filters, Python's defaults (a warning
    is shown, never raised), whatever this process's are, so that a search taken
    back from the worker ends as it would have there.
    """
    first, second, method, seed, options = job
    with warnings.catch_warnings():
        if as_worker:
            warnings.resetwarnings()
        try:
            future.set_result(estimate_transform(first, second, method=method, rng=seed, **options))
        except Exception as error:  # handed to the caller, as the worker does
            future.set_exception(error)


class InlineSearches:
    """Runs each search at once, in this process; the result waits in a done future."""

    def submit(
        self,
        first: OccupancyGrid,
        second: OccupancyGrid,
        *,
        method: str,
        seed: int,
        options: Mapping[str, Any] | None = None,
    ) -> Future[MergeResult]:
        """Run the search now (see :class:`Searches`)."""
        future: Future[MergeResult] = Future()
        _search((first, second, method, seed, dict(options or {})), future)
        return future

    def wait(
        self, search: Future[MergeResult], others: Sequence[Future[MergeResult]]
    ) -> MergeResult:
        """The result (done already; see :class:`Searches`)."""
        return search.result()


class _Job(Future[MergeResult]):
    """A search handed to the worker, known by its number."""

    def __init__(self, number: int) -> None:
        super().__init__()
        self.number = number


class _Worker:
    """The worker process of this process, a thread that writes it the jobs and one that
    reads its answers.

    Jobs wait in a queue until the worker has said it is ready (warmed up) and
    is idle, and only then does the writing thread send it the next (a job, two
    grids, is larger than a pipe holds, so writing it would block until the
    worker read it): the caller, stepping a simulation meanwhile, never waits
    for the pipe, and a job the worker has not started can still be taken back
    (:meth:`take`) and run by a caller that would
    otherwise wait idle for it.
    """

    def __init__(self) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tomosim.search_worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        self.pid = os.getpid()
        self.lock = threading.Condition()
        self.futures: dict[int, tuple[_Job, tuple[Any, ...]]] = {}  # sent, not answered yet
        self.queued: dict[int, tuple[_Job, tuple[Any, ...]]] = {}  # not sent yet, in order
        self.next_job = 0
        self.ended: RuntimeError | None = None  # set once the worker is known to have ended
        self.ready = False  # set once the worker has said it is warmed up
        writer = threading.Thread(target=self._write, name="merge-search-jobs", daemon=True)
        writer.start()
        reader = threading.Thread(target=self._read, name="merge-search-results", daemon=True)
        reader.start()

    def submit(self, job: tuple[Any, ...]) -> _Job:
        with self.lock:
            future = _Job(self.next_job)
            self.next_job += 1
            # Once the worker has ended, jobs wait here for the caller to take them.
            self.queued[future.number] = (future, job)
            self.lock.notify_all()
            return future

    def _end(self) -> None:
        """The worker has ended (killed, say): its jobs, sent or waiting, and every later
        one wait for the caller to run them itself (:meth:`WorkerSearches.wait`), with
        the same results."""
        with self.lock:
            if self.ended is not None:
                return
            self.ended = RuntimeError(
                f"the merge search worker ended (exit status {self.process.poll()})"
            )
            self.queued = {**self.futures, **self.queued}
            self.futures.clear()
            self.lock.notify_all()
        LOG.warning(
            "%s; merge searches run in this process from now on, with the same results",
            self.ended,
        )

    def wait_ready(self, timeout: float) -> bool:
        """Wait up to ``timeout`` seconds for the worker to be warmed up; whether it is."""
        with self.lock:
            self.lock.wait_for(lambda: self.ready or self.ended is not None, timeout)
            return self.ready and self.ended is None

    def take(self, future: Future[MergeResult]) -> tuple[Any, ...] | None:
        """Take back a job the worker has not been sent; None if it has (or was taken)."""
        if not isinstance(future, _Job):
            return None
        with self.lock:
            entry = self.queued.pop(future.number, None)
        return None if entry is None else entry[1]

    def _write(self) -> None:
        stdin = self.process.stdin
        assert stdin is not None  # opened as a pipe
        while True:
            with self.lock:
                # Wait while the worker starts, is busy, or is idle for lack of jobs.
                while self.ended is None and (not self.ready or self.futures or not self.queued):
                    self.lock.wait()
                if self.ended is not None:
                    return
                number = next(iter(self.queued))
                future, job = self.queued.pop(number)
                self.futures[number] = (future, job)
            try:
                stdin.write(pickle.dumps((number, *job), protocol=pickle.HIGHEST_PROTOCOL))
                stdin.flush()
            except OSError:  # the worker ended
                self._end()
                return

    def _read(self) -> None:
        stdout = self.process.stdout
        assert stdout is not None  # opened as a pipe
        try:
            said = pickle.load(stdout)
        except (EOFError, OSError, pickle.UnpicklingError):
            said = None
        if said != READY:
            self._end()
            return
        with self.lock:
            self.ready = True
            self.lock.notify_all()
        while True:
            try:
                number, ok, value = pickle.load(stdout)
            except (EOFError, OSError, pickle.UnpicklingError):
                self._end()
                return
            with self.lock:
                future, _ = self.futures.pop(number)
                self.lock.notify_all()
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)


class WorkerSearches:
    """Runs searches in this process's worker process (module docstring).

    Attributes
    ----------
    cpu_seconds_here : float
        Class attribute: CPU seconds this process has spent on searches it took
        back from the worker (:meth:`wait`); benchmarks subtract them to time the
        simulation alone.
    """

    _worker: _Worker | None = None
    cpu_seconds_here: float = 0.0

    @classmethod
    def worker(cls) -> _Worker:
        """The worker, started on first use in this process (a forked child starts its own)."""
        if cls._worker is None or cls._worker.pid != os.getpid():
            cls._worker = _Worker()
        return cls._worker

    @classmethod
    def wait_ready(cls, timeout: float = 30.0) -> bool:
        """Wait up to ``timeout`` seconds for the worker to be warmed up; whether it is.

        Sessions never need to: until it is ready they run their searches
        themselves. A benchmark of the steady state waits, as it waits for
        compiled kernels to load, so that the worker's start (about a second)
        is not timed as simulation.
        """
        if timeout < 0:
            raise ValueError(f"timeout must be at least 0 seconds, got {timeout}")
        return cls.worker().wait_ready(timeout)

    def submit(
        self,
        first: OccupancyGrid,
        second: OccupancyGrid,
        *,
        method: str,
        seed: int,
        options: Mapping[str, Any] | None = None,
    ) -> Future[MergeResult]:
        """Queue the search for the worker (see :class:`Searches`)."""
        return self.worker().submit((first, second, method, seed, dict(options or {})))

    def wait(
        self, search: Future[MergeResult], others: Sequence[Future[MergeResult]]
    ) -> MergeResult:
        """The result of ``search`` (see :class:`Searches`).

        Rather than wait idle, this process runs ``search`` itself if the worker
        has not started it, and then each of ``others`` the worker has not
        started, until ``search`` is done: the worker and this process then
        share the searches the caller needs now. Should the worker end (be
        killed), its searches come back and are run here, with the same
        results.
        """
        worker = self.worker()
        while not search.done():
            for candidate in (search, *others):
                if search.done():
                    break
                job = worker.take(candidate)
                if job is not None:
                    clock = time.process_time()
                    _search(job, candidate, as_worker=True)
                    WorkerSearches.cpu_seconds_here += time.process_time() - clock
            # The worker has it; should the worker end meanwhile, it comes back to take.
            futures.wait([search], timeout=TAKE_BACK_POLL_S)
        return search.result()


def searches(*, worker: bool) -> Searches:
    """Worker searches when asked for, else inline ones (the same results either way).

    The worker is started here if it is not running yet, so that its start (a
    second or so) falls on the session's construction, not on a step.
    """
    if not worker:
        return InlineSearches()
    WorkerSearches.worker()
    return WorkerSearches()
