"""Where the shared real data lives: maps and lidar logs kept beside the project.

The data are read in place and never copied into the project. The folder is
found, in this order, from

1. the environment variable ``TOMOSIM_SHARED`` (the folder holding ``maps/``
   and ``datasets/``); ``TOMOSIM_MAPS`` overrides the maps folder alone;
2. a folder named ``shared`` beside the project checkout or beside one of its
   parent folders (walking up from the checkout).

Every function returns ``None`` when the folder cannot be found, so that tests
can skip with a reason instead of failing.
"""

from __future__ import annotations

import os
from pathlib import Path

SHARED_ENV = "TOMOSIM_SHARED"
"""Environment variable naming the shared data folder."""
MAPS_ENV = "TOMOSIM_MAPS"
"""Environment variable naming the maps folder (overrides ``TOMOSIM_SHARED/maps``)."""
SHARED_NAME = "shared"
"""Name of the shared data folder looked for beside the checkout."""
_MARKERS = ("maps", "datasets")
"""Subfolders of which at least one must exist for a ``shared`` folder to count."""


def _project_root() -> Path:
    """The folder holding the ``tomosim`` package (the checkout when installed editable)."""
    return Path(__file__).resolve().parents[1]


def _looks_shared(folder: Path) -> bool:
    return folder.is_dir() and any((folder / marker).is_dir() for marker in _MARKERS)


def shared_dir() -> Path | None:
    """The shared data folder, or ``None`` when it cannot be found."""
    env = os.environ.get(SHARED_ENV)
    if env:
        path = Path(env).expanduser()
        return path if path.is_dir() else None
    for ancestor in _project_root().parents:
        candidate = ancestor / SHARED_NAME
        if _looks_shared(candidate):
            return candidate
    return None


def maps_dir() -> Path | None:
    """The folder of real ``map_server`` maps, or ``None`` when absent."""
    env = os.environ.get(MAPS_ENV)
    if env:
        path = Path(env).expanduser()
        return path if path.is_dir() else None
    shared = shared_dir()
    if shared is None or not (shared / "maps").is_dir():
        return None
    return shared / "maps"


def maps_missing() -> str:
    """Why :func:`maps_dir` found no maps folder, and what to do, in one line."""
    maps_env, shared_env = os.environ.get(MAPS_ENV), os.environ.get(SHARED_ENV)
    if maps_env:
        return f"{MAPS_ENV}={maps_env} is not a folder; set it to the folder of the real maps"
    if shared_env:
        return (
            f"{SHARED_ENV}={shared_env} holds no maps folder; set it to the shared data "
            f"folder (holding maps/), or set {MAPS_ENV} to the maps folder itself"
        )
    return (
        f"the real maps folder was not found: set {MAPS_ENV} to it, or keep the shared "
        f"data folder ({SHARED_NAME}/, holding maps/) beside the checkout"
    )


def datasets_dir() -> Path | None:
    """The folder of lidar logs (``carmen/*.log.gz``), or ``None`` when absent."""
    shared = shared_dir()
    if shared is None or not (shared / "datasets").is_dir():
        return None
    return shared / "datasets"
