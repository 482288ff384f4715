"""Any team setting by its dotted name: ``confirmations``, ``tracker.keep_confidence``,
``simulation.lidar.beams``.

:class:`~tomosim.team.TeamConfig` nests frozen settings objects (the tracker's,
linking's, the communication's, the simulation's); a *setting name* walks them
with dots. :func:`with_settings` makes a copy with some settings changed, from
values or from their text (as the command line gives them, converted by the
field's type), and :func:`changed_settings` lists the settings in which a team
differs from the default one, so that a run records what it changed.

>>> from tomosim.team import TeamConfig
>>> from tomosim.team.overrides import changed_settings, with_settings
>>> team = with_settings(TeamConfig(), {"confirmations": "3", "tracker.keep_confidence": "0.55"})
>>> team.confirmations, team.tracker.keep_confidence
(3, 0.55)
>>> changed_settings(team)
{'confirmations': 3, 'tracker.keep_confidence': 0.55}
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping
from typing import Any

from tomosim.team.config import TeamConfig

SCALARS = (bool, int, float, str)
"""The kinds of value a setting holds (the leaves of the nested settings)."""
TRUE_WORDS, FALSE_WORDS = ("true", "yes", "on", "1"), ("false", "no", "off", "0")
"""How a switch is written on the command line."""


def setting_names(config: Any = None, prefix: str = "") -> dict[str, type]:
    """Every setting name of ``config`` (default: a :class:`TeamConfig`) and its type."""
    config = TeamConfig() if config is None else config
    hints = typing.get_type_hints(type(config))
    names: dict[str, type] = {}
    for item in dataclasses.fields(config):
        value = getattr(config, item.name)
        name = f"{prefix}{item.name}"
        if dataclasses.is_dataclass(value):
            names.update(setting_names(value, f"{name}."))
            continue
        kind = _scalar_kind(hints.get(item.name))
        if kind is not None:
            names[name] = kind
    return names


def _scalar_kind(hint: Any) -> type | None:
    """The scalar type a field holds (``float | None`` gives ``float``), or None."""
    options = (
        typing.get_args(hint)
        if typing.get_origin(hint) in (typing.Union, type(int | None))
        else (hint,)
    )
    kinds = [option for option in options if option in SCALARS]
    return kinds[0] if len(kinds) == 1 else None


def parse_value(text: str, kind: type, name: str) -> Any:
    """``text`` as a value of ``kind`` (``none`` for an optional setting's None)."""
    word = text.strip().lower()
    if word == "none":
        return None
    if kind is bool:
        if word in TRUE_WORDS or word in FALSE_WORDS:
            return word in TRUE_WORDS
        raise ValueError(f"{name} is a switch: give true or false, got {text!r}")
    try:
        return kind(text.strip())
    except ValueError:
        raise ValueError(f"{name} takes {kind.__name__} values, got {text!r}") from None


def with_settings(team: TeamConfig, settings: Mapping[str, Any]) -> TeamConfig:
    """A copy of ``team`` with ``settings`` (setting name -> value or its text) changed.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones) or a value the
        setting refuses (the settings objects check their fields).
    """
    known = setting_names(team)
    for name, value in settings.items():
        if name not in known:
            raise ValueError(
                f"no team setting named {name!r}; the settings are: {', '.join(sorted(known))}"
            )
        if isinstance(value, str) and known[name] is not str:
            value = parse_value(value, known[name], name)
        team = _replaced(team, name.split("."), value)
    return team


def _replaced(config: Any, path: list[str], value: Any) -> Any:
    """``config`` with the setting at ``path`` made ``value`` (nested copies)."""
    head, *rest = path
    new = value if not rest else _replaced(getattr(config, head), rest, value)
    return dataclasses.replace(config, **{head: new})


def changed_settings(team: TeamConfig, default: TeamConfig | None = None) -> dict[str, Any]:
    """The settings (by name) in which ``team`` differs from ``default`` (a default
    :class:`TeamConfig`), in the order of :func:`setting_names`."""
    default = TeamConfig() if default is None else default
    changed = {}
    for name in setting_names(team):
        value, base = _get(team, name), _get(default, name)
        if value != base:
            changed[name] = value
    return changed


def _get(config: Any, name: str) -> Any:
    for part in name.split("."):
        config = getattr(config, part)
    return config
