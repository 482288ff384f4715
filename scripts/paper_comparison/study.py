"""What the comparison works on and records: cases, tolerances, answers, rows, the study.

A :class:`Case` is one pair of maps with its truth; an :class:`Answer` is one
method's result on it; a :class:`Row` is that answer measured against the
truth, as written to ``rows.csv`` (its fields are the CSV's columns, in
order); the :class:`Study` gathers the rows and the notes that the report
needs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from merging.result import MergeResult


@dataclass(frozen=True, slots=True)
class Tolerance:
    """When an estimate counts as right: RMS error of map 2's walls and rotation error.

    Attributes
    ----------
    cells : float
        Largest RMS distance, in cells, between where the estimate and the
        truth put map 2's occupied cells.
    degrees : float
        Largest rotation error, degrees; 180 or more leaves it to the RMS bound.
    metres_per_cell : float
        Resolution of the maps, to state the bound in metres too.
    """

    cells: float
    degrees: float
    metres_per_cell: float

    def __str__(self) -> str:
        text = f"{self.cells:g} cells ({self.cells * self.metres_per_cell:.2f} m) RMS"
        return text + (f" and {self.degrees:g}°" if self.degrees < 180 else "")

    def admits(self, rms_cells: float, rotation_deg: float) -> bool:
        """Whether an error is within (errors as
        :func:`merging.evaluation.metrics.transform_error` gives them).

        NaN errors (no truth to measure against) are not within.
        """
        return bool(rms_cells <= self.cells and rotation_deg <= self.degrees)


@dataclass(frozen=True, slots=True)
class Case:
    """One pair of maps to merge, with its truth (or None when decided afterwards).

    Attributes
    ----------
    row : str
        The table row it belongs to, e.g. ``"Sim. aces3"``.
    group : str
        ``"Sim."`` or ``"Exp."``: which of the paper's rows it compares with.
    label : str
        The pair's name in notes and figures.
    map1, map2 : int8 ndarray
        The grids in the ROS coding.
    truth : (3, 3) float ndarray or None
        Map transformation matrix taking map 2's cells to map 1's; None when
        the reference is chosen from the methods' answers.
    tolerance : Tolerance
        When an answer counts as right.
    """

    row: str
    group: str
    label: str
    map1: NDArray[np.int8]
    map2: NDArray[np.int8]
    truth: NDArray[np.float64] | None
    tolerance: Tolerance


@dataclass(frozen=True, slots=True)
class Row:
    """One method on one case: a line of ``rows.csv``.

    ``overlap`` is the pair's average overlap ratio; ``rms_cells`` and
    ``rotation_error_deg`` the error against the truth (NaN when the case
    is not judged); ``matching_index`` is Ψ of eq. (31) of the answer and
    ``truth_matching_index`` that of the truth; ``acceptance_index`` is ω of
    the answer; ``seconds`` the method's own total time.
    """

    row: str
    case: str
    method: str
    overlap: float
    rms_cells: float
    rotation_error_deg: float
    judged: bool
    success: bool
    accepted: bool
    confidence: float
    matching_index: float
    truth_matching_index: float
    acceptance_index: float
    seconds: float


@dataclass(slots=True)
class Study:
    """What the run collected, for the report.

    Attributes
    ----------
    rows : list of Row
        Every result, in the order they were run.
    notes : dict
        Table row -> lines on how its references were found.
    tolerances : dict
        Table row -> its :class:`Tolerance`.
    references : dict
        Case label -> the reference transform chosen for a case without truth.
    """

    rows: list[Row] = field(default_factory=list)
    notes: dict[str, list[str]] = field(default_factory=dict)
    tolerances: dict[str, Tolerance] = field(default_factory=dict)
    references: dict[str, NDArray[np.float64]] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Answer:
    """One method's answer on a case, scored with both indices from one warp.

    ``matching_index`` is Ψ of eq. (31) and ``acceptance_index`` Birk and
    Carpin's ω (:func:`merging.evaluation.metrics.match_indices`).
    """

    result: MergeResult
    matching_index: float
    acceptance_index: float
