"""``tomosim review RUN.rrd``: read a recording back and summarise it.

The recording is read with rerun's own reader (:func:`tomosim.recording.read_recording`).
The command prints the merge-quality timeline (per merge round and pair: the
confidence, whether the merger accepted and confirmed the estimate and whether
the round's linking used it, and the errors of accepted estimates against the
simulator's truth, with the merged map's agreement with the truth), then the
final figures (with the steps at which a round first linked two maps and first
linked every robot's map into one), and
writes a PNG:
the final merged map beside the ground truth, the error curves and the
coverage curve (``--png``, default ``RUN_summary.png`` beside the recording).

A run that did not finish (interrupted, or killed so that its recording still
says "running") is reported as such, first; a file cut short by a killed
process is read up to its last whole message, with a warning. Recordings of
other applications than tomosim are refused.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

from tomosim.commands import CommandError, UsageError, check_writable, one_line
from tomosim.commands.explore_report import (
    pair_table,
    recorded_figures,
    render_figures,
    settings_line,
    summarise_pairs,
)
from tomosim.recording import RecordedRun, read_recording
from tomosim.recording.paths import AGREEMENT, STATUS_FINISHED, STATUS_RUNNING
from tomosim.team import pair_order

NAME = "review"
"""The subcommand's name."""
HELP = "summarise a tomosim .rrd recording: merge-quality timeline, final figures, PNG"
"""One line for ``tomosim --help``."""
PNG_SUFFIX = "_summary.png"
"""The default PNG is the recording's name with this ending."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the command's arguments on its subparser."""
    parser.add_argument("recording", type=Path, help="a .rrd file written by tomosim explore")
    parser.add_argument(
        "--png", type=Path, default=None, help=f"summary image (default RUN{PNG_SUFFIX})"
    )
    parser.add_argument("--no-png", action="store_true", help="do not write the summary image")
    parser.add_argument("--json", action="store_true", help="print the timeline as JSON")


def _number(value: float | None) -> float | None:
    """JSON-safe: non-finite numbers become None."""
    return value if value is not None and math.isfinite(value) else None


def _flag(run: RecordedRun, name: str, quantity: str, step: int) -> bool | None:
    """Whether a pair's 0/1 ``quantity`` was set at ``step``; None when the recording does
    not hold it (recordings written before ``used`` and ``dropped`` were logged)."""
    series = run.pair(name, quantity)
    if not len(series.steps):
        return None
    return (series.at(step) or 0.0) > 0


def first_link_step(rounds: list[dict[str, Any]]) -> int | None:
    """The first round of :func:`timeline` whose linking used a pair's estimate (None when
    none did, or when the recording does not say which were used)."""
    for merge in rounds:
        if any(p.get("used") for p in merge["pairs"].values()):
            return int(merge["step"])
    return None


def all_linked_step(rounds: list[dict[str, Any]], robots: int | None) -> int | None:
    """The first round of :func:`timeline` whose used pairs link all ``robots`` maps into
    one (``all_linked_step`` of the episode's merge figures); None when no round did,
    when the recording does not say which pairs were used, or for a team of one.

    The linking of a round is a forest of the pairs it used, so its maps form one group
    exactly when those pairs join every robot (``robots``: the run's setting; without
    it, the robots the pairs' names count).
    """
    if robots is None:
        named = [pair_robots(name) for merge in rounds for name in merge["pairs"]]
        robots = 1 + max((k for pair in named if pair for k in pair), default=0)
    if robots < 2:
        return None
    for merge in rounds:
        used = [pair_robots(name) for name, pair in merge["pairs"].items() if pair.get("used")]
        if _joined([ends for ends in used if ends and max(ends) < robots], robots):
            return int(merge["step"])
    return None


def _joined(links: list[tuple[int, int]], robots: int) -> bool:
    """Whether ``links`` (pairs of robots) join robots ``0 .. robots - 1`` into one group."""
    group = list(range(robots))

    def root(k: int) -> int:
        while group[k] != k:
            k = group[k]
        return k

    for first, second in links:
        group[root(first)] = root(second)
    return len({root(k) for k in range(robots)}) == 1


def pair_robots(name: str) -> tuple[int, int] | None:
    """The robots of a pair named ``rI-rJ`` (None for a name of another form)."""
    numbers = re.fullmatch(r"r(\d+)-r(\d+)", name)
    return None if numbers is None else (int(numbers[1]), int(numbers[2]))


def timeline(run: RecordedRun) -> list[dict[str, Any]]:
    """Per merge round: its step, the merged map's agreement and each pair's figures."""
    agreement = run.series.get(AGREEMENT)
    steps = sorted({int(s) for name in run.pairs for s in run.pair(name, "accepted").steps})
    rounds = []
    for step in steps:
        pairs = {}
        for name in run.pairs:
            accepted = run.pair(name, "accepted").at(step)
            if accepted is None:
                continue
            entry: dict[str, Any] = {
                "accepted": accepted > 0,
                "confirmed": (run.pair(name, "confirmed").at(step) or 0.0) > 0,
                "used": _flag(run, name, "used", step),
                "dropped": _flag(run, name, "dropped", step),
                "confidence": run.pair(name, "confidence").at(step),
                "matching_index": _number(run.pair(name, "matching_index").at(step)),
            }
            if entry["accepted"]:
                entry["rotation_error_deg"] = _number(run.pair(name, "rotation_error_deg").at(step))
                entry["translation_error_m"] = _number(
                    run.pair(name, "translation_error_m").at(step)
                )
            pairs[name] = entry
        rounds.append(
            {
                "step": step,
                "agreement": None if agreement is None else agreement.at(step),
                "pairs": pairs,
            }
        )
    return rounds


def describe_status(run: RecordedRun) -> str:
    """How the run ended, in words, from ``run/status`` and the file's state."""
    if not run.status and run.notes:
        return (
            f"did not finish: the recording was cut short at step {run.last_step}, before "
            "it said how the run ended"
        )
    if not run.status:
        return (
            f"unknown end: the recording ends at step {run.last_step} and does not say how "
            "the run ended (an older tomosim wrote it)"
        )
    if run.status.startswith(STATUS_RUNNING):
        return (
            f"did not finish: the recording ends at step {run.last_step} without saying how "
            "the run ended (the process was killed or crashed)"
        )
    if run.status.startswith(STATUS_FINISHED):
        return run.status
    return f"did not finish: {run.status}"


def summary(run: RecordedRun) -> dict[str, Any]:
    """Everything the command prints, as plain values."""
    coverage = run.coverage
    rounds = timeline(run)
    return {
        "recording": str(run.path),
        "finished": run.finished,
        "status": describe_status(run),
        "notes": list(run.notes),
        "settings": run.settings,
        "steps": int(coverage.steps[-1]) if len(coverage.steps) else 0,
        "coverage": _number(coverage.last()),
        "exploration": recorded_figures(run),
        "merges": rounds,
        "first_link_step": first_link_step(rounds),
        "all_linked_step": all_linked_step(rounds, _robots(run.settings)),
    }


def _robots(settings: dict[str, Any]) -> int | None:
    """The run's team size, when its settings say it."""
    value = settings.get("robots") if settings else None
    return int(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def _used(pair: dict[str, Any]) -> str:
    """A timeline row's ``used`` column: yes, no, "dropped" (confirmed but contradicting
    the other links), or ``-`` when the recording does not say."""
    if pair.get("used") is None:
        return "-"
    return "yes" if pair["used"] else "dropped" if pair.get("dropped") else "no"


def render(report: dict[str, Any]) -> str:
    """The text form of :func:`summary`."""
    s = report["settings"]
    lines = [f"recording {report['recording']}", f"run {report['status']}"]
    if s:
        lines.append(settings_line(s))
    lines += ["", "merge-quality timeline (errors of accepted estimates against the truth)"]
    header = (
        f"{'step':>6}  {'pair':<7}{'confidence':>11}{'accepted':>10}{'confirmed':>11}"
        f"{'used':>7}{'rotation [deg]':>16}{'translation [m]':>17}{'agreement':>11}"
    )
    lines.append(header)
    rows = []
    for merge in report["merges"]:
        for k, (name, p) in enumerate(
            sorted(merge["pairs"].items(), key=lambda item: pair_order(item[0]))
        ):
            rot = p.get("rotation_error_deg")
            shift = p.get("translation_error_m")
            agree = merge["agreement"] if k == 0 and merge["agreement"] is not None else None
            lines.append(
                f"{merge['step']:>6}  {name:<7}{p['confidence']:>11.3f}"
                f"{'yes' if p['accepted'] else 'no':>10}{'yes' if p['confirmed'] else 'no':>11}"
                f"{_used(p):>7}"
                f"{'-' if rot is None else f'{rot:.2f}':>16}"
                f"{'-' if shift is None else f'{shift:.3f}':>17}"
                f"{'' if agree is None else f'{agree:.3f}':>11}"
            )
            rows.append(
                (
                    name,
                    bool(p["accepted"]),
                    bool(p["confirmed"]),
                    math.inf if rot is None else rot,
                    math.inf if shift is None else shift,
                )
            )
    if not report["merges"]:
        lines.append("  (no merge rounds recorded)")
    coverage = report["coverage"]
    lines += [
        "",
        f"{'steps':<16}{report['steps']}",
        f"{'team coverage':<16}{'-' if coverage is None else f'{coverage:.3f}'}",
        *render_figures(report["exploration"]),
    ]
    if rows:
        accepted = sum(1 for r in rows if r[1])
        lines.append(f"{'merges':<16}{accepted} of {len(rows)} pair estimates accepted")
        if report["first_link_step"] is not None:
            lines.append(f"{'first link':<16}step {report['first_link_step']}")
        if report.get("all_linked_step") is not None:
            lines.append(f"{'all linked':<16}step {report['all_linked_step']}")
        lines += ["", pair_table(summarise_pairs(rows))]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Read the recording, print the report, write the PNG; returns the exit status."""
    path: Path = args.recording
    if path.suffix != ".rrd":
        raise UsageError(f"give a .rrd recording, got {path}")
    if args.png is not None and args.no_png:
        raise UsageError("give either --png or --no-png, not both")
    if args.png is not None and args.png.resolve() == path.resolve():
        raise UsageError(f"--png {args.png} is the recording itself; choose another file")
    if args.png is not None and args.png.suffix.lower() != ".png":
        raise UsageError(f"--png must name a .png file, got {args.png}")
    try:
        recorded = read_recording(path)
    except FileNotFoundError as exc:
        raise CommandError(one_line(exc)) from exc
    except ValueError as exc:
        raise CommandError(one_line(exc)) from exc
    for note in recorded.notes:
        print(f"tomosim: warning: {note}", file=sys.stderr)
    if not recorded.series:
        raise CommandError(f"{path} holds no tomosim figures; record it with tomosim explore")
    report = summary(recorded)
    png = None
    if not args.no_png:
        png = args.png if args.png is not None else path.with_name(path.stem + PNG_SUFFIX)
        check_writable(png, option="--png" if args.png is not None else "--png (or --no-png)")
        from tomosim.commands.review_plot import plot_summary  # matplotlib only when plotting

        try:
            plot_summary(recorded, report, png)
        except OSError as exc:
            raise CommandError(f"cannot write {png}: {one_line(exc.strerror or exc)}") from exc
        report["png"] = str(png)
    print(json.dumps(report, indent=2) if args.json else render(report))
    if png is not None and not args.json:
        print(f"\nsummary image: {png}")
    return 0
