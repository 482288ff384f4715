"""Reduce the rows of one method on one table row to the figures the tables show."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .contenders import Contender
from .study import Row, Study


@dataclass(frozen=True, slots=True)
class Summary:
    """One method on one row of the tables.

    ``pairs`` counts its cases and ``judged`` those with a truth or
    reference; Ψ (eq. 31) and seconds are over all cases; ``success``,
    ``accepted`` and ``accepted_wrong`` are shares of the judged cases (NaN
    when none is judged); ``worst_accepted`` is the largest RMS error, in
    cells, of an accepted answer (0 when none).
    """

    pairs: int
    judged: int
    psi_mean: float
    psi_std: float
    seconds_mean: float
    seconds_std: float
    success: float
    accepted: float
    accepted_wrong: float
    worst_accepted: float


def summarise(rows: Sequence[Row]) -> Summary:
    """Ψ and time over all rows; success and acceptance over the judged ones (with a truth)."""
    psi = np.array([r.matching_index for r in rows])
    seconds = np.array([r.seconds for r in rows])
    judged = [r for r in rows if r.judged]
    success = np.array([r.success for r in judged], dtype=bool)
    accepted = np.array([r.accepted for r in judged], dtype=bool)

    def share(values: NDArray[np.bool_]) -> float:
        return float(values.mean()) if len(values) else float("nan")

    return Summary(
        len(rows),
        len(judged),
        float(psi.mean()),
        float(psi.std()),
        float(seconds.mean()),
        float(seconds.std()),
        share(success),
        share(accepted),
        share(accepted & ~success),
        max((r.rms_cells for r in judged if r.accepted), default=0.0),
    )


def table_rows(study: Study) -> list[str]:
    """The rows of the tables, in the order they were run."""
    return list(dict.fromkeys(r.row for r in study.rows))


def truth_matching(study: Study, row: str) -> float:
    """Mean Ψ of the true (or reference) transforms of a row's judged cases."""
    return float(np.mean([r.truth_matching_index for r in study.rows if r.row == row and r.judged]))


def summaries(study: Study, contenders: Sequence[Contender]) -> dict[tuple[str, str], Summary]:
    """``(table row, contender key) -> Summary`` for every row and contender."""
    return {
        (row, c.key): summarise([r for r in study.rows if r.row == row and r.method == c.key])
        for row in table_rows(study)
        for c in contenders
    }
