"""``--merger NAME=VALUE``: any setting of the default merger by its dotted name.

``tomosim merge`` and the benchmark scripts (``scripts/bench_real_maps.py``,
``scripts/bench_cycles.py``, ``scripts/merger_answers.py``) take it, repeatable:
``--merger confidence.accept=0.5 --merger robust.margin=0.2``. The names are
those of :func:`merging.settings.setting_names` on a
:class:`~merging.params.TomographicParams` (an unknown name's error lists
them all); only the default method (``tomographic``) takes settings.
"""

from __future__ import annotations

import argparse

from merging.api import DEFAULT_METHOD
from merging.params import DEFAULT_PARAMS, TomographicParams
from merging.settings import changed_settings, parse_assignments, with_settings
from tomosim.commands import UsageError

OPTION = "--merger"
"""The option's name."""
EXAMPLE = "confidence.accept=0.5"
"""The example its help and its errors show."""


def add_merger_argument(parser: argparse.ArgumentParser) -> None:
    """Declare ``--merger NAME=VALUE`` (repeatable) on ``parser``."""
    parser.add_argument(
        OPTION,
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help=f"set a setting of the default merger by its dotted name, e.g. {EXAMPLE}, "
        "robust.margin=0.2 (repeatable; the names: "
        "merging.settings.setting_names(merging.params.DEFAULT_PARAMS))",
    )


def merger_params(pairs: list[str], method: str = DEFAULT_METHOD) -> TomographicParams | None:
    """The default merger's settings that ``--merger`` ``pairs`` ask for; None when none
    is given (the method's own defaults).

    Raises
    ------
    UsageError
        For a pair that is not ``NAME=VALUE``, an unknown name (the message
        lists the names), a value the setting refuses, or settings given for
        a method other than the default one.
    """
    if not pairs:
        return None
    if method != DEFAULT_METHOD:
        raise UsageError(
            f"{OPTION} sets the {DEFAULT_METHOD!r} method's settings; the {method!r} method "
            "takes none"
        )
    try:
        settings = parse_assignments(pairs, option=OPTION, example=EXAMPLE)
    except ValueError as error:
        raise UsageError(str(error)) from None
    try:
        return with_settings(DEFAULT_PARAMS, settings, what="merger setting")
    except ValueError as error:
        raise UsageError(f"{OPTION}: {error}") from None


def changed(params: TomographicParams | None) -> dict[str, object]:
    """The settings ``params`` changes from the default merger's (empty for None), to
    record beside a run's results."""
    return {} if params is None else changed_settings(params, DEFAULT_PARAMS)
