"""The team options ``explore`` and ``sweep`` share, and the :class:`~tomosim.team.TeamConfig`
they make.

``--merge-interval``, ``--comm-range`` and ``--line-of-sight`` set the fields
``merge_interval`` and ``comms`` of the team; each command adds its own way
of choosing the merging method (``explore``: ``--method`` and ``--no-merge``;
``sweep``: ``--methods``, a dimension of its grid). Their defaults are the
team's own (:class:`~tomosim.team.TeamConfig`); every other team setting keeps
its default on the command line.
"""

from __future__ import annotations

import argparse
from typing import Any

from merging.validators import real_number, whole_number
from tomosim.commands import UsageError
from tomosim.team import CommsConfig, TeamConfig

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
    try:
        return TeamConfig(
            merge_interval=args.merge_interval,
            comms=CommsConfig(args.comm_range, args.line_of_sight),
            **fields,
        )
    except ValueError as error:
        raise UsageError(str(error)) from None
