"""Stop signals: raised as :class:`Stopped`, and remembered when their exception is lost."""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import time

import pytest

from tomosim.commands.stopping import (
    Stopped,
    raise_if_stopped,
    stop_behind,
    stop_received,
    stop_signals_handled,
)


def lose_a_signal(signum: int) -> None:
    """Send this process ``signum`` and swallow the exception its handler raises."""
    with contextlib.suppress(Stopped):
        os.kill(os.getpid(), signum)
        for _ in range(1000):  # the handler runs between bytecodes, soon
            time.sleep(0.001)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_lost_signal_is_raised_at_the_next_check(signum: int) -> None:
    with stop_signals_handled():
        raise_if_stopped()  # nothing received yet: no-op
        assert stop_received() is None
        lose_a_signal(signum)
        with pytest.raises(Stopped) as stopped:
            raise_if_stopped()
        assert stopped.value.signum == signum


def test_an_error_after_a_lost_signal_stands_for_the_stop() -> None:
    with stop_signals_handled():
        assert stop_behind(ValueError("unrelated")) is None
        lose_a_signal(signal.SIGTERM)
        interrupt = stop_behind(ValueError("after the signal"))
        assert isinstance(interrupt, Stopped) and interrupt.signum == signal.SIGTERM
        plain = KeyboardInterrupt()
        assert stop_behind(plain) is plain


def test_handlers_and_memory_end_with_the_context() -> None:
    before = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    with stop_signals_handled():
        lose_a_signal(signal.SIGTERM)
    assert stop_received() is None
    raise_if_stopped()
    assert {signum: signal.getsignal(signum) for signum in before} == before


def test_a_stop_lost_in_a_ctypes_callback_is_not_reported_and_is_raised_later(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # What numba's compiler does on a first run: C calls back into Python, and an
    # exception raised there goes to sys.unraisablehook ("Exception ignored") and is dropped.
    def signalled() -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            time.sleep(0.001)

    def failing() -> None:
        raise RuntimeError("not a stop")

    reported: list[BaseException] = []
    monkeypatch.setattr(
        sys, "unraisablehook", lambda unraisable: reported.append(unraisable.exc_value)
    )
    callback_type = ctypes.CFUNCTYPE(None)
    with stop_signals_handled():
        callback_type(signalled)()  # the Stopped raised inside is lost...
        assert reported == []  # ...without a traceback
        with pytest.raises(Stopped):
            raise_if_stopped()
        callback_type(failing)()
    assert [type(error) for error in reported] == [RuntimeError]  # other errors still reported
