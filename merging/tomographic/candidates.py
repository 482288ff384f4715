"""What every step of the default method's search shares: both maps and the candidates.

A candidate is a placement of map 2 on map 1 (a 3 x 3 matrix, map 2 cells ->
map 1 cells) with its verification (:class:`~merging.evidence.verify.Verification`),
ranked by :func:`rank`. :class:`SearchMaps` holds both prepared maps, map 1's
smoothed fields and coarse images (made once, reused by every step and by a
second search of the same map 1, such as the mirror check's) and the
settings; its :meth:`~SearchMaps.refine` runs one row of the refinement
schedule (:class:`~merging.params.RefineStage`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.evidence.refine import SmoothedMap, refine_transform
from merging.evidence.verify import PreparedMap, Verification, verify
from merging.params import RefineStage, TomographicParams
from merging.tomographic.angular import AngularSpectrum, angular_spectrum
from merging.tomographic.correlate import CoarseMap, coarsen
from merging.transforms import apply_transform

Candidate = tuple[Verification, NDArray[np.float64]]
"""A hypothesis and its verification."""


def _image_settings(params: TomographicParams) -> tuple[Any, ...]:
    """The settings map 1's fields, coarse images and angular spectra are made with."""
    translation = params.translation
    return (params.rotation, params.gauss_newton, translation.wall_blur, translation.free_penalty)


def rank(check: Verification) -> float:
    """The score hypotheses are ranked by (:attr:`Verification.score`)."""
    return check.score


class SearchMaps:
    """Both prepared maps, map 1's fields and the settings: what every stage needs."""

    __slots__ = ("coarse_first", "first", "params", "second", "smoothed", "spectra_first")

    smoothed: SmoothedMap
    coarse_first: dict[int, CoarseMap]
    spectra_first: dict[tuple[int, int], AngularSpectrum]

    def __init__(
        self,
        first: PreparedMap,
        second: PreparedMap,
        params: TomographicParams,
        begun: SearchMaps | None = None,
    ):
        """``begun``: another search of the same map 1, whose images of it are reused."""
        self.first, self.second, self.params = first, second, params
        if begun is not None:
            if begun.first is not first or _image_settings(begun.params) != _image_settings(params):
                raise ValueError(
                    "a search reuses another's images of map 1 only for the same map 1 "
                    "and the same rotation and gauss_newton settings, wall_blur and "
                    "free_penalty"
                )
            self.smoothed = begun.smoothed
            self.coarse_first = begun.coarse_first
            self.spectra_first = begun.spectra_first
            return
        gauss_newton = params.gauss_newton
        self.smoothed = SmoothedMap(
            first.walls,
            first.shape,
            downsample_from_sigma=gauss_newton.downsample_from_sigma,
            whole_field_share=gauss_newton.whole_field_share,
        )
        self.coarse_first = {}
        self.spectra_first = {}

    def first_coarse(self, factor: int) -> CoarseMap:
        """Map 1 in blocks of ``factor`` cells (kept for another search with that factor)."""
        if factor not in self.coarse_first:
            self.coarse_first[factor] = coarsen(self.first, factor, params=self.params.translation)
        return self.coarse_first[factor]

    def first_spectrum(self, factor: int, size: int) -> AngularSpectrum:
        """Map 1's angular spectrum in blocks of ``factor`` cells on an FFT of ``size``."""
        key = (factor, size)
        if key not in self.spectra_first:
            walls, rotation = self.first_coarse(factor).walls, self.params.rotation
            self.spectra_first[key] = angular_spectrum(walls, size=size, params=rotation)
        return self.spectra_first[key]

    def verify(self, matrix: NDArray[np.float64]) -> Verification:
        return verify(self.first, self.second, matrix, params=self.params.verify)

    def refine(self, candidate: Candidate, stage: RefineStage, *, keep: bool = True) -> Candidate:
        """Refine a candidate; keep the start only when the refined one verifies clearly worse.

        Refinement may settle on a nearby optimum that explains the maps
        worse (two close parallel walls blurred into one by a wide field).
        Within ``keep_refined_margin`` the refined transform wins:
        verification tolerates a cell of misfit, so it cannot rank finer.
        ``keep=False`` returns the refined one always: the optimum the start
        leads to.
        """
        before, matrix = candidate
        better = refined_on(self.smoothed, self.second, matrix, stage, self.params)
        after = self.verify(better)
        if not keep or rank(after) >= rank(before) - self.params.keep_refined_margin:
            return after, better
        return before, matrix


def refined_on(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    stage: RefineStage,
    params: TomographicParams,
) -> NDArray[np.float64]:
    """``matrix`` refined on ``smoothed``'s fields as ``stage`` says (one row of the schedule)."""
    return refine_transform(
        smoothed,
        second,
        matrix,
        sigmas=stage.sigmas,
        iterations=stage.iterations,
        local=stage.local,
        max_points=stage.points,
        params=params.gauss_newton,
    )


def rms_between(a: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64]):
    diff = apply_transform(a, points) - apply_transform(b, points)
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def finished(maps: SearchMaps, candidate: Candidate) -> Candidate:
    """``candidate`` refined on the narrow fields the winner of the schedule was refined on.

    The schedule refines only its best few on its narrow fields
    (:data:`merging.params.DEFAULT_STAGES`); a placement of the pool judged
    after the winner may have seen only the widest field's first steps, a
    cell or two from its optimum, and over a small overlap that becomes two
    cells or more at map 2's far walls.
    """
    for stage in maps.params.stages[1:]:
        candidate = maps.refine(candidate, stage)
    return candidate
