"""Any team setting by its dotted name: ``confirmations``, ``tracker.keep_confidence``,
``simulation.lidar.beams``.

:class:`~tomosim.team.TeamConfig` nests frozen settings objects (the tracker's,
linking's, the communication's, the simulation's); a *setting name* walks them
with dots. :func:`with_settings` makes a copy with some settings changed, from
values or from their text (as the command line gives them, converted by the
field's type), and :func:`changed_settings` lists the settings in which a team
differs from the default one, so that a run records what it changed. The
walking itself is :mod:`merging.settings`'s, which the merger's settings use too.

>>> from tomosim.team import TeamConfig
>>> from tomosim.team.overrides import changed_settings, with_settings
>>> team = with_settings(TeamConfig(), {"confirmations": "3", "tracker.keep_confidence": "0.55"})
>>> team.confirmations, team.tracker.keep_confidence
(3, 0.55)
>>> changed_settings(team)
{'confirmations': 3, 'tracker.keep_confidence': 0.55}
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from merging import settings as by_name
from merging.settings import parse_value
from tomosim.team.config import TeamConfig

__all__ = ["changed_settings", "parse_value", "setting_names", "with_settings"]


def setting_names(config: Any = None, prefix: str = "") -> dict[str, type]:
    """Every setting name of ``config`` (default: a :class:`TeamConfig`) and its type
    (:func:`merging.settings.setting_names`)."""
    return by_name.setting_names(TeamConfig() if config is None else config, prefix)


def with_settings(team: TeamConfig, settings: Mapping[str, Any]) -> TeamConfig:
    """A copy of ``team`` with ``settings`` (setting name -> value or its text) changed.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones) or a value the
        setting refuses (the settings objects check their fields).
    """
    return by_name.with_settings(team, settings, what="team setting")


def changed_settings(team: TeamConfig, default: TeamConfig | None = None) -> dict[str, Any]:
    """The settings (by name) in which ``team`` differs from ``default`` (a default
    :class:`TeamConfig`), in the order of :func:`setting_names`."""
    return by_name.changed_settings(team, TeamConfig() if default is None else default)
