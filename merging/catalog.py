"""Maps found by name: the folders of the maps path, and what they hold.

A map is named by its YAML file's path relative to a folder of the maps path,
without the suffix: ``aces3`` for ``aces3.yaml``, ``halmstad/E5_01`` for
``halmstad/E5_01.yaml``. The maps path is, in this order,

1. the environment variable ``TOMOSIM_MAPS``: one or more folders, separated
   as in ``PATH`` (``:`` on Linux and macOS, ``;`` on Windows);
2. ``maps/`` in the folder named by ``TOMOSIM_SHARED`` (the shared data folder,
   which also holds the lidar logs);
3. ``shared/maps`` beside the repository (or beside one of its parent
   folders), where a checkout keeps the real maps it reads but does not carry.

An earlier folder wins when two hold a map of the same name.

A path is taken as it is; a name is looked up (``merging.load_map("intel")``
loads the map named ``intel``, ``tomosim maps`` lists the names):

>>> from merging.catalog import find_map, is_map_path
>>> str(find_map("maps/office.yaml"))
'maps/office.yaml'
>>> is_map_path("halmstad/E5_01"), is_map_path("./E5_01.yaml")
(False, True)
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from PIL import Image

from merging.validators import near_names

MAPS_ENV = "TOMOSIM_MAPS"
"""Environment variable naming the folders of maps (separated by ``os.pathsep``)."""
SHARED_ENV = "TOMOSIM_SHARED"
"""Environment variable naming the shared data folder (holding ``maps/`` and ``datasets/``)."""
SHARED_NAME = "shared"
"""Name of the shared data folder looked for beside the checkout."""
MAP_SUFFIXES = (".yaml", ".yml")
"""Suffixes of a map's YAML file."""
IMAGE_SUFFIXES = (".pgm", ".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
"""Suffixes of a map's image: written as a path (the image given for its YAML file), never
a map's name."""


def is_yaml_name(path: str | Path) -> bool:
    """Whether ``path`` ends in a map's YAML suffix (:data:`MAP_SUFFIXES`), in any case:
    ``E5.YAML`` is read, listed as an argument and written as ``e5.yaml`` is."""
    return Path(path).suffix.lower() in MAP_SUFFIXES


def repository_root() -> Path:
    """The folder holding the ``merging`` package: the checkout, when installed editable."""
    return Path(__file__).resolve().parents[1]


def shared_folder() -> Path | None:
    """The shared data folder (``TOMOSIM_SHARED``, or ``shared/`` beside the checkout), or None.

    Beside the checkout, a folder named ``shared`` counts when it holds ``maps/``
    or ``datasets/``; the checkout's parent folders are searched upwards.
    """
    configured = os.environ.get(SHARED_ENV)
    if configured:
        path = Path(configured).expanduser()
        return path if path.is_dir() else None
    for ancestor in repository_root().parents:
        candidate = ancestor / SHARED_NAME
        if (candidate / "maps").is_dir() or (candidate / "datasets").is_dir():
            return candidate
    return None


def map_folders() -> tuple[Path, ...]:
    """The folders searched for maps by name, in order (some may not exist).

    Without ``TOMOSIM_MAPS`` and ``TOMOSIM_SHARED``, and with no shared folder
    beside the checkout, this is the one place the maps are expected:
    ``../shared/maps`` from the repository root.
    """
    configured = os.environ.get(MAPS_ENV)
    if configured:
        return tuple(Path(part).expanduser() for part in configured.split(os.pathsep) if part)
    shared = shared_folder()
    if shared is not None:
        return (shared / "maps",)
    if os.environ.get(SHARED_ENV):  # named but missing: say so, not the default
        return (Path(os.environ[SHARED_ENV]).expanduser() / "maps",)
    return (repository_root().parent / SHARED_NAME / "maps",)


def describe_folders(folders: tuple[Path, ...] | None = None) -> str:
    """The folders of the maps path and where they come from, for messages."""
    folders = map_folders() if folders is None else folders
    listed = ", ".join(str(folder) for folder in folders)
    if os.environ.get(MAPS_ENV):
        return f"{listed} (from {MAPS_ENV})"
    if os.environ.get(SHARED_ENV):
        return f"{listed} (from {SHARED_ENV})"
    return f"{listed} (the default; set {MAPS_ENV} to the folders of your maps)"


def is_map_path(source: str | Path) -> bool:
    """Whether ``source`` is written as a file path rather than a map name (:func:`find_map`)."""
    text = str(source)
    return (
        isinstance(source, Path)
        or is_yaml_name(text)
        or text.lower().endswith(IMAGE_SUFFIXES)
        or text.startswith(("/", "~", "."))
        or "\\" in text
    )


def find_map(source: str | Path) -> Path:
    """The YAML file of the map named ``source``, or ``source`` itself when it is a path.

    Parameters
    ----------
    source : str or Path
        A map name (``"intel"``, ``"halmstad/E5_01"``), looked up in the
        folders of :func:`map_folders`, or a path to a ``map_server`` YAML file.
        A ``Path``, a string ending in ``.yaml``, ``.yml`` or an image's suffix
        (:data:`IMAGE_SUFFIXES`: the image given for its YAML file, which its
        reader names), or one starting with ``/``, ``~`` or ``.`` is a path; an
        existing file is always taken as it is.

    Returns
    -------
    Path
        The YAML file (for a path: the path as given, whether or not it exists,
        so that its reader names it).

    Raises
    ------
    FileNotFoundError
        For a name no folder holds; the message lists the folders searched.
    TypeError
        If ``source`` is neither a string nor a path.
    """
    if not isinstance(source, str | Path):
        raise TypeError(f"a map is a name or a path, got {type(source).__name__}")
    if is_map_path(source) or Path(source).is_file():
        return Path(source).expanduser()
    name = str(source).strip("/")
    if not name:
        raise FileNotFoundError("a map name must not be empty; `tomosim maps` lists the names")
    folders = map_folders()
    for folder in folders:
        for suffix in MAP_SUFFIXES:
            candidate = folder / f"{name}{suffix}"
            if candidate.is_file():
                return candidate
    try:
        near = near_names(name, _map_names(folders) - {name}, separator="/")
    except OSError:  # a folder that cannot be walked: no suggestion, the message stands
        near = []
    meant = f" (did you mean {' or '.join(near)}?)" if near else ""
    raise FileNotFoundError(
        f"no map named {name!r}{meant} in {describe_folders(folders)}; `tomosim maps` lists "
        "the maps found, or give the path of a map_server YAML file"
    )


def _map_names(folders: tuple[Path, ...]) -> set[str]:
    """The names of the YAML files under ``folders`` (as :func:`list_maps` names them,
    without reading them)."""
    return {
        path.relative_to(folder).with_suffix("").as_posix()
        for folder in folders
        if folder.is_dir()
        for path in folder.rglob("*")
        if path.suffix in MAP_SUFFIXES and path.is_file()
    }


@dataclass(frozen=True, slots=True)
class MapEntry:
    """One map of the maps path, as :func:`list_maps` finds it.

    Attributes
    ----------
    name : str
        Its name (the YAML file's path in its folder, ``/``-separated, no suffix).
    path : Path
        Its YAML file.
    rows, cols : int
        The image's size in cells.
    resolution : float
        Metres per cell.
    """

    name: str
    path: Path
    rows: int
    cols: int
    resolution: float

    @property
    def size_m(self) -> tuple[float, float]:
        """Width and height in metres."""
        return self.cols * self.resolution, self.rows * self.resolution


def list_maps(folders: tuple[Path, ...] | None = None) -> list[MapEntry]:
    """Every readable map in the maps path, sorted by name (an earlier folder wins a name).

    Reads each YAML file and the header of its image, not the pixels; files
    that are not ``map_server`` maps (other YAML, unreadable images) are skipped.
    """
    found: dict[str, MapEntry] = {}
    for folder in map_folders() if folders is None else folders:
        for entry in _maps_in(folder):
            found.setdefault(entry.name, entry)
    return [found[name] for name in sorted(found)]


def _maps_in(folder: Path) -> Iterator[MapEntry]:
    """The readable maps under ``folder``."""
    # Imported here: mapio imports this module (to find a map by its name).
    from merging.mapio import map_header

    if not folder.is_dir():
        return
    for path in sorted(p for suffix in MAP_SUFFIXES for p in folder.rglob(f"*{suffix}")):
        try:
            image, resolution = map_header(path)
            with Image.open(image) as picture:
                cols, rows = picture.size
        except (OSError, ValueError, KeyError):
            continue
        name = path.relative_to(folder).with_suffix("").as_posix()
        yield MapEntry(name, path, rows, cols, resolution)
