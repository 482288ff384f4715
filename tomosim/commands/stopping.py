"""Runs stopped from outside: Ctrl-C (SIGINT) and SIGTERM, told apart and explained.

:class:`Stopped` is a ``KeyboardInterrupt``, so code that already cleans up on
Ctrl-C (closing a recording, ending a process pool) does so on SIGTERM too.
A command that catches it adds what the user should know (what was kept, how
to go on) and raises it again; :func:`tomosim.cli.main` prints it in one line.

A signal handler's exception can be lost: raised while Python runs a callback
from C (numba compiling a kernel on a first run calls back into Python through
ctypes), it is printed as "Exception ignored" and the run goes on. So
:func:`stop_signals_handled` also remembers each signal (and keeps such a
lost stop from printing a traceback), and commands call
:func:`raise_if_stopped` at every step and consult :func:`stop_behind` when
they fail: a stop asked for is a stop, wherever its exception went.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

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


STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)
"""The signals a command stops on."""
_received: list[int] = []
"""Stop signals received since :func:`stop_signals_handled` was entered, oldest first."""


def _stop(signum: int, frame: FrameType | None) -> None:
    _received.append(signum)
    raise Stopped(signum)


@contextmanager
def stop_signals_handled() -> Iterator[None]:
    """Within this context Ctrl-C and SIGTERM raise :class:`Stopped` and are remembered.

    Handlers can only be set from the main thread; elsewhere (a command run in
    a worker thread) the signals keep their handlers and nothing is remembered.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, _stop) for signum in STOP_SIGNALS}
    previous_hook = sys.unraisablehook

    def quiet_about_stops(unraisable: Any) -> None:
        # A stop lost in a callback is remembered and raised at the next check: no traceback.
        if not isinstance(unraisable.exc_value, Stopped):
            previous_hook(unraisable)

    _received.clear()
    sys.unraisablehook = quiet_about_stops
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        _received.clear()


def stop_received() -> Stopped | None:
    """A :class:`Stopped` for the first stop signal received in the context, if any."""
    return Stopped(_received[0]) if _received else None


def stop_behind(error: BaseException) -> KeyboardInterrupt | None:
    """The interrupt a failure with ``error`` stands for: itself, a stop received, or None.

    An error that follows a stop signal whose exception was lost (say, a
    compilation left unfinished) is reported as the stop the user asked for.
    """
    return error if isinstance(error, KeyboardInterrupt) else stop_received()


def raise_if_stopped() -> None:
    """Raise the stop a signal asked for, if its own exception was lost on the way."""
    stopped = stop_received()
    if stopped is not None:
        raise stopped
