"""The one decorator every compiled kernel uses.

``cache=True`` keeps the machine code beside the module (``__pycache__``), so
only the first process after an install pays the compilation (a few seconds
for all kernels). ``error_model="numpy"`` makes a division by zero give
``inf``/``nan`` as numpy does instead of raising, which the ray caster relies
on for beams parallel to a wall. No ``fastmath``: the kernels must give the
same numbers as their numpy oracles, run after run.
"""

from __future__ import annotations

from collections.abc import Callable
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
