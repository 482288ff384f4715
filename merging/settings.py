"""Settings by dotted name: ``confidence.accept``, ``robust.margin``, ``translation.peaks``.

The default method's settings (:class:`~merging.params.TomographicParams`)
nest frozen dataclasses, one per concern; a *setting name* walks them with
dots. :func:`setting_names` lists every setting that holds one value, with
its type; :func:`with_settings` makes a copy with some of them changed (from
values, or from their text as a command line gives them, converted by the
field's type); :func:`changed_settings` lists those in which a settings
object differs from another. Settings holding several values (the
refinement schedule, field widths) have no name: set them in Python with
``dataclasses.replace``.

The same names reach the settings from the command line:
``tomosim merge --merger confidence.accept=0.5`` and the benchmark scripts'
``--merger``. The functions take any nesting of frozen dataclasses
(:mod:`tomosim.team.overrides` uses them for the team's settings).

>>> from merging.params import TomographicParams
>>> from merging.settings import changed_settings, with_settings
>>> params = with_settings(TomographicParams(), {"robust.margin": "0.2"})
>>> params.robust.margin
0.2
>>> changed_settings(params, TomographicParams())
{'robust.margin': 0.2}
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from merging.validators import near_names

SCALARS = (bool, int, float, str)
"""The kinds of value a named setting holds (the leaves of the nested settings)."""
TRUE_WORDS, FALSE_WORDS = ("true", "yes", "on", "1"), ("false", "no", "off", "0")
"""How a switch is written on the command line."""

Settings = TypeVar("Settings")


def setting_names(config: Any, prefix: str = "") -> dict[str, type]:
    """Every setting name of ``config`` (a frozen dataclass, nested or not) and its type.

    A field holding a dataclass is walked into; one holding a single value of
    :data:`SCALARS` (or None besides) is a setting; other fields (tuples,
    arrays) are left out.
    """
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise TypeError(f"settings are read from a dataclass instance, got {type(config).__name__}")
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


def with_settings(
    config: Settings, settings: Mapping[str, Any], *, what: str = "setting"
) -> Settings:
    """A copy of ``config`` with ``settings`` (setting name -> value or its text) changed.

    ``what`` names the settings in an error ("no {what} named ...").

    Raises
    ------
    ValueError
        For an unknown name (the message suggests the names meant,
        :func:`unknown_setting`) or a value the setting refuses (the settings
        objects check their fields).
    """
    known = setting_names(config)
    for name, value in settings.items():
        if name not in known:
            raise ValueError(unknown_setting(name, known, what=what))
        if isinstance(value, str) and known[name] is not str:
            value = parse_value(value, known[name], name)
        config = _replaced(config, name.split("."), value)
    return config


def unknown_setting(name: str, known: Mapping[str, type], *, what: str = "setting") -> str:
    """Why ``name`` is not among the ``known`` setting names, and which names may be meant.

    A group of settings named whole, or by its last part (``robust`` for
    ``merger.robust``), lists the group's settings. Otherwise the names it may
    have meant (:func:`merging.validators.near_names`: ``accept`` finds
    ``confidence.accept``), within the group it names first (``robust.margn``:
    among the ``robust.*`` settings), then among all; failing those, the
    group's settings, or the settings without a group and the groups with
    their sizes (rather than every name).

    >>> print(unknown_setting("confidence.acept", {"confidence.accept": float, "peaks": int}))
    no setting named 'confidence.acept'; did you mean confidence.accept?
    """
    message = f"no {what} named {name!r}"
    stripped = name.strip(".")
    names = sorted(known)
    groups = sorted(
        {
            ".".join(parts[:end])
            for parts in (n.split(".") for n in names)
            for end in range(1, len(parts))
        }
    )
    named = [g for g in groups if stripped and (g == stripped or g.endswith(f".{stripped}"))]
    if named:  # a group, named whole or by its last part
        members = ", ".join(n for n in names if n.startswith(f"{named[0]}."))
        return f"{message}; the {named[0]}.* settings are: {members}"
    group = stripped.rsplit(".", 1)[0] + "." if "." in stripped else ""
    in_group = [n for n in names if group and n.startswith(group)]
    near = near_names(stripped, in_group) or near_names(stripped, names)
    if near:
        return f"{message}; did you mean {' or '.join(near)}?"
    if in_group:
        return f"{message}; the {group}* settings are: {', '.join(in_group)}"
    sizes: dict[str, int] = {}
    for head, _, rest in (n.partition(".") for n in names):
        if rest:
            sizes[head] = sizes.get(head, 0) + 1
    listed = [n for n in names if "." not in n] + [f"{h}.* ({k})" for h, k in sizes.items()]
    return f"{message}; the settings are: {', '.join(listed)}"


def _replaced(config: Any, path: list[str], value: Any) -> Any:
    """``config`` with the setting at ``path`` made ``value`` (nested copies)."""
    head, *rest = path
    new = value if not rest else _replaced(getattr(config, head), rest, value)
    return dataclasses.replace(config, **{head: new})


def changed_settings(config: Any, default: Any) -> dict[str, Any]:
    """The settings (by name) in which ``config`` differs from ``default``, in the order of
    :func:`setting_names`."""
    changed = {}
    for name in setting_names(config):
        value, base = setting_value(config, name), setting_value(default, name)
        if value != base:
            changed[name] = value
    return changed


def setting_value(config: Any, name: str) -> Any:
    """The value of the setting ``name`` (dotted) of ``config``."""
    for part in name.split("."):
        config = getattr(config, part)
    return config


def parse_assignments(pairs: list[str], *, option: str, example: str) -> dict[str, str]:
    """``NAME=VALUE`` texts (as an option repeated on a command line gives them) as a
    mapping; ``ValueError`` naming ``option`` and showing ``example`` for one that is not."""
    settings: dict[str, str] = {}
    for pair in pairs:
        name, equals, value = pair.partition("=")
        name = name.strip()
        if not equals or not name or not value.strip():
            raise ValueError(f"{option} takes NAME=VALUE (e.g. {example}), got {pair!r}")
        settings[name] = value
    return settings
