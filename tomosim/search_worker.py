"""The merge search worker: answers pickled search jobs, one after another.

:mod:`tomosim.team.worker` starts it as ``python -m tomosim.search_worker``
and talks to it over its standard input and output. It imports ``merging``
alone, so that it starts in a fraction of a second, runs one small search to
load the compiled kernels, and says it is ready: until then its caller runs
the searches it needs itself rather than wait for a worker still starting.
"""

from __future__ import annotations

import os
import pickle
import signal
import sys
from typing import IO, Any

import numpy as np

from merging import estimate_transform
from merging.grid import FREE, OCCUPIED, UNKNOWN

READY = "ready"
"""What the worker writes on its output, before any answer, once it is warmed up."""
WARM_UP_SIDE = 48
"""Cells a side of the two small rooms the worker merges once on starting."""


def warm_up() -> None:
    """Merge two small rooms once, so that the search's compiled kernels are loaded (from
    numba's cache, a few tenths of a second) before the first job, not during it."""
    room = np.full((WARM_UP_SIDE, WARM_UP_SIDE), UNKNOWN, dtype=np.int8)
    room[4:-4, 4:-4] = OCCUPIED
    room[6:-6, 6:-6] = FREE
    room[6:20, 24] = OCCUPIED  # a wall into the room, so that it has one placement
    estimate_transform(room, room[:, ::-1].copy())


def serve(jobs: IO[bytes], answers: IO[bytes]) -> None:
    """Answer pickled ``(number, first, second, method, seed, options)`` jobs until ``jobs``
    ends (``options``: the keyword arguments of the method's settings, ``params=``).

    Each answer is ``(number, True, MergeResult)``, or ``(number, False,
    exception)`` when the search raised.
    """
    while True:
        try:
            number, first, second, method, seed, options = pickle.load(jobs)
        except (EOFError, pickle.UnpicklingError):  # the end, or a caller that ended mid-job
            return
        answer: tuple[Any, ...]
        try:
            result = estimate_transform(first, second, method=method, rng=seed, **options)
            answer = (number, True, result)
        except Exception as error:  # handed back to the caller, who raises it
            answer = (number, False, error)
        try:
            pickle.dump(answer, answers, protocol=pickle.HIGHEST_PROTOCOL)
            answers.flush()
        except BrokenPipeError:  # the caller has ended: nobody is waiting for answers
            _silence(answers)
            return


def _silence(answers: IO[bytes]) -> None:
    """Send what is left in ``answers``' buffer nowhere, not to an error at exit."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), answers.fileno())


def main() -> None:
    """Warm up, say so (:data:`READY`), then serve jobs on the standard streams.

    Ctrl-C is ignored: a terminal sends it to the caller too, which stops and
    reports it, and this worker ends when the caller's end of its input closes
    (a traceback of its own would only clutter the caller's one-line message).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    warm_up()
    try:
        pickle.dump(READY, sys.stdout.buffer, protocol=pickle.HIGHEST_PROTOCOL)
        sys.stdout.buffer.flush()
    except BrokenPipeError:  # the caller ended while this worker started
        _silence(sys.stdout.buffer)
        return
    serve(sys.stdin.buffer, sys.stdout.buffer)


if __name__ == "__main__":
    main()
