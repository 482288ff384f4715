"""The one decorator every compiled kernel uses, and a Ctrl-C caught inside one.

``cache=True`` keeps the machine code beside the module (``__pycache__``), so
only the first process after an install pays the compilation (a few seconds
for all kernels). ``error_model="numpy"`` makes a division by zero give
``inf``/``nan`` as numpy does instead of raising, which the ray caster relies
on for beams parallel to a wall. No ``fastmath``: the kernels must give the
same numbers as their numpy oracles, run after run.

A signal's ``KeyboardInterrupt`` that lands while a kernel hands back its result
comes out of numba's dispatcher as a ``SystemError``; :func:`interrupt_behind`
and :func:`interrupts_unwrapped` turn it back into the interrupt.
"""

from __future__ import annotations

from collections.abc import Callable
from types import TracebackType
from typing import Any, TypeVar, cast

import numba

F = TypeVar("F", bound=Callable[..., Any])


def kernel(function: F) -> F:
    """Compile ``function`` with the project's numba options (module docstring)."""
    compiled = numba.njit(cache=True, error_model="numpy", nogil=True)(function)
    return cast(F, compiled)  # a Dispatcher is called like the function it compiles


def interrupt_behind(error: SystemError) -> KeyboardInterrupt | None:
    """The Ctrl-C or SIGTERM that ``error`` stands for, if it stands for one.

    A signal's ``KeyboardInterrupt`` is raised by its Python handler, which may
    run while a kernel hands back its result; numba's dispatcher then reports a
    ``SystemError`` ("returned a result with an exception set") caused by the
    interrupt. Callers that stop cleanly on an interrupt raise this one instead.
    """
    cause = error.__cause__ or error.__context__
    return cause if isinstance(cause, KeyboardInterrupt) else None


def interrupts_unwrapped() -> InterruptsUnwrapped:
    """Let a Ctrl-C or SIGTERM that arrived inside a compiled call surface as itself.

    Inside this context (``with interrupts_unwrapped(): ...``) a ``SystemError``
    standing for an interrupt (:func:`interrupt_behind`) is replaced by the
    interrupt, so that callers stop on it as on any other; every other error
    passes unchanged.
    """
    return _UNWRAPPED


class InterruptsUnwrapped:
    """The context of :func:`interrupts_unwrapped` (a class, not a generator: an
    environment enters it at every step, and this costs a fraction of the time)."""

    __slots__ = ()

    def __enter__(self) -> None:
        return None

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        if isinstance(error, SystemError):
            interrupt = interrupt_behind(error)
            if interrupt is not None:
                raise interrupt from None


_UNWRAPPED = InterruptsUnwrapped()
"""The one context :func:`interrupts_unwrapped` hands out (it holds no state)."""
