"""The summary ``tomosim explore`` prints, and the per-pair tables ``tomosim review`` shares.

Both commands describe merge rounds the same way: per pair, how many of the
rounds' estimates the merger accepted and how many were confirmed (only
confirmed ones link maps), and the rotation and translation errors of the
accepted ones against the simulator's truth (:mod:`tomosim.team.quality`); and the exploration
figures the same way (time to the target, path lengths, each robot's
coverage, the overlap rate): from the episode's metrics for ``explore``, from
the recording's ``team/`` series for ``review`` (:func:`recorded_figures`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tomosim.episode import DEFAULT_COVERAGE_TARGET, EpisodeMetrics
from tomosim.recording import RecordedRun, Series
from tomosim.recording.paths import (
    OVERLAP_RATE,
    PATH_LENGTH_TOTAL,
    path_length_path,
    robot_coverage_path,
)
from tomosim.team import pair_order


@dataclass(frozen=True, slots=True)
class PairSummary:
    """One pair's merge figures over an episode.

    ``accepted_errors`` and ``confirmed_errors`` hold ``(rotation_deg,
    translation_m)`` of the estimates the merger accepted, and of those also
    confirmed (the ones that linked maps).
    """

    name: str
    rounds: int
    accepted_errors: tuple[tuple[float, float], ...]
    confirmed_errors: tuple[tuple[float, float], ...]


DEFAULT_TARGET = DEFAULT_COVERAGE_TARGET
"""Coverage target assumed for a recording whose settings do not name one."""
DEFAULT_DT = 0.1
"""Simulated seconds per step assumed for a recording whose settings do not name them."""


def summarise_pairs(
    rows: Sequence[tuple[str, bool, bool, float, float]],
) -> list[PairSummary]:
    """Group ``(pair, accepted, confirmed, rotation_deg, translation_m)`` rows by pair."""
    out = []
    for name in sorted({row[0] for row in rows}, key=pair_order):
        mine = [row for row in rows if row[0] == name]
        out.append(
            PairSummary(
                name=name,
                rounds=len(mine),
                accepted_errors=tuple((row[3], row[4]) for row in mine if row[1]),
                confirmed_errors=tuple((row[3], row[4]) for row in mine if row[1] and row[2]),
            )
        )
    return out


def _stats(values: Sequence[float], digits: int) -> str:
    """``median / max`` of finite ``values`` (``-`` when there are none)."""
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "-"
    return f"{float(np.median(finite)):.{digits}f} / {max(finite):.{digits}f}"


def pair_table(pairs: Sequence[PairSummary]) -> str:
    """Per pair, the accepted and the confirmed estimates and their errors against the truth."""
    lines = [
        f"{'pair':<7}{'estimates':<11}{'count':>7}"
        f"{'rotation err [deg]':>22}{'translation err [m]':>22}",
        f"{'':<25}{'median / max':>22}{'median / max':>22}",
    ]
    for p in pairs:
        for label, errors in (("accepted", p.accepted_errors), ("confirmed", p.confirmed_errors)):
            lines.append(
                f"{p.name:<7}{label:<11}{f'{len(errors)}/{p.rounds}':>7}"
                f"{_stats([e[0] for e in errors], 2):>22}{_stats([e[1] for e in errors], 3):>22}"
            )
    return "\n".join(lines)


def episode_rows(metrics: EpisodeMetrics) -> list[tuple[str, bool, bool, float, float]]:
    """The ``(pair, accepted, confirmed, rotation, translation)`` rows of every round."""
    return [
        (p.name, p.accepted, p.confirmed, p.rotation_error_deg, p.translation_error_m)
        for merge in metrics.merges
        for p in merge.pairs
    ]


def settings_line(s: Mapping[str, Any]) -> str:
    """A run's settings in one line, as ``tomosim explore`` and ``tomosim review`` head
    their reports: the world, the team, its policy, merging, the reach of its radios."""
    merging = "no merging"
    if s["merge"]:
        unlinked = s.get("unlinked_merge_interval", s["merge_interval"])
        sooner = f", {unlinked} while unlinked" if unlinked < s["merge_interval"] else ""
        merging = f"merging every {s['merge_interval']} steps{sooner} ({s['method']})"
    policy = f"{s['policy']} policy, " if s.get("policy") else ""
    reach = ""
    if s.get("comm_range") is not None:
        sight = " in line of sight" if s.get("line_of_sight") else ""
        reach = f", talking within {s['comm_range']:g} m{sight}"
    robots = f"{s['robots']} robot{'' if s['robots'] == 1 else 's'}"
    return f"world {s['world']}, {robots}, {policy}{merging}{reach}, seed {s['seed']}"


def render_summary(metrics: EpisodeMetrics) -> str:
    """The text ``tomosim explore`` ends with."""
    s = metrics.settings
    target = metrics.steps_to(float(s["coverage_target"]))
    reached = (
        "not reached"
        if target is None
        else f"reached at step {target}, {target * metrics.dt:.1f} s"
    )
    lines = [
        settings_line(s),
        "",
        f"{'steps':<18}{metrics.steps} ({metrics.sim_seconds:.1f} s simulated, "
        f"{metrics.wall_seconds:.1f} s wall clock)",
        f"{'stopped':<18}{metrics.stop_reason}",
        f"{'team coverage':<18}{metrics.coverage:.3f} "
        f"(target {s['coverage_target']:.2f} {reached})",
    ]
    if metrics.path_lengths:
        each = ", ".join(f"r{k} {p:.1f}" for k, p in enumerate(metrics.path_lengths))
        own = ", ".join(f"r{k} {c:.2f}" for k, c in enumerate(metrics.robot_coverage))
        lines += [
            f"{'path length':<18}{metrics.path_length:.1f} m ({each})",
            f"{'own coverage':<18}{own}; overlap rate {metrics.overlap_rate:.2f}",
        ]
    if metrics.merges and len(metrics.drift) == 1:
        lines.append(f"{'merge rounds':<18}{len(metrics.merges)}: one robot, no pair to merge")
    elif metrics.merges:
        rows = episode_rows(metrics)
        accepted = sum(1 for row in rows if row[1])
        confirmed = sum(1 for row in rows if row[2])
        used = sum(1 for merge in metrics.merges for p in merge.pairs if p.used)
        last = metrics.merges[-1]
        merged = ", ".join(f"r{k}" for k in last.merged_robots)
        stats = metrics.merge_stats()
        first, whole = stats.first_link_step, stats.all_linked_step
        since = "" if first is None else f"; first link at step {first}"
        if whole is not None and whole != first:
            since += f", all linked at step {whole}"
        if first is not None and len(last.merged_robots) == 1:
            since += ", none held at the last round"
        lines += [
            f"{'merge rounds':<18}{len(metrics.merges)}: {accepted} of {len(rows)} pair "
            f"estimates accepted, {confirmed} confirmed, {used} used to link maps",
            f"{'merged map':<18}{merged}{since}; agreement with the truth {last.agreement:.3f}",
        ]
    drift = "; ".join(f"r{k} {h:.2f} deg {p:.2f} m" for k, (h, p) in enumerate(metrics.drift))
    lines.append(f"{'odometry drift':<18}{drift}")
    if metrics.merges and len(metrics.drift) > 1:
        lines += ["", pair_table(summarise_pairs(episode_rows(metrics)))]
    if metrics.record is not None:
        lines += ["", f"recording: {metrics.record} (view: rerun {metrics.record})"]
    return "\n".join(lines)


def recorded_figures(run: RecordedRun) -> dict[str, Any]:
    """The exploration figures of a recording (the time series under ``team/``): the step and
    simulated seconds at which the coverage target was reached, and at the last step each
    robot's coverage and path length, the team's path length and overlap rate.

    A file cut short ends its series at different steps (a robot's coverage is written
    before its path length): every figure is read at ``at_step``, the last step all of
    them reached, so that they describe one moment; one missing is None.
    """
    settings = run.settings
    coverage = run.coverage
    target = float(settings.get("coverage_target", DEFAULT_TARGET))
    dt = float(settings.get("dt", DEFAULT_DT))
    reached = np.flatnonzero(coverage.values >= target)
    step = int(coverage.steps[reached[0]]) if len(reached) else None
    per_robot = []
    k = 0
    while robot_coverage_path(k) in run.series:
        per_robot.append((run.series[robot_coverage_path(k)], run.series.get(path_length_path(k))))
        k += 1
    total = run.series.get(PATH_LENGTH_TOTAL)
    overlap = run.series.get(OVERLAP_RATE)
    read = [total, overlap, *(series for pair in per_robot for series in pair)]
    ends = [int(series.steps[-1]) for series in read if series is not None and len(series.steps)]
    moment = min(ends) if ends else None
    return {
        "coverage_target": target,
        "steps_to_target": step,
        "seconds_to_target": None if step is None else round(step * dt, 6),
        "at_step": moment,
        "path_length_m": _value_at(total, moment),
        "overlap_rate": _value_at(overlap, moment),
        "robots": [
            {"coverage": _value_at(own, moment), "path_length_m": _value_at(length, moment)}
            for own, length in per_robot
        ],
    }


def _value_at(series: Series | None, step: int | None) -> float | None:
    """``series``'s value at ``step`` or the last before it (None when there is none, or
    it is not finite)."""
    if series is None or step is None:
        return None
    index = int(np.searchsorted(series.steps, step, side="right")) - 1
    return _finite(float(series.values[index])) if index >= 0 else None


def render_figures(figures: dict[str, Any]) -> list[str]:
    """Lines for the figures of :func:`recorded_figures`."""
    step = figures["steps_to_target"]
    target = figures["coverage_target"]
    reached = (
        "not reached" if step is None else f"step {step}, {figures['seconds_to_target']:.1f} s"
    )
    lines = [f"{'time to ' + f'{target:.0%}':<16}{reached}"]
    robots = figures["robots"]
    if figures["path_length_m"] is not None:
        each = ", ".join(f"r{k} {_shown(r['path_length_m'], 1)}" for k, r in enumerate(robots))
        lines.append(f"{'path length':<16}{figures['path_length_m']:.1f} m ({each})")
    if figures["overlap_rate"] is not None:
        own = ", ".join(f"r{k} {_shown(r['coverage'], 2)}" for k, r in enumerate(robots))
        lines.append(f"{'own coverage':<16}{own}; overlap rate {figures['overlap_rate']:.2f}")
    return lines


def _shown(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None
