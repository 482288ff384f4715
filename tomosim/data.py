"""Where the shared real data lives: maps and lidar logs kept beside the project.

The data are read in place and never copied into the project. Maps are found
through the maps path of :mod:`merging.catalog` (``TOMOSIM_MAPS``, else
``TOMOSIM_SHARED/maps``, else ``shared/maps`` beside the checkout); the lidar
logs through the shared folder (``TOMOSIM_SHARED``, else ``shared/`` beside
the checkout).

Every function returns ``None`` when the folder cannot be found, so that tests
can skip with a reason instead of failing.
"""

from __future__ import annotations

from pathlib import Path

from merging.catalog import MAPS_ENV, SHARED_ENV, describe_folders, map_folders, shared_folder

__all__ = ["MAPS_ENV", "SHARED_ENV", "datasets_dir", "maps_dir", "maps_missing", "shared_dir"]


def shared_dir() -> Path | None:
    """The shared data folder, or ``None`` when it cannot be found."""
    return shared_folder()


def maps_dir() -> Path | None:
    """The first folder of the maps path that exists, or ``None`` when none does."""
    return next((folder for folder in map_folders() if folder.is_dir()), None)


def maps_missing() -> str:
    """Why :func:`maps_dir` found no maps folder, and what to do, in one line."""
    return f"no folder of real maps found: looked in {describe_folders()}"


def datasets_dir() -> Path | None:
    """The folder of lidar logs (``carmen/*.log.gz``), or ``None`` when absent."""
    shared = shared_dir()
    if shared is None or not (shared / "datasets").is_dir():
        return None
    return shared / "datasets"
