"""Reading and writing ROS ``map_server`` maps (a YAML file beside a PGM/PNG image).

The image's row 0 is the top of the picture, the largest ``y`` of the map;
:class:`~merging.grid.OccupancyGrid` keeps row 0 at the origin, so both
functions flip rows. Pixel values are interpreted as ``map_server`` does:
``occ = (255 - p) / 255`` (or ``p / 255`` with ``negate: 1``), then

* ``trinary``: ``occ > occupied_thresh`` -> 100, ``occ < free_thresh`` -> 0, else -1;
* ``scale``: unknown where the pixel is not opaque (an image with an alpha
  channel or a transparent colour), else as trinary at the extremes, linear
  in between (as ROS 2's ``map_server`` reads it; ROS 1's applies the
  thresholds before the alpha);
* ``raw``: the pixel value itself (values above 100 become unknown).

Outside ``scale`` mode the alpha channel is not read (``map_server`` folds it
into the grey level of colour images; a map's image rarely has one).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import IO, Any, NamedTuple

import numpy as np
import yaml
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from merging.catalog import find_map, is_yaml_name
from merging.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid

MODES = ("trinary", "scale", "raw")
"""The ``mode`` values ``map_server`` understands."""
PIXEL_OCCUPIED, PIXEL_UNKNOWN, PIXEL_FREE = 0, 205, 254
"""Grey levels ``map_saver`` writes in trinary mode."""
MAX_YAML_BYTES = 64 * 1024
"""Largest map YAML read: a map_server YAML is a dozen short lines; this leaves
room for long comments and refuses anything that cannot be one."""
IMAGE_SIGNATURES = (
    (b"\x89PNG", "PNG"),
    (b"P5\n", "PGM"),
    (b"P5 ", "PGM"),
    (b"P2\n", "PGM"),
    (b"P2 ", "PGM"),
    (b"\xff\xd8\xff", "JPEG"),
    (b"GIF8", "GIF"),
    (b"II*\x00", "TIFF"),
    (b"MM\x00*", "TIFF"),
)
"""First bytes of the image formats a map's image comes in, to name the mistake
of passing the image instead of its YAML."""
FORMATS = {"pgm": "PPM", "png": "PNG"}
"""Pillow's format name for each image suffix :func:`save_map` writes."""


class _NoAliasLoader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases: ``*name`` is refused, not expanded.

    ``map_server`` files never need aliases, and a few hundred bytes of nested
    aliases expand to gigabytes ("billion laughs").
    """

    def compose_node(self, parent: yaml.Node | None, index: object) -> yaml.Node | None:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.composer.ComposerError(
                None, None, "aliases are not allowed in a map_server file", event.start_mark
            )
        return super().compose_node(parent, index)


def _read_yaml(path: Path) -> object:
    """The YAML document in ``path``, refusing what no map_server YAML is (ValueError)."""
    with path.open("rb") as handle:
        # The map's image given in place of its YAML file is the common mistake, and an
        # image is mostly larger than a YAML file may be: say so before the size.
        head = handle.read(max(len(signature) for signature, _ in IMAGE_SIGNATURES))
    for signature, kind in IMAGE_SIGNATURES:
        if head.startswith(signature):
            raise ValueError(
                f"{path} is a {kind} image, not a map_server YAML file; "
                "pass the .yaml file that names it"
            )
    size = path.stat().st_size
    if size > MAX_YAML_BYTES:
        raise ValueError(
            f"{path} is {size} bytes, too large for a map_server YAML file (at most "
            f"{MAX_YAML_BYTES}); pass the .yaml file that names the map's image"
        )
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{path} is not a text file (byte {exc.start} is not UTF-8), so not a map_server "
            "YAML file; pass the map's .yaml file"
        ) from exc
    try:
        return yaml.load(text, Loader=_NoAliasLoader)  # a safe loader that refuses aliases
    except yaml.YAMLError as exc:
        raise ValueError(f"{path} is not valid YAML: {' '.join(str(exc).split())}") from exc


def load_map(source: str | Path) -> OccupancyGrid:
    """Load a ``map_server`` map, by name or from its YAML file.

    Parameters
    ----------
    source : str or Path
        The map's YAML file (its ``image`` entry is resolved relative to it),
        or the name of a map in the maps path (``"intel"``,
        ``"halmstad/E5_01"``; :func:`merging.catalog.find_map`).

    Returns
    -------
    OccupancyGrid

    Raises
    ------
    FileNotFoundError
        If the YAML file or its image does not exist, or no folder of the maps
        path holds a map of that name (the message lists the folders searched).
    ValueError
        If the path is a directory, or the YAML is malformed, lacks a
        required key, is not text (an image passed by mistake), names a file
        that is not an image, is larger than :data:`MAX_YAML_BYTES` or uses
        YAML aliases (refused rather than expanded).
    """
    path = find_map(source)
    meta = _map_meta(path)
    image_path = _image_of(path, meta)
    header = _header(path, meta)
    try:
        with Image.open(image_path) as image:
            pixels = grey_levels(image)
            see_through = transparent(image) if header.mode == "scale" else None
    except UnidentifiedImageError as exc:
        raise ValueError(
            f"image {image_path} named by {path} is not an image Pillow can read; give a PGM or PNG"
        ) from exc
    except OSError as exc:  # a truncated or damaged file, one not to be read
        if isinstance(exc, FileNotFoundError | PermissionError | IsADirectoryError):
            raise
        raise ValueError(
            f"image {image_path} named by {path} cannot be read ({' '.join(str(exc).split())}); "
            "is it whole? save the map again"
        ) from exc
    data = pixels_to_cells(
        pixels,
        mode=header.mode,
        negate=header.negate,
        occupied_thresh=header.occupied_thresh,
        free_thresh=header.free_thresh,
        transparent=see_through,
    )
    try:
        return OccupancyGrid(data[::-1].copy(), resolution=header.resolution, origin=header.origin)
    except ValueError as exc:  # an origin too far away, say
        raise ValueError(f"{path}: {exc}") from exc


def map_image(yaml_path: str | Path) -> Path:
    """The image file a ``map_server`` YAML names, resolved against the YAML's folder.

    Raises as :func:`load_map` does for a missing or malformed YAML or a
    missing image.
    """
    path = Path(yaml_path)
    return _image_of(path, _map_meta(path))


def map_header(path: Path) -> tuple[Path, float]:
    """The image file a map's YAML names and its resolution, without reading the pixels;
    the YAML's other entries are checked as :func:`load_map` checks them.

    Raises
    ------
    FileNotFoundError, ValueError
        As :func:`load_map` for a bad YAML file or a missing image.
    """
    meta = _map_meta(path)
    image = _image_of(path, meta)
    return image, _header(path, meta).resolution


class _Header(NamedTuple):
    """A map YAML's entries, checked: all but the pixels."""

    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str


def _header(path: Path, meta: dict[str, Any]) -> _Header:
    """The entries of a map's YAML ``meta`` (read from ``path``), or a ValueError naming
    the file and the entry."""
    if not isinstance(meta["origin"], list | tuple):
        raise ValueError(f"{path}: origin must be a list [x, y, yaw], got {meta['origin']!r}")

    def number(key: str, default: object = None) -> Any:
        value = meta.get(key, default)
        values = value if key == "origin" else [value]
        # YAML reads ``true`` as a bool, which float() would take for 1.
        if any(isinstance(v, bool) for v in values):
            raise ValueError(f"{path}: {key} must be a number, got {value!r}")
        try:
            numbers = [float(v) for v in values]
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"{path}: {key} must be {'numbers' if key == 'origin' else 'a number'}, "
                f"got {value!r}"
            ) from exc
        if not all(math.isfinite(v) for v in numbers):
            raise ValueError(f"{path}: {key} must be finite, got {value!r}")
        return numbers if key == "origin" else numbers[0]

    resolution = _positive_resolution(path, meta["resolution"])
    origin_values = number("origin")
    negate = meta.get("negate", 0)
    if isinstance(negate, str) and negate.strip() in ("0", "1"):  # quoted in the YAML
        negate = int(negate)
    if negate not in (0, 1):  # True and False are 1 and 0 too
        raise ValueError(f"{path}: negate must be 0 or 1, got {negate!r}")
    occupied_thresh = number("occupied_thresh", 0.65)
    free_thresh = number("free_thresh", 0.196)
    if len(origin_values) != 3:
        raise ValueError(f"{path}: origin must be [x, y, yaw], got {meta['origin']}")
    mode = str(meta.get("mode", "trinary"))
    if mode not in MODES:
        raise ValueError(f"{path}: mode must be one of {MODES}, got {mode!r}")
    if not 0.0 <= free_thresh < occupied_thresh <= 1.0:
        raise ValueError(
            f"{path}: thresholds must satisfy 0 <= free_thresh < occupied_thresh <= 1, got "
            f"free_thresh {free_thresh} and occupied_thresh {occupied_thresh}"
        )
    origin = (origin_values[0], origin_values[1], origin_values[2])
    return _Header(resolution, origin, bool(negate), occupied_thresh, free_thresh, mode)


def _positive_resolution(path: Path, value: object) -> float:
    """A map's ``resolution`` entry as metres per cell, or a ValueError naming ``path``."""
    message = f"{path}: resolution must be a positive number of metres, got {value!r}"
    if isinstance(value, bool):  # YAML's true, which float() would take for 1
        raise ValueError(message)
    try:
        metres = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ValueError(message) from exc
    if not (math.isfinite(metres) and metres > 0):
        raise ValueError(message)
    return metres


def _map_meta(path: Path) -> dict[str, Any]:
    """The YAML mapping of a map, checked to hold the keys every map needs."""
    if path.is_dir():
        raise ValueError(f"{path} is a directory; give a map's .yaml file")
    if not path.is_file():
        raise FileNotFoundError(f"map file not found: {path}")
    meta = _read_yaml(path)
    if not isinstance(meta, dict):
        raise ValueError(f"{path} must be a YAML mapping with image, resolution and origin")
    missing = [key for key in ("image", "resolution", "origin") if key not in meta]
    if missing:
        raise ValueError(f"{path} lacks the key(s) {', '.join(missing)}")
    return meta


def _image_of(path: Path, meta: dict[str, Any]) -> Path:
    """The existing image file ``meta`` (read from ``path``) names."""
    named = meta["image"]
    if not isinstance(named, str) or not named.strip():
        raise ValueError(
            f"{path}: image must name the map's picture file (a PGM or PNG beside it), "
            f"got {named!r}"
        )
    image_path = Path(named)
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    if image_path.is_dir():
        raise ValueError(f"image {image_path} named by {path} is a folder; name the picture file")
    if not image_path.is_file():
        raise FileNotFoundError(f"image {image_path} named by {path} not found")
    return image_path


SIXTEEN_BIT_MODES = ("I;16", "I;16B", "I;16L", "I;16N", "I")
"""Pillow's modes of 16-bit greyscale images (PNGs of 16 bits a sample open as ``I``)."""


def grey_levels(image: Image.Image) -> NDArray[np.float64]:
    """The image's pixels as grey levels 0-255, as ``map_server`` reads them.

    Colour images are averaged to grey (Pillow's ``L``); 16-bit greyscale is
    scaled by 255 / 65535, where Pillow's ``L`` conversion would clip every
    value above 255 to white and read unknown grey as free.
    """
    if image.mode in SIXTEEN_BIT_MODES:
        return np.asarray(image, dtype=np.float64) * (255.0 / 65535.0)
    return np.asarray(image.convert("L"), dtype=np.float64)


def transparent(image: Image.Image) -> NDArray[np.bool_] | None:
    """Where the image is not opaque; None for an image without an alpha channel."""
    if "transparency" in image.info:  # a colour key (PNG's tRNS) rather than a channel
        image = image.convert("RGBA")
    if "A" not in image.getbands():
        return None
    return np.asarray(image.getchannel("A")) < 255


def pixels_to_cells(
    pixels: NDArray[np.float64],
    *,
    mode: str = "trinary",
    negate: bool = False,
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
    transparent: NDArray[np.bool_] | None = None,
) -> NDArray[np.int8]:
    """Convert grey levels (0..255, rows as in the image) to the ROS cell coding.

    ``transparent`` marks pixels that are not opaque: unknown in ``scale`` mode.
    """
    if mode == "raw":
        raw = np.where(pixels > OCCUPIED, UNKNOWN, pixels)
        return raw.astype(np.int8)
    occ = pixels / 255.0 if negate else (255.0 - pixels) / 255.0
    data = np.full(pixels.shape, UNKNOWN, dtype=np.int8)
    data[occ > occupied_thresh] = OCCUPIED
    data[occ < free_thresh] = FREE
    if mode == "scale":
        between = (occ >= free_thresh) & (occ <= occupied_thresh)
        ratio = (occ[between] - free_thresh) / (occupied_thresh - free_thresh)
        data[between] = np.rint(99 * ratio).astype(np.int8)
        if transparent is not None:
            data[transparent] = UNKNOWN
    return data


def save_map(grid: OccupancyGrid, yaml_path: str | Path, *, image_format: str = "pgm") -> Path:
    """Write ``grid`` as a ``map_server`` YAML plus a trinary PGM or PNG image.

    Cells ``>= 65`` are written black (0), free cells (``<= 19``) white (254),
    everything else grey (205), so :func:`load_map` reads the grid back exactly
    when it holds only -1, 0 and 100.

    The pair is written whole or not at all: both files go to temporary files
    beside their targets first and replace them only once both are complete,
    the image then the YAML, so that a failed write (a full disk, a folder
    without write permission) leaves an existing pair as it was. The folder
    must exist.

    Returns
    -------
    Path
        The image file written beside the YAML.

    Raises
    ------
    FileNotFoundError
        If the YAML's folder does not exist.
    ValueError
        If ``yaml_path`` does not end in ``.yaml`` or ``.yml``, or ends in the
        image's suffix (the image would overwrite it).
    OSError
        If a file cannot be written (nothing is replaced then).
    """
    if not isinstance(grid, OccupancyGrid):
        raise TypeError(f"grid must be an OccupancyGrid, got {type(grid).__name__}")
    if image_format not in FORMATS:
        raise ValueError(f"image_format must be 'pgm' or 'png', got {image_format!r}")
    path = Path(yaml_path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {path.parent} does not exist")
    image_path = path.with_suffix(f".{image_format}")
    if image_path == path:
        raise ValueError(
            f"yaml_path {str(path)!r} is where the {image_format} image would go (the image "
            "takes the YAML's name with its own suffix); give the YAML's path, ending in .yaml"
        )
    if not is_yaml_name(path):
        raise ValueError(
            f"yaml_path {str(path)!r} must end in .yaml (or .yml): map_server and load_map "
            "read the map from its YAML file"
        )
    pixels = np.full(grid.shape, PIXEL_UNKNOWN, dtype=np.uint8)
    pixels[grid.free()] = PIXEL_FREE
    pixels[grid.occupied()] = PIXEL_OCCUPIED
    meta = {
        "image": image_path.name,
        "resolution": float(grid.resolution),
        "origin": [float(v) for v in grid.origin],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
        "mode": "trinary",
    }
    image_partial = _partial(image_path)
    yaml_partial = _partial(path)
    try:
        with image_partial.open("wb") as handle:
            Image.fromarray(pixels[::-1]).save(handle, format=FORMATS[image_format])
            _sync(handle)
        _write_text(yaml_partial, yaml.safe_dump(meta, sort_keys=False))
        image_partial.replace(image_path)
        yaml_partial.replace(path)
    finally:
        image_partial.unlink(missing_ok=True)
        yaml_partial.unlink(missing_ok=True)
    return image_path


def _partial(path: Path) -> Path:
    """A temporary name beside ``path`` (hidden, unique to this process)."""
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


def _sync(handle: IO[bytes]) -> None:
    """Push ``handle``'s bytes to the disk, so that a rename after it publishes whole files."""
    handle.flush()
    os.fsync(handle.fileno())


def _write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` and sync it (the YAML half of :func:`save_map`)."""
    with path.open("wb") as handle:
        handle.write(text.encode("utf-8"))
        _sync(handle)
