"""Runs stopped from outside: Ctrl-C (SIGINT) and SIGTERM, told apart and explained.

:class:`Stopped` is a ``KeyboardInterrupt``, so code that already cleans up on
Ctrl-C (closing a recording, ending a process pool) does so on SIGTERM too.
A command that catches it adds what the user should know (what was kept, how
to go on) and raises it again; :func:`tomosim.cli.main` prints it in one line.
"""

from __future__ import annotations

import signal

SIGNAL_NAMES: dict[int, str] = {
    signal.SIGINT: "interrupted (Ctrl-C)",
    signal.SIGTERM: "terminated (SIGTERM)",
}
"""How each signal is told in messages."""


class Stopped(KeyboardInterrupt):
    """The run was stopped by signal ``signum``; ``detail`` says what remains and what to do."""

    def __init__(self, signum: int, detail: str = "") -> None:
        super().__init__(signum, detail)
        self.signum = int(signum)
        self.detail = detail

    @classmethod
    def of(cls, interrupt: KeyboardInterrupt, detail: str) -> Stopped:
        """``interrupt`` (a plain Ctrl-C or a :class:`Stopped`) with ``detail`` added."""
        signum = interrupt.signum if isinstance(interrupt, Stopped) else signal.SIGINT
        return cls(signum, detail)

    @property
    def why(self) -> str:
        """``SIGINT`` or ``SIGTERM``: the signal, for records."""
        return signal.Signals(self.signum).name

    def describe(self) -> str:
        """One line: what stopped the run, then the detail."""
        told = SIGNAL_NAMES.get(self.signum, f"stopped by {self.why}")
        return f"{told}; {self.detail}" if self.detail else told
