"""The study's episodes as sweeps: one results file per world, resumable.

A world's episodes are every combination of team size, policy, merge method
and seed, less those whose outcome another episode already gives: a robot
that is linked to nobody explores alone, and every policy then chooses its
targets as ``nearest`` does (``tests/tomosim/exploration/test_coordination.py``), so

* a team of one runs with merging off only (its time is every method's), and
* merging off runs with one policy only (its time is every policy's),

both with the study's own policy (:attr:`Grid.alone`); and with a
communication range merging off is left out too (it is the same without
one). The rows go to ``<folder>/episodes_<label>.csv``
(``episodes_<label>_comm<range>m.csv`` with a range: the study's own
episode rows, not the world's map) as episodes finish (:func:`tomosim.sweep.run_sweep`),
so a killed study loses at most the episodes running, and the next run skips
what is done.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from exploration_study.worlds import StudyWorld
from tomosim.sweep import NO_MERGE, ResultsFile, SweepPlan, run_sweep
from tomosim.team import TeamConfig


@dataclass(frozen=True, slots=True)
class Grid:
    """What the study varies within each world."""

    robots: tuple[int, ...]
    policies: tuple[str, ...]
    methods: tuple[str, ...]
    seeds: tuple[int, ...]
    alone: str
    """The policy of the episodes in which no robot is linked (module docstring)."""
    comm_range: float | None = None
    """Metres over which robots talk (None: unlimited)."""
    team: TeamConfig = field(default_factory=TeamConfig)
    """The team's settings (``--team``); its communication range is :attr:`comm_range`."""


def plans(world: StudyWorld, grid: Grid) -> list[SweepPlan]:
    """The sweeps of one world (module docstring); all share one results file."""
    common: dict[str, Any] = {
        "worlds": (world.spec,),
        "seeds": grid.seeds,
        "steps": world.steps,
        "team": replace(grid.team, comms=replace(grid.team.comms, range=grid.comm_range)),
    }
    out = []
    teams = tuple(n for n in grid.robots if n > 1)
    merging = tuple(m for m in grid.methods if m != NO_MERGE)
    if grid.comm_range is not None:
        if teams and merging and grid.policies:
            out.append(SweepPlan(robots=teams, policies=grid.policies, methods=merging, **common))
        return out
    alone = tuple(n for n in grid.robots if n == 1)
    if alone:
        out.append(SweepPlan(robots=alone, policies=(grid.alone,), methods=(NO_MERGE,), **common))
    if teams and NO_MERGE in grid.methods:
        out.append(SweepPlan(robots=teams, policies=(grid.alone,), methods=(NO_MERGE,), **common))
    if teams and merging and grid.policies:
        out.append(SweepPlan(robots=teams, policies=grid.policies, methods=merging, **common))
    return out


def results_path(folder: Path, world: StudyWorld, comm_range: float | None = None) -> Path:
    """Where a world's rows go (with a communication range, a file of their own)."""
    suffix = "" if comm_range is None else f"_comm{comm_range:g}m"
    return folder / f"episodes_{world.label}{suffix}.csv"


def run_world(
    world: StudyWorld, grid: Grid, folder: Path, *, executor: str, workers: int | None
) -> int:
    """Run the world's pending episodes; returns how many ran."""
    path = results_path(folder, world, grid.comm_range)

    def progress(row: dict[str, object]) -> None:
        reached = row["time_to_target_s"] or "-"
        print(
            f"  {world.label} {str(row['key']).split('|', 1)[1]}: "
            f"90 % at {reached} s, coverage {row['coverage']}, {row['wall_seconds']} s wall",
            file=sys.stderr,
            flush=True,
        )

    ran = 0
    for plan in plans(world, grid):
        outcome = run_sweep(
            plan, path, executor=executor, workers=workers, resume=True, progress=progress
        )
        ran += outcome.ran
    return ran


def read_rows(
    folder: Path, worlds: Sequence[StudyWorld], comm_range: float | None = None
) -> dict[str, list[dict[str, str]]]:
    """Every world's rows so far (with ``comm_range``), by label."""
    return {w.label: ResultsFile(results_path(folder, w, comm_range)).rows() for w in worlds}


def progress(world: StudyWorld, grids: Sequence[Grid], folder: Path) -> tuple[int, int]:
    """``(done, planned)``: the world's episodes of ``grids`` already in its results files."""
    planned: dict[Path, set[str]] = {}
    for grid in grids:
        path = results_path(folder, world, grid.comm_range)
        keys = planned.setdefault(path, set())
        keys.update(e.key for plan in plans(world, grid) for e in plan.episodes())
    done = 0
    for path, keys in planned.items():
        done += len(keys & {row["key"] for row in ResultsFile(path).rows()})
    return done, sum(len(keys) for keys in planned.values())
