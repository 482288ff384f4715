"""Run every method on every case and record the results as they come.

All methods run on one case before the next case is built, one after the
other, so that the machine's load affects them alike. Each case's rows are
appended to ``rows.csv`` and flushed as soon as the case is done, so an
interrupted run keeps what it measured.
"""

from __future__ import annotations

import csv
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

import merging
from merging.evaluation.metrics import match_indices, matching_index, transform_error

# The pairs module's own overlap ratio (the one cut_window_pairs filters on),
# so that every row measures overlap as the Sim. pairs were selected by it.
from merging.evaluation.pairs import overlap_ratio

from .cases import CaseGroup
from .contenders import Contender
from .references import corroborated_reference, within_tolerance
from .study import Answer, Case, Row, Study


def run_groups(
    groups: Sequence[CaseGroup],
    contenders: Sequence[Contender],
    *,
    seed: int,
    study: Study,
    csv_path: Path,
) -> list[tuple[str, list[Case]]]:
    """Build and run every group in turn, writing ``csv_path`` row by row.

    Progress goes to standard error. Returns each group's name with the
    cases it built (the figures draw some of them).
    """
    built: list[tuple[str, list[Case]]] = []
    with csv_path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=[f.name for f in fields(Row)])
        writer.writeheader()
        for name, build in groups:
            clock = time.perf_counter()
            cases = build()
            for k, case in enumerate(cases):
                rows = run_case(case, contenders, seed=seed, study=study)
                writer.writerows(asdict(row) for row in rows)
                handle.flush()
                print(f"  {name}: {k + 1}/{len(cases)}", end="\r", file=sys.stderr)
            print(
                f"  {name}: {len(cases)} pairs in {time.perf_counter() - clock:.0f} s",
                file=sys.stderr,
            )
            built.append((name, cases))
    return built


def run_case(case: Case, contenders: Sequence[Contender], *, seed: int, study: Study) -> list[Row]:
    """Run every contender on one case; returns a row per contender, also added to ``study``.

    A case without truth gets the corroborated reference of the answers
    (noted in ``study``), or is not judged when there is none.
    """
    study.tolerances[case.row] = case.tolerance
    answers = {contender.key: answer(case, contender, seed=seed) for contender in contenders}
    truth = case.truth if case.truth is not None else choose_reference(case, answers, study)
    overlap = truth_psi = float("nan")
    if truth is not None:
        overlap = overlap_ratio(case.map1 >= 0, case.map2, truth)
        truth_psi = matching_index(case.map1, case.map2, truth)
    rows = []
    for contender in contenders:
        found = answers[contender.key]
        result = found.result
        rms = degrees = float("nan")
        if truth is not None:
            rms, degrees = transform_error(result.matrix, truth, case.map2)
        rows.append(
            Row(
                case.row,
                case.label,
                contender.key,
                round(overlap, 4),
                round(rms, 2),
                round(degrees, 3),
                truth is not None,
                case.tolerance.admits(rms, degrees),
                result.accepted,
                round(result.confidence, 4),
                round(found.matching_index, 4),
                round(truth_psi, 4),
                round(found.acceptance_index, 4),
                round(result.timings["total"], 4),
            )
        )
    study.rows.extend(rows)
    return rows


def answer(case: Case, contender: Contender, *, seed: int) -> Answer:
    """One contender's answer on ``case``, scored with Ψ and ω."""
    result = merging.estimate_transform(
        case.map1, case.map2, method=contender.method, rng=seed, **dict(contender.options)
    )
    return Answer(result, *match_indices(case.map1, case.map2, result.matrix))


def choose_reference(
    case: Case, answers: Mapping[str, Answer], study: Study
) -> NDArray[np.float64] | None:
    """The corroborated reference of a case without truth, noted in ``study``; None if none."""
    notes = study.notes.setdefault(case.row, [])
    chosen = corroborated_reference(case, answers)
    if chosen is None:
        notes.append(f"{case.label}: no two method families agree; no reference, not judged")
        return None
    source, truth = chosen
    study.references[case.label] = truth
    agreeing = [k for k in answers if within_tolerance(answers[k].result.matrix, truth, case)]
    notes.append(
        f"{case.label}: reference from {source} (ω = {answers[source].acceptance_index:.3f}); "
        f"agreeing: {', '.join(agreeing)}"
    )
    return truth
