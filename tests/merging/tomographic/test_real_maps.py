"""The default merger on the maps users bring: whole buildings, separate sessions, low overlap."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import merging
from merging.evaluation.metrics import transform_error
from merging.evidence import verdict
from merging.evidence.robust import open_consistency, robust_confidence, tolerant_fit
from merging.evidence.verdict import MIRROR_REASON
from merging.evidence.verify import prepare_map
from merging.params import DEFAULT_PARAMS, DEFAULT_STAGES, RobustParams, TomographicParams
from merging.resample import coarsen_cells, scale_matrix
from merging.tomographic.hypotheses import coarse_to_fine
from merging.transforms import apply_transform, rigid_matrix
from tests.merging.builders import synthetic_building, turned


def shifted_crops(grid: np.ndarray, side: int, shift: tuple[int, int]):
    """``grid[:side, :side]`` and the crop ``shift`` = (dx, dy) cells further, with the truth."""
    dx, dy = shift
    return grid[:side, :side], grid[dy : dy + side, dx : dx + side], rigid_matrix(dx, dy, 0.0)


def test_a_large_synthetic_building_is_as_right_as_a_small_one() -> None:
    # 1500 cells a side: the coarse grid's blocks are 10 cells, so its hypotheses are
    # several cells off; the wide first fields must still bring them within a cell.
    grid = synthetic_building(21, shape=(1560, 1560))
    first, second, truth = shifted_crops(grid, 1500, (23, 37))
    result = merging.estimate_transform(first, second)
    assert result.accepted
    assert transform_error(result.matrix, truth, second)[0] < 0.5


def test_wider_fields_only_for_coarse_grids() -> None:
    params = TomographicParams()
    first = DEFAULT_STAGES[0]
    assert coarse_to_fine(first, 5, params).sigmas == first.sigmas  # 800 cells: as before
    assert coarse_to_fine(first, 10, params).sigmas == (4.0, *first.sigmas)
    assert coarse_to_fine(first, 25, params).sigmas == (16.0, 8.0, 4.0, *first.sigmas)


def test_whole_building_crops_within_a_cell(maps_folder) -> None:
    aces = merging.load_map(maps_folder / "aces3.yaml").data[100:]
    for side in (1200, 1600):
        first, second, truth = shifted_crops(aces, side, (23, 37))
        result = merging.estimate_transform(first, second)
        assert result.accepted
        assert transform_error(result.matrix, truth, second)[0] < 1.0


def test_whole_building_turned(maps_folder) -> None:
    whole = merging.load_map(maps_folder / "fr079.yaml").data
    map2, truth = turned(whole, 137.0, (11.0, -7.0))
    result = merging.estimate_transform(whole, map2)
    assert result.accepted
    assert transform_error(result.matrix, truth, map2)[0] < 0.5


@pytest.fixture(scope="module")
def e5_truth(maps_folder) -> dict:
    return json.loads((maps_folder / "halmstad" / "truth_E5.json").read_text())["pairs"]


def merged_sessions(folder: Path, truth: dict, key: str) -> merging.MergeResult:
    """The default's merge of the E5 sessions ``key`` ("A|B"), checked right by the
    floor's rule (within ``max(1.5 rms, rms + 10)`` cells of the annotated fit)."""
    first, second = (merging.load_map(folder / f"{name}.yaml") for name in key.split("|"))
    entry = truth[key]
    result = merging.estimate_transform(first, second)
    tolerance = max(1.5 * entry["rms_cells"], entry["rms_cells"] + 10)
    error = transform_error(result.matrix, np.array(entry["matrix_cells"]), second.data)[0]
    assert error < tolerance, (key, error, tolerance)
    return result


@pytest.mark.parametrize("key", ["E5_05|E5_10", "E5_09|E5_08"])
def test_sessions_of_one_floor_are_merged(maps_folder, e5_truth, key: str) -> None:
    # Two sessions that bend against each other: the close fit cannot vouch, the
    # robust evidence does.
    result = merged_sessions(maps_folder / "halmstad", e5_truth, key)
    assert result.accepted
    assert result.evidence["robust_confidence"] >= 0.5 > result.evidence["close_confidence"]
    # Held against map 2's mirror image too: a whole floor's walls are far from achiral.
    assert result.evidence["tolerant_mirror_share"] < 0.7


@pytest.mark.parametrize("key", ["E5_01|E5_03"])
def test_a_placement_a_few_cells_off_is_the_same_one_bent(maps_folder, e5_truth, key) -> None:
    # Sessions bend by up to half a metre: the second best placement, 5-6 cells from
    # the best, explains the overlap about as well. (E5_08|E5_07 showed this too until
    # the search kept the most significant shifts: its second best now lies 117 cells
    # off, and the pair is still accepted and right.) The close fit counts it as
    # different, the robust evidence holds the best against one beyond the bending.
    result = merged_sessions(maps_folder / "halmstad", e5_truth, key)
    evidence = result.evidence
    assert evidence["runner_up_distance_cells"] < 10 and evidence["margin"] < 0.3
    assert evidence["tolerant_runner_up_distance_cells"] > 10
    assert evidence["tolerant_margin"] > 0.3
    assert result.accepted


@pytest.mark.parametrize("key", ["E5_12|E5_13"])
def test_a_near_rival_of_bent_sessions_is_merged_into_the_compromise(
    maps_folder, e5_truth, key: str
) -> None:
    # One part of the overlap fits the best placement, another a placement 9 cells
    # away turned a degree, and each explains about as much: ambiguous as two answers,
    # right as one. The compromise between them over the whole overlap is accepted,
    # within the floor's rule of the annotated fit; taken for two answers it is refused.
    result = merged_sessions(maps_folder / "halmstad", e5_truth, key)
    assert result.accepted
    assert result.evidence["bent_rival_distance_cells"] <= DEFAULT_PARAMS.robust.bent_rival_cells
    assert result.evidence["tolerant_runner_up_distance_cells"] > 100
    strict = replace(DEFAULT_PARAMS, robust=replace(DEFAULT_PARAMS.robust, bent_rival_cells=5.0))
    first, second = (
        merging.load_map(maps_folder / "halmstad" / f"{n}.yaml") for n in key.split("|")
    )
    refused = merging.estimate_transform(first, second, params=strict)
    assert not refused.accepted
    assert refused.reason.startswith("ambiguous: another placement about as good")


def test_a_compromise_of_bent_sessions_is_held_by_its_curvature_on_wide_fields(
    maps_folder,
) -> None:
    # F5_08 and F5_14 (no annotated truth): the rival 24 cells away, turned 3 degrees, is
    # the same answer bent. With the curvature on fields of 1-4 cells alone the compromise
    # between them was refused as a slide (each part pulls its own way, no curvature is
    # left at the compromise); with the curvature on the 8-cell field it was refined on
    # too it is accepted, and agrees with the chain through F5_05.
    folder = maps_folder / "halmstad"
    names = ("F5_08", "F5_05", "F5_14")
    grids = {name: merging.load_map(folder / f"{name}.yaml") for name in names}
    result = merging.estimate_transform(grids["F5_08"], grids["F5_14"])
    assert result.accepted
    assert result.evidence["bent_rival_distance_cells"] < DEFAULT_PARAMS.robust.bent_rival_cells
    first_link = merging.estimate_transform(grids["F5_08"], grids["F5_05"])
    second_link = merging.estimate_transform(grids["F5_05"], grids["F5_14"])
    assert first_link.accepted and second_link.accepted
    chained = first_link.matrix @ second_link.matrix
    assert transform_error(result.matrix, chained, grids["F5_14"].data)[0] < 30.0


def test_a_refused_compromise_of_bent_sessions_says_why(maps_folder) -> None:
    # F5_01 and F5_07 (no annotated truth): the rival 24 cells away is taken for the same
    # answer bent, but the compromise between them lays too many walls on open space.
    folder = maps_folder / "halmstad"
    first, second = (merging.load_map(folder / f"{name}.yaml") for name in ("F5_01", "F5_07"))
    result = merging.estimate_transform(first, second)
    assert not result.accepted
    assert result.reason.startswith("ambiguous: another placement about as good lies 24 cells")
    assert "the compromise between the two is refused too: the walls do not" in result.reason
    assert result.evidence["bent_compromise_confidence"] < 0.6


def test_two_sources_of_one_building_are_merged(maps_folder) -> None:
    intel = merging.load_map(maps_folder / "intel.yaml")
    raster = merging.load_map(maps_folder / "intel_raster.yaml")
    result = merging.estimate_transform(intel, raster)
    assert result.accepted
    # The same placement both ways round.
    back = merging.estimate_transform(raster, intel)
    corners = np.array([[0.0, 0.0], [799.0, 0.0], [0.0, 799.0], [799.0, 799.0]])
    there_and_back = apply_transform(back.matrix @ result.matrix, corners)
    assert np.sqrt(np.mean(np.sum((there_and_back - corners) ** 2, axis=1))) < 3.0


ROUND_HALL_FLIPS = {
    # name: (map 1's top row and left column, map 2's, window height and width)
    "197 x 197 sharing 13 columns": ((751, 924), (754, 740), (197, 197)),
    "291 x 247 sharing 13 columns": ((672, 640), (648, 874), (291, 247)),
    "291 x 247 sharing 30 columns": ((672, 920), (648, 703), (291, 247)),
}
"""Windows side by side across aces3's round hall, each showing a corridor entering it."""


@pytest.mark.parametrize("name", sorted(ROUND_HALL_FLIPS))
def test_half_turns_of_the_round_hall_are_refused(maps_folder, name: str) -> None:
    # Map 2 turned by half a turn fits map 1 wall for wall, while the true overlap
    # holds almost no wall: the half turn is found, and refused because map 2 seen in
    # a mirror fits the same part of map 1 as well (the hall is mirror-symmetric).
    aces = merging.load_map(maps_folder / "aces3.yaml").data
    (top1, left1), (top2, left2), (height, width) = ROUND_HALL_FLIPS[name]
    first = aces[top1 : top1 + height, left1 : left1 + width]
    second = aces[top2 : top2 + height, left2 : left2 + width]
    truth = rigid_matrix(float(left2 - left1), float(top2 - top1), 0.0)
    result = merging.estimate_transform(first, second)
    assert transform_error(result.matrix, truth, second)[0] > 100.0
    assert abs(abs(np.degrees(result.rotation)) - 180.0) < 2.0
    assert result.evidence["close_confidence"] < 0.5 <= result.evidence["close_fit"]
    assert not result.accepted
    assert result.reason == MIRROR_REASON


def test_refusals_say_why_in_words() -> None:
    # One straight wall: the maps could slide along it.
    grid = np.full((100, 160), -1, dtype=np.int8)
    grid[30:70, :] = 0
    grid[50, 20:140] = 100
    wall, _ = turned(grid, 30.0, (4.0, 2.0))
    result = merging.estimate_transform(grid, wall)
    assert not result.accepted and result.reason.startswith("only one wall")
    assert result.evidence["close_constraint"] < 0.5
    # A bare square room: every quarter turn fits.
    room = np.full((120, 120), -1, dtype=np.int8)
    room[10:110, 10:110] = 0
    room[10, 10:110] = room[109, 10:110] = room[10:110, 10] = room[10:110, 109] = 100
    quarter, _ = turned(room, 90.0, (0.0, 0.0))
    result = merging.estimate_transform(room, quarter)
    assert not result.accepted and result.reason.startswith("ambiguous")
    assert f"{result.evidence['runner_up_distance_cells']:.0f} cells away" in result.reason
    # No digits but that distance and the turn: the numbers are in the evidence.
    assert sum(ch.isdigit() for ch in result.reason) <= 6


def test_coarsening_keeps_every_wall_and_the_frame() -> None:
    cells = np.full((7, 9), -1, dtype=np.int8)
    cells[0:2, 0:2] = 0
    cells[5, 7] = 100
    coarse = coarsen_cells(cells, 2.0)
    assert coarse.shape == (4, 5)
    assert coarse[0, 0] == 0 and coarse[2, 3] == 100 and coarse[3, 4] == -1
    odd = coarsen_cells(cells, 1.5)
    assert (odd == 100).sum() == 1
    # Cell centres keep their place in metres: fine cell x at (x + 0.5) r, coarse x' at
    # (x' + 0.5) 2r.
    point = apply_transform(scale_matrix(2.0), np.array([[3.0, 5.0]]))[0]
    assert np.allclose((point + 0.5) * 2.0, [3.5, 5.5])


def test_tolerant_fit_meets_walls_a_few_cells_apart() -> None:
    # Map 2's wall drawn 4 cells beside map 1's: a conflict at one cell, met at four.
    first = np.zeros((60, 80), dtype=np.int8)
    first[30, 5:75] = 100
    second = np.zeros((60, 80), dtype=np.int8)
    second[34, 5:75] = 100
    prepared1, prepared2 = prepare_map(first), prepare_map(second)
    strict_agreement, strict_quality = tolerant_fit(prepared1, prepared2, np.eye(3), tolerance=1)
    agreement, quality = tolerant_fit(prepared1, prepared2, np.eye(3), tolerance=4)
    assert strict_agreement == 0.0 and strict_quality < 0.0
    assert agreement == pytest.approx(1.0) and quality == pytest.approx(1.0)


def test_open_space_on_open_space() -> None:
    grid = synthetic_building(6)
    prepared = prepare_map(grid)
    assert open_consistency(prepared, prepared, np.eye(3)) == pytest.approx(1.0)
    # Shifted by half a room, open space lands on walls and their margins.
    assert open_consistency(prepared, prepared, rigid_matrix(40.0, 25.0, 0.0)) < 0.9


def test_robust_confidence_is_its_weakest_factor() -> None:
    params = RobustParams()
    passing = {
        "margin": 1.0,
        "agreeing": 20000.0,
        "agreement": 0.8,
        "quality": 0.2,
        "open_share": 0.7,
        "open_consistency": 0.95,
        "strength": 30.0,
    }
    value, factors = robust_confidence(passing, params)
    assert value > 0.9 and set(factors) == set(passing)
    for name, low in (("margin", 0.1), ("agreeing", 3000.0), ("open_consistency", 0.85)):
        value, factors = robust_confidence({**passing, name: low}, params)
        assert value < 0.5 and value == factors[name]


@pytest.mark.parametrize(("seed", "shared"), [(7, 20), (8, 10)])
def test_robust_measures_left_out_only_when_they_cannot_matter(
    monkeypatch: pytest.MonkeyPatch, seed: int, shared: int
) -> None:
    # Two halves of a building sharing a strip: the close fit fails and a free
    # factor of the robust way is already below it, so its costly measures are
    # skipped; measured in full, they give the same confidence and reason.
    grid = synthetic_building(seed)
    half = grid.shape[1] // 2
    first, second = grid[:, : half + shared], grid[:, half - shared :]
    quick = merging.estimate_transform(first, second)
    assert "robust_confidence" not in quick.evidence
    assert "tolerant_open_consistency" not in quick.evidence
    measured_in_full = verdict._robust

    def in_full(*args, **kwargs):
        return measured_in_full(*args, **{**kwargs, "at_most": -1.0})

    monkeypatch.setattr(verdict, "_robust", in_full)
    full = merging.estimate_transform(first, second)
    assert full.evidence["robust_confidence"] <= full.evidence["close_confidence"]
    assert (quick.confidence, quick.reason, quick.accepted) == (
        full.confidence,
        full.reason,
        full.accepted,
    )
    assert np.array_equal(quick.matrix, full.matrix)
