"""The merge search worker: answers pickled search jobs, one after another.

:mod:`tomosim.team.worker` starts it as ``python -m tomosim.search_worker``
and talks to it over its standard input and output. It imports ``merging``
alone, so that it starts in a fraction of a second.
"""

from __future__ import annotations

import os
import pickle
import sys
from typing import IO, Any

from merging import estimate_transform


def serve(jobs: IO[bytes], answers: IO[bytes]) -> None:
    """Answer pickled ``(number, first, second, method, seed)`` jobs until ``jobs`` ends.

    Each answer is ``(number, True, MergeResult)``, or ``(number, False,
    exception)`` when the search raised.
    """
    while True:
        try:
            number, first, second, method, seed = pickle.load(jobs)
        except (EOFError, pickle.UnpicklingError):  # the end, or a caller that ended mid-job
            return
        answer: tuple[Any, ...]
        try:
            answer = (number, True, estimate_transform(first, second, method=method, rng=seed))
        except Exception as error:  # handed back to the caller, who raises it
            answer = (number, False, error)
        try:
            pickle.dump(answer, answers, protocol=pickle.HIGHEST_PROTOCOL)
            answers.flush()
        except BrokenPipeError:  # the caller has ended: nobody is waiting for answers
            # What is left in the buffer goes nowhere, not to an error at exit.
            os.dup2(os.open(os.devnull, os.O_WRONLY), answers.fileno())
            return


if __name__ == "__main__":
    serve(sys.stdin.buffer, sys.stdout.buffer)
