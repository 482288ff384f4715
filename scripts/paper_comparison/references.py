"""Reference transforms for the Exp. rows, whose true transforms are not known.

* ap_hill: the robots' maps are nearly in one frame, so the reference of a
  pair is the transform within ±3° and ±20 cells of the identity that
  maximises Birk and Carpin's acceptance index ω
  (:func:`reference_near_identity`), checked for consistency around every
  cycle of three robots (:func:`robot_references`).
* halmstad: sessions in unrelated frames; the reference of a pair is the
  answer with the highest ω that a method of another family agrees with
  (:func:`corroborated_reference`); pairs without such agreement are not
  judged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from itertools import combinations

import numpy as np
from numpy.typing import NDArray
from scipy import fft

import merging
from merging.evaluation.metrics import transform_error
from merging.grid import UNKNOWN, free_mask, occupied_mask
from merging.transforms import rotation_about, translation_matrix
from merging.warp import warp_cells

from .contenders import FAMILIES
from .study import Answer, Case

SEARCH_ANGLE_DEG = 3.0
"""Half-width of the rotation window of the ap_hill reference search: the maps
are documented to be within 2°."""
SEARCH_STEP_DEG = 0.1
"""Rotation step of the reference search: 0.1° turns a 450-cell map's far end
by under 0.4 cells."""
SEARCH_SHIFT = 20
"""Half-width, in cells, of the translation window of the reference search."""
ANGLE_SLACK_DEG = 1e-9
"""Added to the end of the rotation range, degrees, so that floating-point
rounding cannot drop +:data:`SEARCH_ANGLE_DEG` itself."""


def reference_near_identity(
    cells1: NDArray[np.int8], cells2: NDArray[np.int8]
) -> tuple[NDArray[np.float64], float]:
    """The transform near the identity with the highest acceptance index ω, and that ω.

    Every rotation in ±:data:`SEARCH_ANGLE_DEG` (step :data:`SEARCH_STEP_DEG`)
    about map 2's centre and every whole-cell shift in ±:data:`SEARCH_SHIFT`
    is scored; the counts of agreeing and disagreeing cells of all shifts of
    one rotation come from four FFT cross-correlations of the occupied and
    free masks, so ω is exact (for the nearest-neighbour warp of map 2).
    """
    pad = SEARCH_SHIFT
    shape = (cells1.shape[0] + 2 * pad, cells1.shape[1] + 2 * pad)
    size = (int(fft.next_fast_len(shape[0] + pad)), int(fft.next_fast_len(shape[1] + pad)))
    canvas1 = np.full(shape, UNKNOWN, dtype=np.int8)
    canvas1[pad:-pad, pad:-pad] = cells1
    occ1 = fft.rfft2(occupied_mask(canvas1).astype(np.float32), s=size)
    free1 = fft.rfft2(free_mask(canvas1).astype(np.float32), s=size)
    centre = np.array([(cells2.shape[1] - 1) / 2, (cells2.shape[0] - 1) / 2])
    shifts = np.arange(-pad, pad + 1)
    best = (-1.0, np.eye(3))
    for degrees in np.arange(
        -SEARCH_ANGLE_DEG, SEARCH_ANGLE_DEG + ANGLE_SLACK_DEG, SEARCH_STEP_DEG
    ):
        turn = rotation_about(np.deg2rad(degrees), centre)
        warped = warp_cells(cells2, translation_matrix([pad, pad]) @ turn, shape)
        occ2 = np.conj(fft.rfft2(occupied_mask(warped).astype(np.float32), s=size))
        free2 = np.conj(fft.rfft2(free_mask(warped).astype(np.float32), s=size))
        agree = fft.irfft2(occ1 * occ2 + free1 * free2, s=size)
        disagree = fft.irfft2(occ1 * free2 + free1 * occ2, s=size)
        # Entry [dy, dx] (indices modulo size) counts cells for map 2 moved by (dx, dy).
        agree = np.rint(agree[np.ix_(shifts % size[0], shifts % size[1])])
        disagree = np.rint(disagree[np.ix_(shifts % size[0], shifts % size[1])])
        omega = agree / np.maximum(agree + disagree, 1.0)
        dy, dx = np.unravel_index(int(np.argmax(omega)), omega.shape)
        if omega[dy, dx] > best[0]:
            best = (float(omega[dy, dx]), translation_matrix([shifts[dx], shifts[dy]]) @ turn)
    return best[1], best[0]


def robot_references(
    maps: Sequence[NDArray[np.int8]], notes: list[str]
) -> dict[tuple[int, int], NDArray[np.float64]]:
    """References between every two robots' maps, by :func:`reference_near_identity`.

    Returns ``(i, j) -> matrix`` taking robot ``j``'s cells to robot ``i``'s,
    for every ordered pair. Appends to ``notes`` each reference and, for every
    cycle of three robots, how far chaining two references lands from the
    third (an estimate of the references' own error).
    """
    references: dict[tuple[int, int], NDArray[np.float64]] = {}
    for i in range(len(maps)):
        for j in range(i + 1, len(maps)):
            matrix, omega = reference_near_identity(maps[i], maps[j])
            references[(i, j)] = matrix
            references[(j, i)] = np.linalg.inv(matrix).astype(np.float64)
            dx, dy, theta = merging.matrix_to_pose(matrix)
            notes.append(
                f"reference robot{j} -> robot{i}: ({dx:+.0f}, {dy:+.0f}) cells, "
                f"{np.rad2deg(theta):+.1f}°, ω = {omega:.3f}"
            )
    for i, j, k in combinations(range(len(maps)), 3):
        chained = references[(i, j)] @ references[(j, k)]
        rms, degrees = transform_error(chained, references[(i, k)], maps[k])
        notes.append(
            f"cycle check robot{k} -> robot{j} -> robot{i} vs robot{k} -> robot{i}: "
            f"{rms:.1f} cells RMS, {degrees:.2f}°"
        )
    return references


def within_tolerance(first: NDArray[np.float64], second: NDArray[np.float64], case: Case) -> bool:
    """Whether two transforms of ``case``'s map 2 are within the case's tolerance of each other."""
    return case.tolerance.admits(*transform_error(first, second, case.map2))


def corroborated_reference(
    case: Case, answers: Mapping[str, Answer]
) -> tuple[str, NDArray[np.float64]] | None:
    """The answer with the highest ω that a method of another family agrees with, if any.

    ``answers`` maps contender keys to their answers on ``case``; returns the
    chosen key and its matrix.

    Answers from a method that found no transform at all (no hypotheses) are
    not candidates. Two answers agree when they are within the case's
    tolerance of each other; requiring a second family keeps one method's
    lucky or systematic answer from becoming the reference on its own.
    """
    found = [key for key, answer in answers.items() if answer.result.hypotheses]
    for key in sorted(found, key=lambda k: -answers[k].acceptance_index):
        matrix = answers[key].result.matrix
        if any(
            FAMILIES[other] != FAMILIES[key]
            and within_tolerance(answers[other].result.matrix, matrix, case)
            for other in found
        ):
            return key, matrix
    return None
