"""Many seeded episodes at once: a grid of worlds, team sizes, merge methods and seeds.

:func:`run_sweep` runs every episode of a :class:`SweepPlan` with a local
process pool or on Ray, appending one row per finished episode to a CSV file,
so that a killed sweep loses nothing and a resumed one skips what is done; a
sweep locks its file, so that two sweeps never write one file.
"""

from tomosim.sweep.executors import EXECUTORS, WorkerDied, run_sweep
from tomosim.sweep.plan import NO_MERGE, Episode, SweepPlan
from tomosim.sweep.rows import ROW_FIELDS, ResultsFile, SweepLockedError, episode_row, run_one

__all__ = [
    "EXECUTORS",
    "NO_MERGE",
    "ROW_FIELDS",
    "Episode",
    "ResultsFile",
    "SweepLockedError",
    "SweepPlan",
    "WorkerDied",
    "episode_row",
    "run_one",
    "run_sweep",
]
