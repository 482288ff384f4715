"""The result every merging method returns: the merger contract (a transform, a
confidence in [0, 1], and whether the method vouches for it; valid grids never
raise, and `accepted=True` on a wrong transform is the worst failure)."""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from merging.transforms import checked_transform, matrix_to_pose


@dataclass(frozen=True, slots=True)
class Hypothesis:
    """One candidate transform a method considered.

    ``score`` is the method's own ranking value (higher is better); the
    verification fields are those of :class:`merging.evidence.verify.Verification`.
    """

    matrix: NDArray[np.float64]
    score: float
    agreement: float = 0.0
    conflict: float = 0.0
    overlap: int = 0


@dataclass(frozen=True, slots=True)
class MergeResult:
    """What :func:`merging.estimate_transform` returns.

    Attributes
    ----------
    matrix : (3, 3) float ndarray
        Map transformation matrix of eq. (1): map 2 cells -> map 1 cells,
        ``(x, y) = (col, row)``. Rigid, except between grids of different
        resolutions, where it also scales by their ratio.
    confidence : float
        In ``[0, 1]``; higher means more certainly right.
    accepted : bool
        The method vouches for ``matrix``; when False the matrix is only the
        best guess and must not be used to fuse maps.
    method : str
        The method's registered name.
    matrix_metres : (3, 3) float ndarray or None
        The same transform between the maps' frames in metres (map 2 frame ->
        map 1 frame), when both inputs were :class:`OccupancyGrid` objects; always
        rigid.
    hypotheses : tuple of Hypothesis
        Candidates considered, best first.
    timings : dict
        Seconds spent per stage, and ``"total"``.
    reason : str
        Why the result was not accepted, in words (empty when accepted).
    evidence : dict
        The numbers behind the verdict, by name, for methods that report
        them (the default: ``agreement``, ``conflict``, ``quality`` (the
        plain fit, ``agreement - conflict_weight * conflict``) and
        ``fit_quality`` (the one the fit factor used, tolerant of bent maps
        where that fits better), ``matching_wall_cells``,
        ``shared_open_cells``, ``strength``, ``margin``,
        ``runner_up_distance_cells`` and ``runner_up_turn_deg`` against the
        best different placement (and, when refused, ``runner_up_same_walls``:
        the share of the walls the placement aligns that it lays on the same
        walls again; ``tolerant_margin`` and
        ``tolerant_runner_up_*`` against the best one beyond the bending of
        separate sessions, which the robust evidence holds it against),
        the factors ``close_*`` and, when the close fit fails, ``robust_*``
        and ``tolerant_*`` (only the free ones, and the strength a refusal's
        reason may need, when one of them already keeps the robust way below
        the close fit; ``robust_confidence`` then is absent); for a placement a way
        would vouch for, ``mirror_share`` and ``close_mirror`` or
        ``tolerant_mirror_share`` and ``robust_mirror`` against map 2's
        mirror image; see :mod:`merging.evidence.verdict` and :mod:`merging.evidence.mirror`).
    """

    matrix: NDArray[np.float64]
    confidence: float
    accepted: bool
    method: str
    matrix_metres: NDArray[np.float64] | None = None
    hypotheses: tuple[Hypothesis, ...] = ()
    timings: dict[str, float] = field(default_factory=dict)
    reason: str = ""
    evidence: dict[str, float] = field(default_factory=dict)

    @property
    def rotation(self) -> float:
        """Rotation of :attr:`matrix` in radians, counter-clockwise, in ``(-pi, pi]``."""
        return matrix_to_pose(self.matrix)[2]

    @property
    def translation(self) -> tuple[float, float]:
        """Translation ``(dx, dy)`` of :attr:`matrix` in cells."""
        dx, dy, _ = matrix_to_pose(self.matrix)
        return dx, dy


def checked_result(result: object, where: str) -> MergeResult:
    """``result`` if it is a :class:`MergeResult` whose matrix, and each of its
    hypotheses' (a pair is read either way round), is a finite, invertible, homogeneous
    3 x 3 transform, whose confidence is a number in ``[0, 1]`` and whose ``accepted`` is
    a bool; else raise naming ``where`` (what gave it: a method, a pair given to a
    linking)."""
    if not isinstance(result, MergeResult):
        raise TypeError(f"{where} must be a MergeResult, got {type(result).__name__}")
    checked_transform(result.matrix, name=f"the matrix of {where}")
    for k, hypothesis in enumerate(result.hypotheses):
        if not isinstance(hypothesis, Hypothesis):
            raise TypeError(
                f"hypotheses[{k}] of {where} must be a Hypothesis, got {type(hypothesis).__name__}"
            )
        checked_transform(hypothesis.matrix, name=f"the matrix of hypotheses[{k}] of {where}")
    confidence = result.confidence
    if (
        isinstance(confidence, bool)
        or not isinstance(confidence, numbers.Real)
        or not 0.0 <= confidence <= 1.0
    ):
        raise ValueError(
            f"{where} has the confidence {confidence!r}: a MergeResult's confidence must be "
            "a number in [0, 1]"
        )
    if not isinstance(result.accepted, (bool, np.bool_)):
        raise TypeError(
            f"{where} has accepted={result.accepted!r}: a MergeResult's accepted must be "
            "True or False"
        )
    return result
