"""The team options ``explore`` and ``sweep`` share, and the :class:`~tomosim.team.TeamConfig`
they make.

``--merge-interval``, ``--comm-range`` and ``--line-of-sight`` set the fields
``merge_interval`` and ``comms`` of the team; each command adds its own way
of choosing the merging method (``explore``: ``--method`` and ``--no-merge``;
``sweep``: ``--methods``, a dimension of its grid). Their defaults are the
team's own (:class:`~tomosim.team.TeamConfig`). ``--team NAME=VALUE`` (repeatable)
sets any other team setting by its dotted name (:mod:`tomosim.team.overrides`):
``--team confirmations=3 --team tracker.keep_confidence=0.55 --team
simulation.lidar.beams=180``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from merging.settings import parse_assignments
from merging.validators import real_number, whole_number
from tomosim.commands import UsageError
from tomosim.sweep.plan import NO_MERGE
from tomosim.team import CommsConfig, TeamConfig
from tomosim.team.config import settings_for_other_methods
from tomosim.team.overrides import with_settings

DEFAULT_TEAM = TeamConfig()
"""The team without options."""
STEP_SECONDS = DEFAULT_TEAM.simulation.dt
"""Simulated seconds a step, to say how long the merge interval is."""


def add_team_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare ``--merge-interval``, ``--comm-range`` and ``--line-of-sight``."""
    interval = DEFAULT_TEAM.merge_interval
    parser.add_argument(
        "--merge-interval",
        type=int,
        default=interval,
        help=f"steps between merge rounds (default {interval}, {interval * STEP_SECONDS:g} s)",
    )
    parser.add_argument(
        "--comm-range",
        type=float,
        default=DEFAULT_TEAM.comms.range,
        metavar="METRES",
        help="robots exchange maps, poses and targets, and merge, only within this range, "
        "directly or through teammates in range (default unlimited)",
    )
    parser.add_argument(
        "--line-of-sight", action="store_true", help="walls block communication (with --comm-range)"
    )
    parser.add_argument(
        "--team",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="set any other team setting by its dotted name, e.g. confirmations=3, "
        "tracker.keep_confidence=0.55, merger.confidence.accept=0.7, "
        "simulation.lidar.beams=180 (repeatable; the names: "
        "tomosim.team.overrides.setting_names())",
    )


def team_config(args: argparse.Namespace, **fields: Any) -> TeamConfig:
    """The team the options ask for, with ``fields`` (``merge``, ``method``) set too;
    :class:`UsageError` naming the option when it cannot be."""
    try:
        whole_number(args.merge_interval, "--merge-interval", minimum=1, unit="steps")
        if args.comm_range is not None:
            real_number(args.comm_range, "--comm-range", low=0.0, low_open=True, unit="metres")
    except ValueError as error:
        raise UsageError(str(error)) from None
    if args.line_of_sight and args.comm_range is None:
        raise UsageError("--line-of-sight needs --comm-range")
    settings = team_settings(getattr(args, "team", []))
    try:
        team = TeamConfig(
            merge_interval=args.merge_interval,
            comms=CommsConfig(args.comm_range, args.line_of_sight),
            **fields,
        )
        team = with_settings(team, settings)
    except ValueError as error:
        raise UsageError(f"--team: {error}" if settings else str(error)) from None
    if "method" in fields:
        method = fields["method"]
        default = " (the default)" if method == DEFAULT_TEAM.method else ""
        merging = fields.get("merge", True)
        check_methods_use(
            team,
            [method] if merging else [],
            chosen=f"--method {method}{default}" if merging else "--no-merge",
            fix="give --method {method}",
        )
    return team


def check_methods_use(team: TeamConfig, methods: list[str], *, chosen: str, fix: str) -> None:
    """:class:`UsageError` when ``team`` changes a setting that only a method not among
    ``methods`` uses (:func:`tomosim.team.config.settings_for_other_methods`).

    ``chosen`` names the options that chose the methods (``--methods tomographic
    none``), ``fix`` how to run the method that uses the setting (``{method}`` stands
    for its name: ``add {method} to --methods``).
    """
    unused = settings_for_other_methods(team, methods)
    if not unused:
        return
    name, needs = next(iter(unused.items()))
    shown = f"{name}.*" if name in ("merger", "tracker") else name
    raise UsageError(
        f"--team {shown}: only the {needs!r} method uses it, and {chosen} does not run "
        f"it; drop the setting or {fix.format(method=needs)}"
    )


def check_methods_option(team: TeamConfig, methods: Sequence[str]) -> None:
    """:func:`check_methods_use` for a run over ``--methods`` (``none``: merging off), as
    ``tomosim sweep`` and the exploration study take them."""
    check_methods_use(
        team,
        [m for m in methods if m != NO_MERGE],
        chosen=f"--methods {' '.join(methods)}",
        fix="add {method} to --methods",
    )


OWN_OPTIONS = {
    "merge": "--no-merge",
    "method": "--method",
    "merge_interval": "--merge-interval",
    "comms.range": "--comm-range",
    "comms.line_of_sight": "--line-of-sight",
}
"""Team settings that have options of their own, which ``--team`` leaves to them."""


def team_settings(pairs: list[str]) -> dict[str, str]:
    """The ``NAME=VALUE`` pairs of ``--team`` as a mapping; :class:`UsageError` for a pair
    that is not one, or a setting that has its own option."""
    try:
        settings = parse_assignments(pairs, option="--team", example="confirmations=3")
    except ValueError as error:
        raise UsageError(str(error)) from None
    for name in settings:
        if name in OWN_OPTIONS:
            raise UsageError(f"--team {name}: use {OWN_OPTIONS[name]} instead")
    return settings
