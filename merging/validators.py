"""Checks of settings: whole numbers, real numbers in a range, a choice among names, a
switch, and the source of randomness; and the names a misspelt one may have meant.

Every settings object and entry point of ``merging``, ``tomosim`` and ``envs``
checks its input with these, so that a bad value is refused where it is given,
in words that name it and say what it must be::

    >>> from merging.validators import whole_number
    >>> whole_number(0, "merge_interval", minimum=1, unit="steps")
    Traceback (most recent call last):
    ...
    ValueError: merge_interval must be a whole number of steps >= 1, got 0

Each check returns the value as the plain Python type it stands for (``int``,
``float``, ``str``, ``bool``), so that a NumPy scalar is stored as a number.

A value of the wrong kind (a bool for a count, text for a number) raises
:class:`SettingTypeError`, both a ``TypeError`` and a ``ValueError``; a value
of the right kind out of its range raises ``ValueError``.
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Collection

import numpy as np

RngLike = np.random.Generator | int | None
"""What a keyword-only ``rng`` takes: a Generator, a seed, or None (fresh entropy)."""


class SettingTypeError(TypeError, ValueError):
    """A setting of the wrong kind: a bool for a count, text for a number.

    A ``TypeError``, as Python raises for a value of the wrong type, and a
    ``ValueError``, as the range checks raise, so that a caller catching either
    (a command line turning a bad setting into a usage message) sees it.
    """


def whole_number(value: object, name: str, *, minimum: int | None = None, unit: str = "") -> int:
    """``value`` as an ``int``, if it is a whole number (not a bool) of at least ``minimum``.

    Parameters
    ----------
    value : object
        The setting.
    name : str
        Its name in the message.
    minimum : int, optional
        The least value allowed.
    unit : str, optional
        What it counts, in the message: ``"steps"`` gives "a whole number of steps".

    Raises
    ------
    SettingTypeError
        For anything but an integer (a bool, a float such as ``3.0``).
    ValueError
        For an integer below ``minimum``.
    """
    of = f" of {unit}" if unit else ""
    least = "" if minimum is None else f" >= {minimum}"
    message = f"{name} must be a whole number{of}{least}, got {value!r}"
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise SettingTypeError(message)
    if minimum is not None and value < minimum:
        raise ValueError(message)
    return int(value)


def real_number(
    value: object,
    name: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> float:
    """``value`` as a ``float``, if it is a finite number (not a bool) within the bounds.

    Parameters
    ----------
    value : object
        The setting.
    name : str
        Its name in the message.
    low, high : float, optional
        The bounds of the range (None: unbounded on that side).
    low_open, high_open : bool
        Whether the bound itself is left out: ``low=0, low_open=True`` asks for
        a positive number, ``low=0, high=1, low_open=True`` for one in ``(0, 1]``.
    unit : str, optional
        Its unit, in the message: ``"metres"`` gives "a positive number of metres".

    Raises
    ------
    SettingTypeError
        For anything but a real number (a bool, text, a complex number).
    ValueError
        For NaN, an infinity or a number out of the range.
    """
    message = f"{name} must be {_range_words(low, high, low_open, high_open, unit)}, got {value!r}"
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise SettingTypeError(message)
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(message)
    if low is not None and (number < low or (low_open and number == low)):
        raise ValueError(message)
    if high is not None and (number > high or (high_open and number == high)):
        raise ValueError(message)
    return number


def _range_words(
    low: float | None, high: float | None, low_open: bool, high_open: bool, unit: str
) -> str:
    """ "a number in (0, 1]", "a positive number of metres", "a number >= 2", ..."""
    of = f" of {unit}" if unit else ""
    if low is not None and high is not None:
        left, right = "(" if low_open else "[", ")" if high_open else "]"
        return f"a number{of} in {left}{low:g}, {high:g}{right}"
    if low == 0:
        return f"a {'positive' if low_open else 'non-negative'} number{of}"
    if low is not None:
        return f"a number{of} {'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f"a number{of} {'<' if high_open else '<='} {high:g}"
    return f"a finite number{of}"


def one_of(value: object, choices: Collection[str], *, what: str) -> str:
    """``value``, if it is one of the names ``choices``.

    Parameters
    ----------
    value : object
        The name given.
    choices : collection of str
        The names allowed, listed in the message in their order.
    what : str
        What the names name, in the message: ``"merging method"`` gives
        "unknown merging method 'x'; choose one of: ...".

    Raises
    ------
    ValueError
        For anything but one of ``choices``.
    """
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"unknown {what} {value!r}; choose one of: {', '.join(choices)}")
    return value


def near_names(
    name: str, candidates: Collection[str], *, separator: str = ".", most: int = 4
) -> list[str]:
    """The ``candidates`` a misspelt or shortened ``name`` may have meant, nearest first.

    Names are paths of parts joined by ``separator`` (``merger.confidence.accept``,
    ``halmstad/E5_01``); a name is often given by its last part alone, or with a
    typo in it, so last parts are compared, whatever their case. The candidates
    whose last part is ``name``'s, if any; else those whose last part is spelled
    nearly as it is (``difflib.SequenceMatcher`` ratio of at least 0.75) or
    starts with it (three letters or more), the nearest first; at most ``most``.

    >>> near_names("accept", ["confidence.accept", "robust.margin"])
    ['confidence.accept']
    >>> near_names("E5_1", ["halmstad/E5_01", "halmstad/E5_10", "aces3"], separator="/")
    ['halmstad/E5_01', 'halmstad/E5_10']
    """
    last = name.strip(separator).rsplit(separator, 1)[-1].lower()
    if not last:
        return []
    ends: dict[str, list[str]] = {}
    for candidate in sorted(candidates):
        ends.setdefault(candidate.rsplit(separator, 1)[-1].lower(), []).append(candidate)
    if last in ends:
        return ends[last][:most]  # the name's last part, whole: the group was left out
    ranked = []
    for end in ends:
        ratio = difflib.SequenceMatcher(None, last, end).ratio()
        if ratio >= 0.75 or (len(last) >= 3 and end.startswith(last)):
            ranked.append((-ratio, end))
    ranked.sort()
    return [candidate for _, end in ranked for candidate in ends[end]][:most]


def boolean(value: object, name: str) -> bool:
    """``value`` as a ``bool``, if it is one (Python's or NumPy's): not 0, 1 or ``"no"``.

    Raises
    ------
    SettingTypeError
        For anything but True or False.
    """
    if not isinstance(value, bool | np.bool_):
        raise SettingTypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def as_generator(rng: object, *, name: str = "rng") -> np.random.Generator:
    """``numpy.random.default_rng(rng)``, or an error that names ``name`` and what it takes.

    Accepts what ``default_rng`` does (None, a non-negative int, a
    SeedSequence, a BitGenerator or a Generator, which is returned as it is)
    except a bool.
    """
    takes = f"{name} must be None, a non-negative int, a SeedSequence or a numpy Generator"
    if isinstance(rng, bool | np.bool_):
        raise TypeError(f"{takes}, got {rng!r}")
    try:
        return np.random.default_rng(rng)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"{takes}, got {rng!r}") from exc
