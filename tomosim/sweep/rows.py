"""One CSV row per finished episode, appended as episodes end and read back on resume."""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # not on POSIX: sweeps run without the results file's lock
    fcntl = None  # type: ignore[assignment]

import numpy as np

from tomosim.episode import EpisodeConfig, EpisodeMetrics, run_episode

TIMING_FIELDS = ("wall_seconds", "merge_seconds")
"""Columns that measure the machine, not the episode: they differ between runs."""
ROW_FIELDS = (
    "key", "world", "world_spec", "robots", "policy", "method", "seed", "steps_limit",
    "merge_interval", "coverage_target", "world_size", "comm_range", "team_settings", "steps",
    "coverage",
    "steps_to_target", "time_to_target_s", "stop_reason", "path_length_m", "path_lengths_m",
    "overlap_rate", "efficiency_m2_per_m", "merge_rounds", "pairs_accepted", "pairs_confirmed",
    "pairs_wrong", "pairs_gross_wrong", "pairs_gross_wrong_confirmed", "first_link_step",
    "linked_robots", "all_linked_step",
    "rotation_error_deg_median", "rotation_error_deg_max", "translation_error_m_median",
    "translation_error_m_max", "record", *TIMING_FIELDS,
)  # fmt: skip
"""Columns of the results file, in order."""
EARLIER_ROW_FIELDS = (
    tuple(name for name in ROW_FIELDS if name not in ("all_linked_step", "team_settings")),
    tuple(name for name in ROW_FIELDS if name != "team_settings"),
)
"""Columns of results files written by earlier versions, which a sweep still resumes: a
file keeps the columns it was started with, so its rows never miss a column that its
other rows hold (``all_linked_step`` is unknown, not empty, for their episodes; without
``team_settings`` a resumed file cannot say which team settings its rows ran with)."""
HEADER_BYTES = 4096
"""Bytes of a file read to check that it starts with the results header (about 700)."""


def episode_row(key: str, metrics: EpisodeMetrics, shared: dict[str, Any]) -> dict[str, Any]:
    """Flatten an episode's metrics into one row of :data:`ROW_FIELDS`."""
    settings = metrics.settings
    accepted = [pair for _, pair in metrics.accepted()]
    rotation = np.array([p.rotation_error_deg for p in accepted], dtype=float)
    translation = np.array([p.translation_error_m for p in accepted], dtype=float)
    stats = metrics.merge_stats()
    target = metrics.steps_to(float(settings["coverage_target"]))
    return {
        "key": key,
        "world": settings["world"],
        "world_spec": settings["world_spec"],
        "robots": settings["robots"],
        "policy": settings["policy"],
        "method": settings["method"] if settings["merge"] else "none",
        "seed": settings["seed"],
        "steps_limit": shared["steps_limit"],
        "merge_interval": shared["merge_interval"],
        "coverage_target": shared["coverage_target"],
        "world_size": shared["world_size"],
        "comm_range": shared["comm_range"],
        "team_settings": team_text(settings.get("team", {})),
        "steps": metrics.steps,
        "coverage": round(metrics.coverage, 6),
        "steps_to_target": "" if target is None else target,
        "time_to_target_s": "" if target is None else round(target * metrics.dt, 3),
        "stop_reason": metrics.stop_reason,
        "path_length_m": round(metrics.path_length, 3),
        "path_lengths_m": ";".join(f"{p:.3f}" for p in metrics.path_lengths),
        "overlap_rate": round(metrics.overlap_rate, 6),
        "efficiency_m2_per_m": _round(metrics.efficiency, 4),
        "merge_rounds": stats.rounds,
        "pairs_accepted": stats.accepted,
        "pairs_confirmed": stats.confirmed,
        "pairs_wrong": stats.wrong,
        "pairs_gross_wrong": stats.gross_wrong,
        "pairs_gross_wrong_confirmed": stats.gross_wrong_confirmed,
        "first_link_step": "" if stats.first_link_step is None else stats.first_link_step,
        "linked_robots": stats.linked_robots,
        "all_linked_step": "" if stats.all_linked_step is None else stats.all_linked_step,
        "rotation_error_deg_median": _stat(np.median, rotation),
        "rotation_error_deg_max": _stat(np.max, rotation),
        "translation_error_m_median": _stat(np.median, translation),
        "translation_error_m_max": _stat(np.max, translation),
        "record": metrics.record or "",
        "wall_seconds": round(metrics.wall_seconds, 3),
        "merge_seconds": round(sum(m.seconds for m in metrics.merges), 3),
    }


def team_text(others: dict[str, Any]) -> str:
    """A row's ``team_settings``: the episode's team settings changed from the defaults
    but those with columns or options of their own
    (:func:`tomosim.episode.config.other_team_settings`), ``name=value`` joined by
    ``"; "``; empty for the defaults."""
    return "; ".join(f"{name}={value}" for name, value in others.items())


def _round(value: float, digits: int) -> float | str:
    return round(value, digits) if math.isfinite(value) else ""


def _stat(function: Any, values: np.ndarray) -> float | str:
    finite = values[np.isfinite(values)]
    return round(float(function(finite)), 6) if len(finite) else ""


def run_one(
    key: str,
    config: EpisodeConfig,
    shared: dict[str, Any],
    progress: Callable[[int, float], None] | None = None,
) -> dict[str, Any]:
    """Run one episode and return its row: the unit of work every executor ships.

    ``progress(step, team_coverage)`` is called after every step, if given.
    """
    return episode_row(key, run_episode(config, progress=progress), shared)


class SweepLockedError(ValueError):
    """Another sweep is writing the results file."""


class ResultsFileError(OSError):
    """The results file cannot be written; the message names it."""


class ResultsFile:
    """The CSV file a sweep appends to.

    Every row is flushed and synced to disk as soon as it is written. On
    opening, a last line cut short by a killed process is dropped, so that
    the file holds only whole rows. A sweep holds the file's lock
    (:meth:`locked`) while it runs, so that a second sweep on the same file
    refuses instead of running every episode again and writing duplicates.
    """

    __slots__ = ("path",)

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold an exclusive lock on the file (created empty if missing) while in the block.

        The lock is the operating system's (``flock``): it ends with the
        process, even one killed with SIGKILL, so no stale lock is left.

        Raises
        ------
        SweepLockedError
            If another process holds it.
        ResultsFileError
            If the file cannot be opened for writing.
        """
        try:
            handle = self.path.open("a")
        except OSError as exc:
            raise ResultsFileError(
                f"cannot write {self.path}: {exc.strerror or exc}; choose another --out"
            ) from exc
        try:
            if fcntl is not None:
                try:
                    fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    raise SweepLockedError(
                        f"{self.path} is being written by another sweep (it holds the file's "
                        "lock); wait for that sweep to end or choose another --out"
                    ) from None
            yield
        finally:
            handle.close()  # releases the lock

    def rows(self) -> list[dict[str, str]]:
        """The whole rows in the file (none when it does not exist)."""
        if not self.path.is_file():
            return []
        self.check_columns()
        with self.path.open(newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            return [row for row in reader if None not in row.values() and None not in row]

    def check_columns(self) -> None:
        """Raise ValueError unless the file is missing, empty or starts with the header of
        sweep results (:data:`ROW_FIELDS`, or one of :data:`EARLIER_ROW_FIELDS`); reads
        only its first line."""
        self.columns()

    def columns(self) -> tuple[str, ...]:
        """The file's columns: :data:`ROW_FIELDS` for a new or empty file, else its header,
        one of :data:`EARLIER_ROW_FIELDS` for a file an earlier version started.

        Raises
        ------
        ValueError
            If the file is not a sweep results file.
        """
        if not self.path.is_file():
            return ROW_FIELDS
        with self.path.open("rb") as handle:
            first = handle.readline(HEADER_BYTES)
        if not first:
            return ROW_FIELDS
        try:
            header = tuple(next(csv.reader([first.decode("utf-8").rstrip("\r\n")]), []))
        except UnicodeDecodeError:
            header = ()
        if header != ROW_FIELDS and header not in EARLIER_ROW_FIELDS:
            raise ValueError(
                f"{self.path} is not a tomosim sweep results file (its columns differ); "
                "it was left as it was; choose another --out"
            )
        return header

    def repair(self) -> int:
        """Drop a trailing partial line left by a killed writer; returns rows kept.

        Only a sweep results file is touched: any other file raises ValueError first
        (:meth:`check_columns`), whole.
        """
        if not self.path.is_file():
            return 0
        self.check_columns()
        text = self.path.read_bytes()
        if text and not text.endswith(b"\n"):
            os.truncate(self.path, text.rfind(b"\n") + 1)
        return len(self.rows())

    def append(self, row: dict[str, Any]) -> None:
        """Append one row (writing the header first into a new file), in the file's own
        columns (:meth:`columns`): a column an earlier version's file lacks is left out."""
        new = not self.path.is_file() or self.path.stat().st_size == 0
        buffer = io.StringIO()
        writer = csv.DictWriter(
            buffer, fieldnames=self.columns(), lineterminator="\n", extrasaction="ignore"
        )
        if new:
            writer.writeheader()
        writer.writerow(row)
        with self.path.open("a", newline="") as handle:
            handle.write(buffer.getvalue())
            handle.flush()
            os.fsync(handle.fileno())
