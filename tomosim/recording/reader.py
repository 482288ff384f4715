"""Reading a tomosim recording back with rerun's own reader (``rerun.chunk.RrdReader``).

:func:`read_recording` streams the chunks of an ``.rrd`` file's recording
store (not the blueprint), keeps the entities a summary needs (the settings,
every scalar series on the ``step`` timeline, the ground truth and the merged
map, the merge log) and leaves the bulky per-step ones (poses, scans, robot
maps) unread.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray
from rerun.chunk import RrdReader

from merging.grid import OccupancyGrid
from tomosim.recording.paths import (
    CONFIG,
    COVERAGE,
    MERGE_LOG,
    MERGED,
    PAIR_QUANTITIES,
    STEP_TIMELINE,
    TRUTH,
)

READ_CONTENTS = ("+ /run/**", "+ /merge/**", "+ /team/**", f"+ /{MERGED}", f"+ /{TRUTH}")
"""Entity path filters of what :func:`read_recording` reads."""
FLOAT32_DIGITS = 7
"""Significant digits of a float32 (cell sizes and origins are logged as float32)."""


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
        The latest grid of ``world/truth`` (step None: static) and ``maps/merged``.
    poses : dict of str to (float, float, float)
        The latest planar transform ``(x, y, yaw)`` logged at an entity (for
        ``maps/merged``: where the merged map's frame lies in the world).
    log : list of (int, str)
        The merge log's lines with their steps.
    """

    path: Path
    settings: dict[str, Any]
    series: dict[str, Series]
    grids: dict[str, tuple[int | None, OccupancyGrid]]
    poses: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    log: list[tuple[int, str]] = field(default_factory=list)

    @property
    def coverage(self) -> Series:
        """Team coverage per step."""
        return self.series.get(COVERAGE, Series(np.zeros(0, np.int64), np.zeros(0)))

    @property
    def pairs(self) -> list[str]:
        """Names of the pairs with merge figures (``"r0-r1"``, ...), sorted."""
        names = {path.split("/")[1] for path in self.series if path.startswith("merge/")}
        return sorted(n for n in names if "-" in n)

    def pair(self, name: str, quantity: str) -> Series:
        """One quantity of one pair (empty when never logged)."""
        if quantity not in PAIR_QUANTITIES:
            raise ValueError(f"unknown pair quantity {quantity!r}; choose one of {PAIR_QUANTITIES}")
        empty = Series(np.zeros(0, np.int64), np.zeros(0))
        return self.series.get(f"merge/{name}/{quantity}", empty)


def _rounded(value: float) -> float:
    """A float32 value as the decimal it was logged from (to float32 precision)."""
    return float(f"{value:.{FLOAT32_DIGITS}g}")


def _planar_angle(turn: dict[str, Any]) -> float:
    """The angle about ``+z`` of a logged axis-angle rotation about ``z``."""
    return float(turn["angle"]) * (1.0 if float(turn["axis"][2]) >= 0 else -1.0)


def _grid_rows(batch: pa.RecordBatch) -> Iterable[tuple[int, OccupancyGrid]]:
    """``(row, grid)`` for every GridMap row of a chunk."""
    data = batch.column("GridMap:data")
    formats = batch.column("GridMap:format").to_pylist()
    sizes = batch.column("GridMap:cell_size").to_pylist()
    names = batch.schema.names
    origins: list[Any] = (
        batch.column("GridMap:translation").to_pylist()
        if "GridMap:translation" in names
        else [None] * len(sizes)
    )
    turns: list[Any] = (
        batch.column("GridMap:rotation_axis_angle").to_pylist()
        if "GridMap:rotation_axis_angle" in names
        else [None] * len(sizes)
    )
    for row in range(batch.num_rows):
        if not data[row].is_valid or not formats[row]:
            continue
        shape = formats[row][0]
        blob = np.asarray(data[row].values[0].values.to_numpy(zero_copy_only=False), np.uint8)
        image = blob.reshape(int(shape["height"]), int(shape["width"]))
        cells = np.ascontiguousarray(image[::-1]).view(np.int8)
        shift, turn = origins[row], turns[row]
        corner = shift[0] if shift else (0.0, 0.0, 0.0)
        yaw = _planar_angle(turn[0]) if turn else 0.0
        origin = (_rounded(corner[0]), _rounded(corner[1]), _rounded(yaw))
        yield row, OccupancyGrid(cells, resolution=_rounded(sizes[row][0]), origin=origin)


def read_recording(path: str | Path) -> RecordedRun:
    """Read the summary entities of a tomosim ``.rrd`` file (module docstring).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not a readable recording.
    """
    source = Path(path)
    if not source.is_file():
        raise FileNotFoundError(f"no such recording: {source}")
    try:
        stream = RrdReader(source).stream().filter(content=list(READ_CONTENTS))
        chunks = list(stream)
    except Exception as exc:  # rerun's bindings raise their own error types
        raise ValueError(f"cannot read {source} as a rerun recording: {exc}") from exc
    settings: dict[str, Any] = {}
    raw: dict[str, list[tuple[int, float]]] = {}
    grids: dict[str, tuple[int | None, OccupancyGrid]] = {}
    poses: dict[str, tuple[int, tuple[float, float, float]]] = {}
    log: list[tuple[int, str]] = []
    for chunk in chunks:
        entity = chunk.entity_path.lstrip("/")
        batch = chunk.to_record_batch()
        names = batch.schema.names
        steps = (
            batch.column(STEP_TIMELINE).to_pylist()
            if STEP_TIMELINE in names
            else [None] * batch.num_rows
        )
        if "Scalars:scalars" in names:
            for step, values in zip(
                steps, batch.column("Scalars:scalars").to_pylist(), strict=True
            ):
                if step is not None and values:
                    raw.setdefault(entity, []).append((int(step), float(values[0])))
        if "TextDocument:text" in names and entity == CONFIG:
            texts = batch.column("TextDocument:text").to_pylist()
            if texts and texts[-1]:
                settings = json.loads(texts[-1][0])
        if "TextLog:text" in names and entity == MERGE_LOG:
            for step, texts in zip(steps, batch.column("TextLog:text").to_pylist(), strict=True):
                if step is not None and texts:
                    log.append((int(step), str(texts[0])))
        if "Transform3D:translation" in names:
            shifts = batch.column("Transform3D:translation").to_pylist()
            turns = (
                batch.column("Transform3D:rotation_axis_angle").to_pylist()
                if "Transform3D:rotation_axis_angle" in names
                else [None] * batch.num_rows
            )
            for step, shift, turn in zip(steps, shifts, turns, strict=True):
                if step is None or not shift or (entity in poses and poses[entity][0] > step):
                    continue
                yaw = _planar_angle(turn[0]) if turn else 0.0
                poses[entity] = (int(step), (float(shift[0][0]), float(shift[0][1]), yaw))
        if "GridMap:data" in names:
            for row, grid in _grid_rows(batch):
                step = steps[row]
                known = grids.get(entity)
                if known is None or (step is not None and (known[0] or 0) <= step):
                    grids[entity] = (None if step is None else int(step), grid)
    series = {}
    for entity, points in raw.items():
        points.sort(key=lambda item: item[0])
        series[entity] = Series(
            np.array([p[0] for p in points], dtype=np.int64),
            np.array([p[1] for p in points], dtype=np.float64),
        )
    log.sort(key=lambda item: item[0])
    placed = {entity: pose for entity, (_, pose) in poses.items()}
    return RecordedRun(source, settings, series, grids, placed, log)
