"""Reading a tomosim recording back with rerun's own reader (``rerun.chunk.RrdReader``).

:func:`read_recording` streams the chunks of an ``.rrd`` file's recording
store (not the blueprint), keeps the entities a summary needs (the settings
and status, every scalar series on the ``step`` timeline, the ground truth and
the merged map, the merge log) and leaves the bulky per-step ones (poses,
scans, robot maps) unread.

A run killed while writing leaves a file without rerun's footer, and perhaps
with a last message cut short, which rerun's reader refuses whole. Such a
file is read up to its last whole message (rerun's own ``rerun rrd filter``
copies that part), and :attr:`RecordedRun.notes` says so. Only recordings of
the application ``tomosim`` are read.

:func:`recorded_views` reads the blueprint stored in the file: the views the
viewer opens with, and their entity filters.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray
from rerun.chunk import Chunk, RrdReader

from merging.grid import OccupancyGrid
from tomosim.recording.paths import (
    APPLICATION_ID,
    CONFIG,
    COVERAGE,
    MERGE,
    MERGE_LOG,
    MERGED_FRAME,
    PAIR_QUANTITIES,
    STATUS,
    STATUS_FINISHED,
    STEP_TIMELINE,
    TRUTH,
    pair_path,
)
from tomosim.team.merger import pair_order

READ_CONTENTS = (
    "+ /run/**",
    "+ /merge/**",
    "+ /team/**",
    f"+ /{MERGED_FRAME}/**",
    f"+ /{TRUTH}",
)
"""Entity path filters of what :func:`read_recording` reads."""
FLOAT32_DIGITS = 7
"""Significant digits of a float32 (cell sizes and origins are logged as float32)."""
RRD_MAGIC = b"RRF2"
"""The first bytes of an ``.rrd`` file of this rerun version."""
REPAIR_TIMEOUT_S = 300.0
"""Longest wait for ``rerun rrd filter`` to copy the whole part of a torn file."""
NO_FOOTER = "no footer"
"""Words of rerun's warning about a file that was never closed."""


@dataclass(frozen=True)
class Series:
    """One scalar entity over the ``step`` timeline, sorted by step."""

    steps: NDArray[np.int64]
    values: NDArray[np.float64]

    def last(self) -> float:
        """The value at the latest step (NaN when empty)."""
        return float(self.values[-1]) if len(self.values) else float("nan")

    def at(self, step: int) -> float | None:
        """The value logged at ``step``, or None."""
        where = np.flatnonzero(self.steps == step)
        return float(self.values[where[-1]]) if len(where) else None


@dataclass(frozen=True)
class RecordedRun:
    """What :func:`read_recording` found.

    Attributes
    ----------
    path : Path
        The file read.
    settings : dict
        The run's settings (``run/config``).
    series : dict of str to Series
        Every scalar entity (path without the leading ``/``).
    grids : dict of str to (int or None, OccupancyGrid)
        The latest grid of ``world/truth`` (step None: static) and ``world/merged/map``.
    poses : dict of str to (float, float, float)
        The latest planar transform ``(x, y, yaw)`` logged at an entity (for
        ``world/merged``: where the merged map's frame lies in the world).
    log : list of (int, str)
        The merge log's lines with their steps.
    status : str
        ``run/status``: how the run ended ("running" when it was cut off).
    notes : tuple of str
        What was wrong with the file itself (cut short, not closed).
    """

    path: Path
    settings: dict[str, Any]
    series: dict[str, Series]
    grids: dict[str, tuple[int | None, OccupancyGrid]]
    poses: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    log: list[tuple[int, str]] = field(default_factory=list)
    status: str = ""
    notes: tuple[str, ...] = ()

    @property
    def finished(self) -> bool:
        """Whether the run ended by itself and its recording was closed."""
        return self.status.startswith(STATUS_FINISHED) and not self.notes

    @property
    def last_step(self) -> int:
        """The latest step of the team coverage (0 when none was recorded)."""
        steps = self.coverage.steps
        return int(steps[-1]) if len(steps) else 0

    @property
    def coverage(self) -> Series:
        """Team coverage per step."""
        return self.series.get(COVERAGE, Series(np.zeros(0, np.int64), np.zeros(0)))

    @property
    def pairs(self) -> list[str]:
        """Names of the pairs with merge figures (``"r0-r1"``, ...), sorted."""
        names = set()
        for path in self.series:
            parts = path.split("/")
            if len(parts) == 3 and parts[0] == MERGE and parts[1] in PAIR_QUANTITIES:
                names.add(parts[2])
        return sorted(names, key=pair_order)

    def pair(self, name: str, quantity: str) -> Series:
        """One quantity of one pair (empty when never logged)."""
        empty = Series(np.zeros(0, np.int64), np.zeros(0))
        return self.series.get(pair_path(name, quantity), empty)


@dataclass(frozen=True)
class RecordedView:
    """One view of the blueprint stored in a recording.

    ``kind`` is rerun's class identifier (``"2D"``, ``"3D"``, ``"TimeSeries"``,
    ...), ``contents`` its entity filter expressions with ``$origin`` as stored.
    """

    name: str
    kind: str
    origin: str
    contents: tuple[str, ...]


def _rounded(value: float) -> float:
    """A float32 value as the decimal it was logged from (to float32 precision)."""
    return float(f"{value:.{FLOAT32_DIGITS}g}")


def _planar_angle(turn: dict[str, Any]) -> float:
    """The angle about ``+z`` of a logged axis-angle rotation about ``z``."""
    return float(turn["angle"]) * (1.0 if float(turn["axis"][2]) >= 0 else -1.0)


def _column(batch: pa.RecordBatch, name: str) -> list[Any]:
    """Column ``name`` as a list (all None when the chunk lacks it)."""
    if name in batch.schema.names:
        return list(batch.column(name).to_pylist())
    return [None] * batch.num_rows


def _images(batch: pa.RecordBatch) -> Iterable[tuple[int, NDArray[np.int8]]]:
    """``(row, cells)`` for every SegmentationImage row of a chunk (ROS values, row 0 first)."""
    buffers = batch.column("SegmentationImage:buffer")
    formats = batch.column("SegmentationImage:format").to_pylist()
    for row in range(batch.num_rows):
        if not buffers[row].is_valid or not formats[row]:
            continue
        shape = formats[row][0]
        blob = np.asarray(buffers[row].values[0].values.to_numpy(zero_copy_only=False), np.uint8)
        image = blob.reshape(int(shape["height"]), int(shape["width"]))
        yield row, np.ascontiguousarray(image).view(np.int8)


def _placements(batch: pa.RecordBatch) -> Iterable[tuple[int, tuple[float, float, float], float]]:
    """``(row, (x, y, yaw), scale)`` for every Transform3D row with a translation."""
    shifts = _column(batch, "Transform3D:translation")
    turns = _column(batch, "Transform3D:rotation_axis_angle")
    scales = _column(batch, "Transform3D:scale")
    for row, (shift, turn, scale) in enumerate(zip(shifts, turns, scales, strict=True)):
        if not shift:
            continue
        yaw = _planar_angle(turn[0]) if turn else 0.0
        size = float(scale[0][0]) if scale else 1.0
        yield row, (float(shift[0][0]), float(shift[0][1]), yaw), size


def _check_header(source: Path) -> None:
    """Raise ValueError unless ``source`` starts like an ``.rrd`` file."""
    with source.open("rb") as handle:
        head = handle.read(len(RRD_MAGIC))
    if head != RRD_MAGIC:
        raise ValueError(
            f"{source} is not a rerun recording (it does not start with {RRD_MAGIC!r}); "
            "give a .rrd file written by tomosim explore"
        )


def rerun_executable() -> str | None:
    """The ``rerun`` program installed with the rerun-sdk package (or on the PATH)."""
    try:
        import rerun_cli
    except ImportError:
        return shutil.which("rerun")
    suffix = ".exe" if sys.platform.startswith("win") else ""
    bundled = Path(rerun_cli.__file__).parent / f"rerun{suffix}"
    return str(bundled) if bundled.is_file() else shutil.which("rerun")


def _repair(source: Path, folder: Path) -> Path:
    """The whole messages of ``source`` copied to a file in ``folder`` by ``rerun rrd filter``."""
    copy = folder / source.name
    program = rerun_executable()
    if program is None:
        raise ValueError(
            f"{source} is cut short, and reading its intact part needs the rerun program: "
            "python -m pip install rerun-sdk"
        )
    command = [program, "rrd", "filter", str(source), "-o", str(copy)]
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, timeout=REPAIR_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ValueError(f"cannot read the intact part of {source}: {exc}") from exc
    if done.returncode != 0 or not copy.is_file():
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise ValueError(f"cannot read the intact part of {source}: {last}")
    return copy


def _open_reader(source: Path, *, name: Path | None = None) -> tuple[RrdReader, list[str]]:
    """A reader of ``source`` and notes about its state; refuses other applications.

    Messages call the file ``name`` (default ``source``): the user's file, when
    ``source`` is a repaired copy of it.
    """
    named = source if name is None else name
    notes: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            reader = RrdReader(source)
            stores = reader.recordings()
        except (RuntimeError, ValueError, OSError) as exc:
            raise _Torn(str(exc)) from exc
    if any(NO_FOOTER in str(w.message).lower() for w in caught):
        notes.append(f"{named} was not closed: the run was killed or crashed while recording")
    if not stores:
        raise ValueError(f"{named} holds no recording; give a .rrd file written by tomosim explore")
    application = stores[0].application_id
    if application != APPLICATION_ID:
        raise ValueError(
            f"{named} is a recording of the application {application!r}, not of "
            f"{APPLICATION_ID!r}; give a .rrd file written by tomosim explore"
        )
    return reader, notes


class _Torn(Exception):
    """rerun's reader refused a file (a last message cut short, or not a recording)."""


def _load(source: Path) -> tuple[list[Chunk], list[str]]:
    """Every chunk :func:`read_recording` needs, and notes about the file's state."""
    try:
        reader, notes = _open_reader(source)
    except _Torn as torn:
        with tempfile.TemporaryDirectory(prefix="tomosim-review-") as folder:
            copy = _repair(source, Path(folder))
            try:
                reader, _ = _open_reader(copy, name=source)
            except _Torn:
                raise ValueError(f"cannot read {source} as a rerun recording: {torn}") from None
            notes = [
                f"{source} is cut short (the run was killed while writing); "
                "read up to its last whole message"
            ]
            return _filtered(reader, source), notes
    return _filtered(reader, source), notes


def _filtered(reader: RrdReader, source: Path) -> list[Chunk]:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the footer warning was read in _open_reader
            return list(reader.stream().filter(content=list(READ_CONTENTS)))
    except Exception as exc:  # rerun's bindings raise their own error types
        raise ValueError(f"cannot read {source} as a rerun recording: {exc}") from exc


def read_recording(path: str | Path) -> RecordedRun:
    """Read the summary entities of a tomosim ``.rrd`` file (module docstring).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not a readable tomosim recording (the message says why).
    """
    source = Path(path)
    if source.is_dir():
        raise ValueError(f"{source} is a directory; give a .rrd recording file")
    if not source.is_file():
        raise FileNotFoundError(f"no such recording: {source}")
    _check_header(source)
    settings: dict[str, Any] = {}
    status = ""
    raw: dict[str, list[tuple[int, float]]] = {}
    images: dict[str, tuple[int | None, NDArray[np.int8]]] = {}
    placements: dict[str, tuple[int | None, tuple[tuple[float, float, float], float]]] = {}
    log: list[tuple[int, str]] = []
    chunks, notes = _load(source)
    for chunk in chunks:
        entity = chunk.entity_path.lstrip("/")
        batch = chunk.to_record_batch()
        names = batch.schema.names
        steps = _column(batch, STEP_TIMELINE)
        if "Scalars:scalars" in names:
            for step, values in zip(
                steps, batch.column("Scalars:scalars").to_pylist(), strict=True
            ):
                if step is not None and values:
                    raw.setdefault(entity, []).append((int(step), float(values[0])))
        if "TextDocument:text" in names:
            texts = [t for t in batch.column("TextDocument:text").to_pylist() if t]
            if texts and entity == CONFIG:
                settings = _settings(source, texts[-1][0])
            if texts and entity == STATUS:
                status = str(texts[-1][0])
        if "TextLog:text" in names and entity == MERGE_LOG:
            for step, texts in zip(steps, batch.column("TextLog:text").to_pylist(), strict=True):
                if step is not None and texts:
                    log.append((int(step), str(texts[0])))
        if "Transform3D:translation" in names:
            for row, pose, scale in _placements(batch):
                if _later(placements.get(entity), steps[row]):
                    placements[entity] = (_step(steps[row]), (pose, scale))
        if "SegmentationImage:buffer" in names:
            for row, cells in _images(batch):
                if _later(images.get(entity), steps[row]):
                    images[entity] = (_step(steps[row]), cells)
    series = {}
    for entity, points in raw.items():
        points.sort(key=lambda item: item[0])
        series[entity] = Series(
            np.array([p[0] for p in points], dtype=np.int64),
            np.array([p[1] for p in points], dtype=np.float64),
        )
    log.sort(key=lambda item: item[0])
    grids = {}
    for entity, (step, cells) in images.items():
        placed = placements.get(entity)
        origin, resolution = placed[1] if placed else ((0.0, 0.0, 0.0), 1.0)
        grids[entity] = (
            step,
            OccupancyGrid(
                cells,
                resolution=_rounded(resolution),
                origin=(_rounded(origin[0]), _rounded(origin[1]), _rounded(origin[2])),
            ),
        )
    poses = {entity: pose for entity, (_, (pose, _)) in placements.items() if entity not in images}
    return RecordedRun(source, settings, series, grids, poses, log, status, tuple(notes))


def _step(step: Any) -> int | None:
    return None if step is None else int(step)


def _later(known: tuple[int | None, Any] | None, step: Any) -> bool:
    """Whether a value logged at ``step`` replaces ``known`` (static values count as first)."""
    return known is None or step is None or (known[0] is not None and known[0] <= int(step))


def _settings(source: Path, text: str) -> dict[str, Any]:
    """``run/config`` parsed; ValueError naming the file when it is not a JSON object."""
    try:
        settings = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(
            f"{source}: its {CONFIG} is not JSON ({exc.msg}); "
            "the file was not written by tomosim explore or is damaged"
        ) from exc
    if not isinstance(settings, dict):
        raise ValueError(f"{source}: its {CONFIG} is not a JSON object of settings")
    return settings


def recorded_views(path: str | Path) -> list[RecordedView]:
    """The views of the blueprint stored in the ``.rrd`` file ``path``.

    Raises
    ------
    ValueError
        If the file holds no blueprint.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a file without footer still has its blueprint
        reader = RrdReader(Path(path))
        blueprints = reader.blueprints()
        if not blueprints:
            raise ValueError(f"{path} holds no blueprint")
        kinds: dict[str, tuple[str, str, str]] = {}
        contents: dict[str, tuple[str, ...]] = {}
        for chunk in reader.stream(store=blueprints[-1]):
            entity = chunk.entity_path
            batch = chunk.to_record_batch()
            names = batch.schema.names
            if "ViewBlueprint:class_identifier" in names:
                kind = _last(batch, "ViewBlueprint:class_identifier")
                name = _last(batch, "ViewBlueprint:display_name")
                origin = _last(batch, "ViewBlueprint:space_origin")
                kinds[entity] = (str(name), str(kind), str(origin))
            if "ViewContents:query" in names and entity.endswith("/ViewContents"):
                rows = [r for r in batch.column("ViewContents:query").to_pylist() if r]
                if rows:
                    contents[entity.removesuffix("/ViewContents")] = tuple(rows[-1])
    return [
        RecordedView(name, kind, origin, contents.get(entity, ("$origin/**",)))
        for entity, (name, kind, origin) in sorted(kinds.items())
    ]


def _last(batch: pa.RecordBatch, name: str) -> Any:
    values = [v for v in _column(batch, name) if v]
    return values[-1][0] if values else ""
