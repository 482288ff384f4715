"""The options of scripts that study a team's episodes on generated floors, one by one.

``scripts/exploration_precision.py`` and ``scripts/exploration_confidences.py``
run the study's episodes (:mod:`tomosim.episode`) with an observer of their own
and take the same options: ``--worlds`` (floor seeds), ``--seeds``, ``--robots``,
``--policy``, ``--steps`` and ``--team NAME=VALUE`` (any team setting by its
dotted name, :mod:`tomosim.team.overrides`). A bad value ends the script with
``argparse``'s usage error naming the option.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from merging.settings import parse_assignments
from merging.validators import one_of
from tomosim.commands import UsageError
from tomosim.commands.team_options import check_methods_use
from tomosim.episode import EpisodeConfig
from tomosim.exploration.choosers import chooser_names
from tomosim.team import TeamConfig
from tomosim.team.overrides import with_settings

STUDY_WORLDS = (0, 1, 2)
"""The generated floors of the exploration study."""
STUDY_ROBOTS = 4
"""The team size of the exploration study's first stage."""
STUDY_STEPS = 4000
"""The step cap of an episode on a generated floor in the exploration study."""


def add_floor_episode_arguments(
    parser: argparse.ArgumentParser, *, seeds: Sequence[int], team_example: str
) -> None:
    """Declare the options (module docstring); ``seeds`` is the default of ``--seeds``."""
    parser.add_argument(
        "--worlds", nargs="+", type=int, default=list(STUDY_WORLDS), help="floor seeds"
    )
    parser.add_argument("--seeds", nargs="+", type=int, default=list(seeds))
    parser.add_argument("--robots", type=int, default=STUDY_ROBOTS)
    parser.add_argument("--policy", default="utility")
    parser.add_argument("--steps", type=int, default=STUDY_STEPS, help="step cap of an episode")
    parser.add_argument(
        "--team",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help=f"a team setting by its dotted name, e.g. {team_example} (repeatable)",
    )


def check_floor_episode_arguments(
    parser: argparse.ArgumentParser, args: argparse.Namespace, *, team_example: str
) -> None:
    """Check the options, and turn ``args.team`` into the :class:`TeamConfig` it asks for;
    ``parser.error`` (exit status 2) naming the option when one is wrong."""
    try:
        args.team = with_settings(
            TeamConfig(), parse_assignments(args.team, option="--team", example=team_example)
        )
    except ValueError as error:
        parser.error(f"--team: {error}")
    team: TeamConfig = args.team
    try:
        check_methods_use(
            team,
            [team.method] if team.merge else [],
            chosen=f"--team method={team.method}" if team.merge else "--team merge=false",
            fix="set --team method={method}",
        )
    except UsageError as error:
        parser.error(str(error))
    try:
        one_of(args.policy, chooser_names(), what="exploration policy")
    except ValueError as error:
        parser.error(f"--policy: {error}")
    for option, values in (("--worlds", args.worlds), ("--seeds", args.seeds)):
        negative = [value for value in values if value < 0]
        if negative:
            parser.error(f"{option} {negative[0]}: seeds are whole numbers >= 0")
    if args.robots < 2:
        parser.error(f"--robots {args.robots}: a pair needs at least 2 robots")
    if args.steps < 1:
        parser.error(f"--steps {args.steps}: give at least 1 step")


def floor_episode(args: argparse.Namespace, world: int, seed: int) -> EpisodeConfig:
    """The episode on floor ``world`` with ``seed``, as the checked options ask."""
    return EpisodeConfig(
        world=str(world),
        robots=args.robots,
        policy=args.policy,
        steps=args.steps,
        seed=seed,
        team=args.team,
    )
