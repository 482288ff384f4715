"""Figures of the study: time to the coverage target over seeds, speed-ups, the oracle's share.

An episode that never reached the target counts as ``inf`` (it took longer
than its cap), so a median over seeds is finite only when more than half the
episodes reached the target (of an even number, the median of two middle times
one of which is ``inf`` is ``inf``). Spreads are the range (min-max) over seeds.

* **speed-up** of a method over merging off: ``T_none / T_method`` of the
  medians;
* **share of the oracle's speed-up** the tomographic merger reaches:
  ``(T_none - T_tomographic) / (T_none - T_oracle)``, 1 when it is as fast as
  merging with the true start poses, 0 when no faster than no merging.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from tomosim.sweep import NO_MERGE

ORACLE = "oracle"
"""The known-poses bound's method name."""
TOMOGRAPHIC = "tomographic"
"""The default merger's method name."""


@dataclass(frozen=True, slots=True)
class Cell:
    """The episodes of one world, team size, policy and method.

    Attributes
    ----------
    times : tuple of float
        Simulated seconds to the target per seed, ``inf`` when not reached,
        in seed order.
    seeds : tuple of int
    path_length, overlap_rate : float
        Medians over seeds: metres the team travelled, final overlap rate.
    wrong, gross_wrong, gross_wrong_confirmed, accepted : int
        Accepted merges beyond the accuracy bar, false matches, false matches
        that were also confirmed (and so linked maps), all accepted; summed
        over seeds.
    first_links : tuple of float
        Per seed (same order), the step of the first merge round that linked
        two maps, NaN when none did.
    all_links : tuple of float
        Per seed (same order), the step of the first merge round that linked
        every robot's map into one, NaN when none did; empty when the results
        file predates the column (unknown, not never).
    """

    times: tuple[float, ...]
    seeds: tuple[int, ...]
    path_length: float
    overlap_rate: float
    wrong: int
    gross_wrong: int
    gross_wrong_confirmed: int
    accepted: int
    first_links: tuple[float, ...] = ()
    all_links: tuple[float, ...] = ()

    @property
    def median(self) -> float:
        """Median time over seeds (``inf`` when half of them or fewer reached the target)."""
        return statistics.median(self.times) if self.times else math.nan

    @property
    def reached(self) -> int:
        """Episodes that reached the target."""
        return sum(1 for t in self.times if math.isfinite(t))

    @property
    def spread(self) -> tuple[float, float]:
        """``(min, max)`` over seeds."""
        return (min(self.times), max(self.times)) if self.times else (math.nan, math.nan)


def _number(text: str) -> float:
    return float(text) if text else math.nan


def cells(rows: Iterable[dict[str, str]]) -> dict[tuple[int, str, str], Cell]:
    """One world's rows grouped by ``(robots, policy, method)``."""
    groups: dict[tuple[int, str, str], list[dict[str, str]]] = {}
    for row in rows:
        groups.setdefault((int(row["robots"]), row["policy"], row["method"]), []).append(row)
    out = {}
    for key, mine in groups.items():
        mine.sort(key=lambda r: int(r["seed"]))
        times = tuple(_number(r["time_to_target_s"]) if r["time_to_target_s"] else math.inf
                      for r in mine)  # fmt: skip
        out[key] = Cell(
            times=times,
            seeds=tuple(int(r["seed"]) for r in mine),
            path_length=statistics.median(_number(r["path_length_m"]) for r in mine),
            overlap_rate=statistics.median(_number(r["overlap_rate"]) for r in mine),
            wrong=sum(int(r["pairs_wrong"]) for r in mine),
            gross_wrong=sum(int(r["pairs_gross_wrong"]) for r in mine),
            gross_wrong_confirmed=sum(int(r["pairs_gross_wrong_confirmed"]) for r in mine),
            accepted=sum(int(r["pairs_accepted"]) for r in mine),
            first_links=tuple(_number(r.get("first_link_step", "")) for r in mine),
            all_links=tuple(_number(r["all_linked_step"]) for r in mine)
            if all("all_linked_step" in r for r in mine)
            else (),
        )
    return out


def lookup(
    table: dict[tuple[int, str, str], Cell], robots: int, policy: str, method: str
) -> Cell | None:
    """The cell of a team. Where no robot is ever linked (one robot, or merging off) the
    policy makes no difference (:mod:`exploration_study.runs`): any policy's cell stands for
    all, and a robot alone stands for every method."""
    if robots == 1 or method == NO_MERGE:
        own = table.get((robots, policy, NO_MERGE))
        if own is not None:
            return own
        return next((c for (n, _, m), c in table.items() if n == robots and m == NO_MERGE), None)
    return table.get((robots, policy, method))


def speedup(none: float, method: float) -> float:
    """``none / method``; NaN when either is missing or the method never got there."""
    if not (math.isfinite(method) and method > 0) or math.isnan(none):
        return math.nan
    return none / method


def oracle_share(none: float, tomographic: float, oracle: float) -> float:
    """``(none - tomographic) / (none - oracle)`` (module docstring); NaN when undefined."""
    values = (none, tomographic, oracle)
    if not all(math.isfinite(v) for v in values) or none - oracle <= 0:
        return math.nan
    return (none - tomographic) / (none - oracle)


POOLED_SEED_STRIDE = 1_000_000
"""Pooled cells number seeds ``world index * stride + seed``, so that the same seed of two
worlds (different start poses) stays two episodes."""


def pooled(tables: Sequence[dict[tuple[int, str, str], Cell]], robots: int, policy: str,
           method: str) -> Cell | None:  # fmt: skip
    """The cells of several worlds as one (seeds of all worlds together)."""
    found = [c for t in tables if (c := lookup(t, robots, policy, method)) is not None]
    if not found:
        return None
    return Cell(
        times=tuple(t for c in found for t in c.times),
        seeds=tuple(k * POOLED_SEED_STRIDE + s for k, c in enumerate(found) for s in c.seeds),
        path_length=statistics.median(c.path_length for c in found),
        overlap_rate=statistics.median(c.overlap_rate for c in found),
        wrong=sum(c.wrong for c in found),
        gross_wrong=sum(c.gross_wrong for c in found),
        gross_wrong_confirmed=sum(c.gross_wrong_confirmed for c in found),
        accepted=sum(c.accepted for c in found),
        first_links=tuple(step for c in found for step in c.first_links),
        all_links=tuple(step for c in found for step in c.all_links)
        if all(c.all_links or not c.seeds for c in found)
        else (),
    )


def paired_ratios(first: Cell, second: Cell) -> list[float]:
    """``first / second`` time per seed both ran (the same start poses), finite ones only."""
    mine = dict(zip(first.seeds, first.times, strict=True))
    out = []
    for seed, time in zip(second.seeds, second.times, strict=True):
        if seed in mine and math.isfinite(mine[seed]) and math.isfinite(time) and time > 0:
            out.append(mine[seed] / time)
    return out


def on_common_seeds(found: Sequence[Cell | None]) -> list[Cell | None]:
    """The cells restricted to the seeds all of them ran, so that they compare like with like
    (a cell that is None stays None)."""
    present = [c for c in found if c is not None]
    if not present:
        return list(found)
    shared = set(present[0].seeds).intersection(*(c.seeds for c in present[1:]))
    out: list[Cell | None] = []
    for cell in found:
        if cell is None:
            out.append(None)
            continue
        keep = [k for k, seed in enumerate(cell.seeds) if seed in shared]
        out.append(
            Cell(
                times=tuple(cell.times[k] for k in keep),
                seeds=tuple(cell.seeds[k] for k in keep),
                path_length=cell.path_length,
                overlap_rate=cell.overlap_rate,
                wrong=cell.wrong,
                gross_wrong=cell.gross_wrong,
                gross_wrong_confirmed=cell.gross_wrong_confirmed,
                accepted=cell.accepted,
                first_links=tuple(cell.first_links[k] for k in keep) if cell.first_links else (),
                all_links=tuple(cell.all_links[k] for k in keep) if cell.all_links else (),
            )
        )
    return out
