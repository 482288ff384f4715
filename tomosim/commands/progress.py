"""Progress of long commands on standard error: a bar on a terminal, lines elsewhere.

On a terminal, a tqdm bar redrawn in place. Elsewhere (a log file, a batch
job, a pipe), where a bar would be garbage or nothing, one plain line every
:data:`LINE_INTERVAL_S` seconds, and one at the end, so that a job's log shows
that it is alive and how far it got.
"""

from __future__ import annotations

import sys
import time
from typing import IO

from tqdm import tqdm

LINE_INTERVAL_S = 5.0
"""Seconds between two progress lines when standard error is not a terminal."""


def is_terminal(stream: IO[str]) -> bool:
    """Whether ``stream`` is an interactive terminal."""
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


class Progress:
    """Counts ``done`` of ``total`` ``unit`` with a line of detail.

    Parameters
    ----------
    total : int
        The count at which the job is done (an upper bound is fine).
    unit : str
        What is counted (``"step"``, ``"episode"``).
    label : str
        The name lines start with (``"explore"``).
    stream : text stream, optional
        Where to write (standard error by default).
    interval : float, optional
        Seconds between lines off a terminal (default :data:`LINE_INTERVAL_S`).
    """

    __slots__ = ("_bar", "_last_line", "done", "interval", "label", "stream", "total", "unit")

    def __init__(
        self,
        total: int,
        unit: str,
        *,
        label: str,
        stream: IO[str] | None = None,
        interval: float | None = None,
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.total = int(total)
        self.unit = unit
        self.label = label
        self.interval = LINE_INTERVAL_S if interval is None else float(interval)
        self.done = 0
        self._last_line = time.monotonic()
        self._bar: tqdm[object] | None = None
        if is_terminal(self.stream):
            self._bar = tqdm(total=self.total, unit=unit, file=self.stream, leave=False)

    def update(self, done: int, detail: str = "") -> None:
        """Set the count to ``done``; ``detail`` is shown beside it."""
        self.done = int(done)
        if self._bar is not None:
            self._bar.update(self.done - self._bar.n)
            self._bar.set_postfix_str(detail, refresh=False)
            return
        now = time.monotonic()
        if now - self._last_line >= self.interval:
            self._last_line = now
            self._line(detail)

    def _line(self, detail: str) -> None:
        text = f"{self.label}: {self.done}/{self.total} {self.unit}s"
        print(f"{text}, {detail}" if detail else text, file=self.stream, flush=True)

    def close(self, detail: str = "") -> None:
        """Remove the bar, or write the last line."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif detail:
            self._line(detail)
