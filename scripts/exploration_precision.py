"""How close the merger's accepted estimates in exploration come to what the maps allow.

Exploration on generated floors, with the team's settings (the defaults unless
``--team`` changes them); after every
merge round, each accepted pair estimate is compared with the truth (the
relative pose of the two robots' true start frames) and with the *best fit
from the truth*: the default method's refinement of the two grids started at
the truth (:func:`merging.tomographic.search.refine_from`): the rigid
placement near the truth at which those grids fit best, or the truth itself
when the refinement finds nothing that verifies better within its reach.
Both grids were drawn at drifting odometry poses, so that fit is off the
truth by what the maps themselves are off; an estimate at the fit is at the
limit of its data, and cannot be made more precise by a better search.

Per accepted estimate (a false match, beyond 5 degrees or 1 m of the truth,
is counted apart) the rows give the rotation and translation errors of the
estimate against the truth, of the fit against the truth, and of the
estimate against the fit, and how well each of the two lays the grids'
walls on each other (:data:`COLUMNS`); the summary gives the errors'
medians and 90th percentiles, the share of the fits the default verdict
accepts, and how often the estimate fits at least as well as the fit. Where
the fit stayed at the truth, compare the walls each lays on walls: on drifted
maps the estimate may meet more of them a few centimetres away.

Usage::

    python scripts/exploration_precision.py --worlds 0 1 2 --seeds 0 1 2 3 4 5 \\
        --out precision
    python scripts/exploration_precision.py --team merger.confidence.accept=0.7 --out accept07
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.evidence.verify import PreparedMap, prepare_map, verify
from merging.params import DEFAULT_PARAMS
from merging.tomographic.search import refine_from
from tomosim.commands.floor_episodes import (
    add_floor_episode_arguments,
    check_floor_episode_arguments,
    floor_episode,
)
from tomosim.episode.outcome import GROSS_ROTATION_DEG, GROSS_TRANSLATION_M
from tomosim.episode.runner import run_episode
from tomosim.frames import frame_errors
from tomosim.team import TeamSession
from tomosim.team.quality import RoundQuality, in_cells, true_relative

COLUMNS = (
    "world",
    "seed",
    "step",
    "pair",
    "confidence",
    "rotation_error_deg",
    "translation_error_m",
    "fit_rotation_error_deg",
    "fit_translation_error_m",
    "from_fit_rotation_deg",
    "from_fit_translation_m",
    "fit_accepted",
    "quality",
    "fit_quality",
    "walls_meeting",
    "fit_walls_meeting",
)
"""The rows' columns: the estimate against the truth, the best fit from the truth
against the truth (``fit_``), the estimate against that fit (``from_fit_``), and how well
each placement lays the two grids' walls on each other: ``quality`` (the verification's
fit, a fraction of the walls that land on known cells, at most 1;
:attr:`merging.evidence.verify.Verification.quality`) and ``walls_meeting`` (how many
wall cells land on walls, :attr:`~merging.evidence.verify.Verification.agreeing`), with
``fit_`` for the best fit's."""
FIGURES = (
    ("estimate against the truth", "rotation_error_deg", "translation_error_m"),
    (
        "best fit from the truth against the truth",
        "fit_rotation_error_deg",
        "fit_translation_error_m",
    ),
    ("estimate against the best fit", "from_fit_rotation_deg", "from_fit_translation_m"),
)
"""The summary's lines: a label and the two columns it summarises."""
TEAM_EXAMPLE = "merger.confidence.accept=0.7"
"""The ``--team`` setting the help and a malformed ``--team`` name as an example."""


def compare_round(session: TeamSession, merge: RoundQuality) -> list[dict[str, Any]]:
    """One row (:data:`COLUMNS` but world and seed) per pair estimate the round accepted."""
    grids = session.grids()
    starts = session.simulation.start_poses
    rows = []
    for pair in merge.pairs:
        if not pair.accepted:
            continue
        first, second = grids[pair.first], grids[pair.second]
        truth = true_relative(starts[pair.first], starts[pair.second])
        fit = refine_from(first, second, in_cells(first, second, truth))
        estimate = next(
            p.result for p in merge.merge.pairs if (p.first, p.second) == (pair.first, pair.second)
        )
        assert fit.matrix_metres is not None and estimate.matrix_metres is not None
        params = DEFAULT_PARAMS.verify
        prepared = (prepare_map(first.data, params=params), prepare_map(second.data, params=params))
        fit_rotation, fit_translation = frame_errors(fit.matrix_metres, truth)
        off_rotation, off_translation = frame_errors(estimate.matrix_metres, fit.matrix_metres)
        rows.append(
            {
                "step": merge.step,
                "pair": pair.name,
                "confidence": pair.confidence,
                "rotation_error_deg": pair.rotation_error_deg,
                "translation_error_m": pair.translation_error_m,
                "fit_rotation_error_deg": fit_rotation,
                "fit_translation_error_m": fit_translation,
                "from_fit_rotation_deg": off_rotation,
                "from_fit_translation_m": off_translation,
                "fit_accepted": int(fit.accepted),
                **placement_fit(prepared, estimate.matrix, ""),
                **placement_fit(prepared, fit.matrix, "fit_"),
            }
        )
    return rows


def placement_fit(
    prepared: tuple[PreparedMap, PreparedMap], matrix: NDArray[np.float64], prefix: str
) -> dict[str, float]:
    """How well ``matrix`` (the second prepared grid's cells to the first's) lays the
    grids' walls on each other, by the default verification: ``{prefix}quality``, its fit
    (agreement less weighted conflict, a fraction), and ``{prefix}walls_meeting``, the
    wall cells that land on walls (both ways round)."""
    check = verify(*prepared, matrix, params=DEFAULT_PARAMS.verify)
    return {f"{prefix}quality": float(check.quality), f"{prefix}walls_meeting": check.agreeing}


def collect(found: list[dict[str, Any]], session: TeamSession, merge: RoundQuality) -> None:
    """An episode's ``on_merge``: add the round's rows to ``found``."""
    found.extend(compare_round(session, merge))


def false_match(row: dict[str, Any]) -> bool:
    """An estimate beyond the gross bounds of :mod:`tomosim.episode.outcome`."""
    return bool(
        float(row["rotation_error_deg"]) > GROSS_ROTATION_DEG
        or float(row["translation_error_m"]) > GROSS_TRANSLATION_M
    )


def summarise(rows: Sequence[dict[str, Any]]) -> str:
    """The Markdown summary of the rows (module docstring)."""
    right = [r for r in rows if not false_match(r)]
    lines = [
        f"{len(rows)} accepted estimates, {len(rows) - len(right)} of them false matches "
        f"(beyond {GROSS_ROTATION_DEG:g} deg or {GROSS_TRANSLATION_M:g} m; left out below)",
        "",
        "| | rotation [deg] median | p90 | translation [m] median | p90 |",
        "|---|---|---|---|---|",
    ]
    for label, rotation, translation in FIGURES:
        r = np.array([float(row[rotation]) for row in right])
        t = np.array([float(row[translation]) for row in right])
        if not len(r):
            lines.append(f"| {label} | - | - | - | - |")
            continue
        lines.append(
            f"| {label} | {np.median(r):.3f} | {np.percentile(r, 90):.3f} "
            f"| {np.median(t):.3f} | {np.percentile(t, 90):.3f} |"
        )
    if right:
        accepted = sum(int(row["fit_accepted"]) for row in right) / len(right)
        lines += ["", f"the default verdict accepts {accepted:.1%} of the best fits from the truth"]
        gain = np.array([float(row["quality"]) - float(row["fit_quality"]) for row in right])
        walls = np.array(
            [
                float(row["walls_meeting"]) / max(float(row["fit_walls_meeting"]), 1.0)
                for row in right
            ]
        )
        lines += [
            f"the estimate's fit (a fraction) is at least the best fit's in "
            f"{np.mean(gain >= 0):.1%} (difference: median {np.median(gain):.4f}, 10th "
            f"percentile {np.percentile(gain, 10):.4f})",
            f"the estimate lays at least as many walls on walls as the best fit in "
            f"{np.mean(walls >= 1):.1%} (ratio: median {np.median(walls):.2f}, 10th "
            f"percentile {np.percentile(walls, 10):.2f})",
        ]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_floor_episode_arguments(parser, seeds=range(6), team_example=TEAM_EXAMPLE)
    parser.add_argument("--out", type=Path, default=Path("precision"))
    args = parser.parse_args(argv)
    check_floor_episode_arguments(parser, args, team_example=TEAM_EXAMPLE)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "precision.csv"
    rows: list[dict[str, Any]] = []
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        for seed in args.seeds:
            for world in args.worlds:
                found: list[dict[str, Any]] = []
                run_episode(floor_episode(args, world, seed), on_merge=partial(collect, found))
                for row in found:
                    row.update(world=f"floor{world}", seed=seed)
                    writer.writerow(row)
                handle.flush()  # a long run that stops keeps its episodes
                rows += found
                print(f"floor{world} seed {seed}: {len(found)} accepted", file=sys.stderr)
    report = summarise(rows)
    (args.out / "precision.md").write_text(report + "\n", encoding="utf-8")
    print(report)
    print(f"\nrows: {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
