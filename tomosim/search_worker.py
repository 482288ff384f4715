"""The merge search worker: answers pickled search jobs, one after another.

:mod:`tomosim.team.worker` starts it as ``python -m tomosim.search_worker``
and talks to it over its standard input and output. It imports ``merging``
alone, so that it starts in a fraction of a second.
"""

from __future__ import annotations

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
        except EOFError:
            return
        answer: tuple[Any, ...]
        try:
            answer = (number, True, estimate_transform(first, second, method=method, rng=seed))
        except Exception as error:  # handed back to the caller, who raises it
            answer = (number, False, error)
        pickle.dump(answer, answers, protocol=pickle.HIGHEST_PROTOCOL)
        answers.flush()


if __name__ == "__main__":
    serve(sys.stdin.buffer, sys.stdout.buffer)
