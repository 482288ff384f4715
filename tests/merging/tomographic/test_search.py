"""The default merger recovers known transforms, with the sign pinned, and says when it cannot."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import merging
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from merging.evidence.verify import Verification, prepare_map
from merging.params import DEFAULT_PARAMS
from merging.tomographic import candidates, judging, restarts, search
from merging.tomographic.correlate import _suppress, coarsen, translation_peaks
from merging.transforms import matrix_to_pose, rigid_matrix
from tests.merging.builders import synthetic_building, turned

RIGHT_CELLS = 2.0
"""A transform is right when it puts map 2's walls within 2 cells RMS of the truth."""


@pytest.mark.parametrize("degrees", [-179.0, -135.0, -90.0, -33.0, 0.0, 12.5, 71.0, 118.0, 180.0])
def test_recovers_rotations_over_the_full_circle(building: np.ndarray, degrees: float) -> None:
    map2, truth = turned(building, degrees, (7.0, -11.0))
    result = merging.estimate_transform(building, map2)
    rms, rotation_error = transform_error(result.matrix, truth, map2)
    assert rms < RIGHT_CELLS
    assert result.accepted
    # Sign pinned: map 2 shows map 1 turned by +degrees, so T turns by -degrees.
    assert np.isclose(
        np.rad2deg(np.angle(np.exp(1j * (result.rotation + np.deg2rad(degrees))))), 0.0, atol=0.5
    )
    assert rotation_error < 0.5


def test_identity_for_identical_maps(building: np.ndarray) -> None:
    result = merging.estimate_transform(building, building)
    dx, dy, theta = matrix_to_pose(result.matrix)
    assert abs(dx) < 0.5 and abs(dy) < 0.5 and abs(theta) < np.deg2rad(0.2)
    assert result.accepted and result.confidence > 0.9


def test_subcell_accuracy_on_a_pure_shift() -> None:
    grid = synthetic_building(8)
    map2, truth = turned(grid, 0.0, (3.0, 5.0))
    result = merging.estimate_transform(grid, map2)
    assert transform_error(result.matrix, truth, map2)[0] < 0.5


def test_symmetric_room_is_not_accepted() -> None:
    # A bare square room looks the same after every quarter turn: any answer is a guess.
    grid = np.full((120, 120), -1, dtype=np.int8)
    grid[10:110, 10:110] = 0
    grid[10, 10:110] = grid[109, 10:110] = 100
    grid[10:110, 10] = grid[10:110, 109] = 100
    map2, _ = turned(grid, 90.0, (0.0, 0.0))
    result = merging.estimate_transform(grid, map2)
    assert not result.accepted
    assert result.reason


def test_single_wall_is_not_accepted() -> None:
    # One straight wall fixes neither the position along it nor, well, much else.
    grid = np.full((100, 160), -1, dtype=np.int8)
    grid[30:70, :] = 0
    grid[50, 20:140] = 100
    map2, _ = turned(grid, 30.0, (4.0, 2.0))
    result = merging.estimate_transform(grid, map2)
    assert not result.accepted


def test_maps_of_different_places_are_not_accepted() -> None:
    result = merging.estimate_transform(synthetic_building(1), synthetic_building(2))
    assert not result.accepted


def test_a_rotation_band_past_the_maps_is_named_in_the_refusal(building: np.ndarray) -> None:
    # The reason once blamed the maps alone ("too small to hold a wall direction").
    params = replace(
        DEFAULT_PARAMS, rotation=replace(DEFAULT_PARAMS.rotation, min_frequency=1_000_000)
    )
    result = merging.estimate_transform(building, building, params=params)
    assert not result.accepted
    assert "rotation.min_frequency 1000000" in result.reason


def test_reports_stage_timings_and_hypotheses(building: np.ndarray) -> None:
    map2, _ = turned(building, 40.0, (0.0, 0.0))
    result = merging.estimate_transform(building, map2)
    assert {"rotation", "translation", "refine", "total"} <= set(result.timings)
    assert len(result.hypotheses) >= 2
    assert result.hypotheses[0].score >= result.hypotheses[1].score


@pytest.mark.slow
def test_window_pairs_of_real_maps(maps_folder) -> None:
    # The section 4.1 protocol on two real maps: every accepted merge must be right.
    right = accepted_wrong = 0
    total = 0
    for name in ("intel", "aces3"):
        whole = merging.load_map(maps_folder / f"{name}.yaml")
        for pair in cut_window_pairs(whole.data, count=4, rng=17):
            result = merging.estimate_transform(pair.map1, pair.map2)
            good = transform_error(result.matrix, pair.truth, pair.map2)[0] <= RIGHT_CELLS
            right += good
            accepted_wrong += result.accepted and not good
            total += 1
    assert accepted_wrong == 0
    assert right >= total - 1


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"count": -2}, "count must be a whole number"),
        ({"count": 2.5}, "count must be a whole number"),
        ({"count": 1, "overlap_range": (0.5, 0.2)}, "overlap_range must be"),
        ({"count": 1, "size_fraction": (0.3, 1.5)}, "size_fraction must be"),
    ],
)
def test_window_pairs_refuse_impossible_requests_at_once(building, options, message) -> None:
    # A negative count was never reached: the search ran its 20000 tries, keeping pairs.
    with pytest.raises(ValueError, match=message):
        cut_window_pairs(building, **options)


def test_real_map_turned_by_known_angles(maps_folder) -> None:
    whole = merging.load_map(maps_folder / "intel.yaml").data
    for degrees in (-150.0, 65.0):
        map2, truth = turned(whole, degrees, (5.0, 12.0))
        result = merging.estimate_transform(whole, map2)
        assert transform_error(result.matrix, truth, map2)[0] < RIGHT_CELLS
        assert result.accepted


@pytest.mark.parametrize("degrees", [0.0, 17.0, 90.0, 133.0, 251.0])
def test_half_turn_twin_from_one_transform(building: np.ndarray, degrees: float) -> None:
    # The twin's peaks come from a convolution with the unturned image; they must be
    # the peaks a correlation with the image turned by the further half turn finds.
    first = coarsen(prepare_map(building[:, :200]), 3)
    second = coarsen(prepare_map(building[40:, 120:]), 3)
    theta = np.deg2rad(degrees)
    _, twin = translation_peaks(first, second, theta, count=3)
    direct, _ = translation_peaks(first, second, theta + np.pi, count=3)
    assert len(twin) == len(direct) == 3
    for twin_peak, peak in zip(twin, direct, strict=True):
        assert np.allclose(twin_peak.matrix, peak.matrix, atol=1e-9)
        assert twin_peak.mass == pytest.approx(peak.mass, abs=1e-5)


@pytest.mark.parametrize("degrees", [0.0, 90.0, 133.0])
def test_half_turn_twin_of_the_significant_shifts(building: np.ndarray, degrees: float) -> None:
    # Map 1's walls on map 2's clear blocks enter the twin's surface by a convolution
    # too: its significant peaks must be those of the image turned a further half turn.
    first = coarsen(prepare_map(building[:, :200]), 3)
    second = coarsen(prepare_map(building[40:, 120:]), 3)
    theta = np.deg2rad(degrees)
    _, twin = translation_peaks(first, second, theta, count=1, significant=3)
    direct, _ = translation_peaks(first, second, theta + np.pi, count=1, significant=3)
    assert len(twin) == len(direct) == 4
    for twin_peak, peak in zip(twin, direct, strict=True):
        assert twin_peak.significance == pytest.approx(peak.significance, abs=1e-5)
        assert twin_peak.mass == pytest.approx(peak.mass, abs=1e-5)


def test_significance_is_the_mass_less_map_1s_walls_in_map_2s_clear_space(
    building: np.ndarray,
) -> None:
    first = coarsen(prepare_map(building[:, :200]), 3)
    second = coarsen(prepare_map(building[40:, 120:]), 3)
    peaks, _ = translation_peaks(first, second, 0.0, count=1, significant=4, reverse_penalty=2.0)
    clear = {(int(x), int(y)) for x, y in second.clear_points}
    low, high = second.points.min(axis=0), second.points.max(axis=0)
    scale = np.array([[3.0, 0.0, 1.0], [0.0, 3.0, 1.0], [0.0, 0.0, 1.0]])  # block centres
    for peak in peaks[1:]:
        # Map 1's wall blocks carried into map 2's blocks by the peak's shift.
        back = np.linalg.inv(scale) @ np.linalg.inv(peak.matrix) @ scale
        carried = np.rint(first.points @ back[:2, :2].T + back[:2, 2]).astype(int)
        inside = (carried >= low).all(axis=1) & (carried <= high).all(axis=1)
        landing = sum((int(x), int(y)) in clear for x, y in carried[inside])
        expected = peak.mass - 2.0 * landing / len(second.points)
        assert peak.significance == pytest.approx(expected, abs=1e-4)
    assert any(peak.significance < peak.mass for peak in peaks[1:])


@pytest.mark.parametrize(("row", "col"), [(5, 7), (0, 0), (1, 18), (9, 19), (4, 2)])
def test_peak_suppression_wraps_around_the_surface(row: int, col: int) -> None:
    surface = np.zeros((10, 20), dtype=np.float32)
    _suppress(surface, row, col, 2)
    expected = np.zeros_like(surface)
    rows = np.arange(row - 2, row + 3) % 10
    cols = np.arange(col - 2, col + 3) % 20
    expected[np.ix_(rows, cols)] = -np.inf
    assert np.array_equal(surface, expected)


def test_a_placement_judged_after_the_winner_is_refined_as_finely() -> None:
    # A placement the schedule left on the widest field, a cell and a half and 0.4 degrees
    # off, is brought to within a fraction of a cell before it is judged.
    grid = synthetic_building(8)
    map2, truth = turned(grid, 20.0, (5.0, -3.0))
    maps = candidates.SearchMaps(prepare_map(grid), prepare_map(map2), DEFAULT_PARAMS)
    start = rigid_matrix(1.2, -0.9, np.deg2rad(0.4)) @ truth
    _, finished = candidates.finished(maps, (maps.verify(start), start))
    assert transform_error(finished, truth, map2)[0] < 0.3 < transform_error(start, truth, map2)[0]


def test_a_small_overlap_judged_second_is_placed_to_the_cell(maps_folder) -> None:
    # Windows of fr079 sharing 3-15 % (bench_real_maps.py low-overlap --seed 5005, pair 15):
    # the score ranks a loose large overlap first, the verdict refuses it and judges the
    # exact small one, which the schedule had refined on its widest field only. Judged
    # there it was accepted 2.05 cells off; refined as the winner is, it is 0.2 off.
    whole = merging.load_map(maps_folder / "fr079.yaml").data
    pair = cut_window_pairs(whole, count=16, overlap_range=(0.03, 0.15), rng=5005)[15]
    result = merging.estimate_transform(pair.map1, pair.map2)
    rms = transform_error(result.matrix, pair.truth, pair.map2)[0]
    assert not result.accepted or rms < 1.0


def test_a_placement_pinned_by_a_whole_building_has_no_near_rival() -> None:
    grid = synthetic_building(8)
    map2, truth = turned(grid, 20.0, (5.0, -3.0))
    maps = candidates.SearchMaps(prepare_map(grid), prepare_map(map2), DEFAULT_PARAMS)
    assert restarts.turned_rival(maps, truth) is None


def test_a_small_overlap_with_a_near_rival_optimum_is_refused(maps_folder) -> None:
    # Windows of fr079 sharing 3-15 % (bench_real_maps.py low-overlap --seed 1313, pair 12):
    # a search whose significant shifts were ranked by the mass over the landing walls
    # placed it 3.6 cells off, turned 1.2 degrees, where the walls meet closely; turned
    # back about the overlap and refined, that placement finds the truth, which explains
    # as much. (The search ranking them by the net mass places it elsewhere, refused;
    # ranked by fit alone, step 7, the truth is found and accepted.)
    whole = merging.load_map(maps_folder / "fr079.yaml").data
    pair = cut_window_pairs(whole, count=13, overlap_range=(0.03, 0.15), rng=1313)[12]
    first_look = replace(DEFAULT_PARAMS, fit_ranked=False)
    assert not merging.estimate_transform(pair.map1, pair.map2, params=first_look).accepted
    placed = np.array([[0.110898516, 0.993831736, 579.285004], [-0.993831736, 0.110898516,
                       226.151372], [0.0, 0.0, 1.0]])  # fmt: skip
    assert 3.0 < transform_error(placed, pair.truth, pair.map2)[0] < 4.0
    maps = candidates.SearchMaps(prepare_map(pair.map1), prepare_map(pair.map2), DEFAULT_PARAMS)
    rival = restarts.turned_rival(maps, placed)
    assert rival is not None
    assert transform_error(rival[1], pair.truth, pair.map2)[0] < 2.0


HELD_BY_THE_REFINEMENT = {
    # Windows of intel sharing 3-15 % (bench_real_maps.py low-overlap --seed 4242, pair
    # 13): the curvature holds the turn weakly (strength 3), yet started turned by 2 and
    # 4 cells either way the refinement comes back within about half a cell: accepted, a
    # cell off. Asked to come back within a tenth of a cell, it is refused for the turn.
    "turn": ("intel", 4242, 13, "turn_return_cells", 0.1,
             "the overlap is too short to hold map 2's turn"),
    # Windows of fr079 (--seed 12345, pair 42): sliding 2 or 4 cells costs only 30 net
    # cells and the curvature holds the turn weakly (strength 4), yet started slid in
    # each direction, and turned, the refinement comes back within a tenth of a cell:
    # accepted, a quarter of a cell off. Asked to come back from the slides within a
    # hundredth of a cell, it is refused for the slide.
    "slide": ("fr079", 12345, 42, "slide_return_cells", 0.01,
              "only one wall or corridor to align on: started slid"),
}  # fmt: skip
"""Real low-overlap windows accepted only because the refinement comes back, by what it
holds: (map, seed, pair, the measure and its strict setting, the strict refusal)."""


@pytest.mark.parametrize("held", sorted(HELD_BY_THE_REFINEMENT))
def test_a_small_overlap_the_refinement_holds_is_accepted(maps_folder, held: str) -> None:
    name, seed, index, measure, strict_cells, refusal = HELD_BY_THE_REFINEMENT[held]
    whole = merging.load_map(maps_folder / f"{name}.yaml").data
    pair = cut_window_pairs(whole, count=index + 1, overlap_range=(0.03, 0.15), rng=seed)[index]
    result = merging.estimate_transform(pair.map1, pair.map2)
    assert result.accepted
    assert transform_error(result.matrix, pair.truth, pair.map2)[0] < 2.0
    # The verdict on the true placement, whichever optimum near it the search reached.
    held = search.refine_from(pair.map1, pair.map2, pair.truth)
    assert held.accepted
    assert held.evidence[measure] < getattr(DEFAULT_PARAMS.confidence, measure)
    confidence = replace(DEFAULT_PARAMS.confidence, **{measure: strict_cells})
    refused = search.refine_from(
        pair.map1, pair.map2, pair.truth, params=replace(DEFAULT_PARAMS, confidence=confidence)
    )
    assert not refused.accepted
    assert refused.reason.startswith(refusal)


@pytest.mark.parametrize(("seed", "index"), [(12345, 48), (2026, 59)])
def test_a_runner_up_that_only_lacked_the_narrow_fields_is_no_rival(
    maps_folder, monkeypatch, seed: int, index: int
) -> None:
    # Windows of intel sharing 3-15 % (bench_real_maps.py low-overlap --seed SEED, pair
    # INDEX): the runner-up 11-14 cells away, turned 4-5 degrees, was refined on the wide
    # fields only and explains about as much; refined on, it lands on the winner. With
    # it kept as a rival the placement is refused as ambiguous.
    whole = merging.load_map(maps_folder / "intel.yaml").data
    pair = cut_window_pairs(whole, count=index + 1, overlap_range=(0.03, 0.15), rng=seed)[index]
    result = merging.estimate_transform(pair.map1, pair.map2)
    assert result.accepted
    assert transform_error(result.matrix, pair.truth, pair.map2)[0] < 1.0
    monkeypatch.setattr(judging, "rivals_that_stay", lambda maps, pool: pool)
    kept = merging.estimate_transform(pair.map1, pair.map2)
    assert not kept.accepted
    assert kept.reason.startswith("ambiguous: another placement about as good lies 1")


def test_a_slide_return_stops_at_the_first_restart_that_strays() -> None:
    # A single straight wall: slid 4 cells across it, beyond the narrow field's reach,
    # the refinement stays where it was started, its walls on the other map's open
    # space: in conflict, such a restart counts as not back.
    grid = np.full((60, 80), -1, dtype=np.int8)
    grid[20:40, 5:75] = 0
    grid[30, 5:75] = 100
    maps = candidates.SearchMaps(prepare_map(grid), prepare_map(grid), DEFAULT_PARAMS)
    strayed = restarts.slide_return(maps, np.eye(3), 0.5)
    assert strayed > 0.5
    assert restarts.slide_return(maps, np.eye(3), np.inf) >= strayed


@pytest.mark.parametrize(("settled_net", "held"), [(850.0, True), (960.0, False), (-50.0, False)])
def test_a_slid_restart_settling_on_a_worse_optimum_counts_as_coming_back(
    settled_net: float, held: bool
) -> None:
    # Every restart comes back to the placement but one, which settles 5 cells away on
    # an optimum explaining 15 % less (a worse optimum: the slide is held), 4 % less
    # (about as much: a second answer, not held), or in conflict (out of the narrow
    # field's reach, which says nothing for the placement: not held).
    far = rigid_matrix(5.0, 0.0, 0.0)
    nets = {0.0: 1000.0, 5.0: settled_net}

    class Maps:
        params = DEFAULT_PARAMS
        second = prepare_map(synthetic_building(5))

        def verify(self, matrix: np.ndarray) -> Verification:
            net = nets.get(float(matrix[0, 2]), 990.0)
            # Agreement 1: the net is the overlap; a negative one, conflict on one cell.
            if net < 0:
                return Verification(0.0, -net / 3.0, 1.0, 0.0)
            return Verification(1.0, 0.0, net, 0.0)

        def refine(self, candidate, stage, *, keep: bool = True):
            # The largest slide to the right leads to the other optimum.
            end = far if candidate[1][0, 2] >= 4.0 and candidate[1][1, 2] == 0 else np.eye(3)
            return self.verify(end), end

    farthest = restarts.slide_return(Maps(), np.eye(3), 0.75)  # type: ignore[arg-type]
    assert (farthest <= 0.75) is held
    shared = replace(DEFAULT_PARAMS.confidence, slide_settled_share=100.0)
    Maps.params = replace(DEFAULT_PARAMS, confidence=shared)
    assert restarts.slide_return(Maps(), np.eye(3), 0.75) == pytest.approx(5.0)


def test_a_close_alternative_is_held_against_the_rival_explaining_the_most() -> None:
    # Two exact fits of a small overlap far apart (a corridor whose doors repeat) and a
    # loose large overlap the ranking prefers: the close alternative's rival is the exact
    # fit, which explains as much, not the loose one the ranking put first.
    points = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    chosen = (Verification(0.99, 0.0, 520.0, 515.0), np.eye(3))
    loose = (Verification(0.68, 0.25, 1200.0, 816.0), rigid_matrix(40.0, -30.0, 0.5))
    exact = (Verification(1.0, 0.0, 505.0, 505.0), rigid_matrix(-360.0, 60.0, 0.0))
    near = (Verification(0.99, 0.0, 518.0, 513.0), rigid_matrix(1.0, 0.0, 0.0))
    assert exact[0].net > loose[0].net
    pool = [chosen, loose, near, exact]
    distances = (4.0, 10.0)
    by_rank = judging.runners_up_of(pool, points, distances)
    assert by_rank[0] is loose and by_rank[1] is loose
    by_net = judging.runners_up_of(pool, points, distances, by_net=True)
    assert by_net[0] is exact  # the near one is the same answer, closer than 4 cells
    assert by_net[1] is loose  # the robust evidence's rival stays the best-ranked one


def test_a_whole_building_refined_both_ways_lands_in_one_place() -> None:
    grid = synthetic_building(8)
    map2, truth = turned(grid, 20.0, (5.0, -3.0))
    maps = candidates.SearchMaps(prepare_map(grid), prepare_map(map2), DEFAULT_PARAMS)
    between, factor, gap = restarts.both_ways(maps, truth)
    assert gap < 0.5
    assert factor > 0.99
    assert transform_error(between, truth, map2)[0] < 0.5


def test_a_turn_held_only_by_a_sharp_optimum_is_checked_both_ways(maps_folder) -> None:
    # Windows of intel sharing 3-15 % (bench_real_maps.py low-overlap --seed 27182, pair 26),
    # a corner of map 1 turned 45 degrees: started turned, the refinement comes back, but
    # the staircase of the turned walls held it 2.8 cells off. Refined map 1 onto map 2 it
    # lands 1.8 cells away, which costs a third of the confidence: refused (halfway between
    # would have been 1.9 cells off).
    whole = merging.load_map(maps_folder / "intel.yaml").data
    pair = cut_window_pairs(whole, count=27, overlap_range=(0.03, 0.15), rng=27182)[26]
    result = merging.estimate_transform(pair.map1, pair.map2)
    assert "reverse_gap_cells" in result.evidence
    assert not result.accepted or transform_error(result.matrix, pair.truth, pair.map2)[0] < 2.0


def test_a_search_of_the_same_map_1_reuses_its_images_whatever_the_shifts_it_keeps() -> None:
    # The search for the mirror image keeps fewer shifts per rotation
    # (mirror_significant_peaks) and still starts from the first search's fields and
    # coarse images of map 1; images made with other settings are not reused.
    grid = synthetic_building(8)
    first, second = prepare_map(grid), prepare_map(turned(grid, 20.0, (5.0, -3.0))[0])
    maps = candidates.SearchMaps(first, second, DEFAULT_PARAMS)
    fewer = replace(DEFAULT_PARAMS.translation, significant_peaks=0)
    twin = candidates.SearchMaps(
        first, second, replace(DEFAULT_PARAMS, translation=fewer), begun=maps
    )
    assert twin.smoothed is maps.smoothed and twin.coarse_first is maps.coarse_first
    translation = DEFAULT_PARAMS.translation
    blurred = replace(translation, wall_blur=2 * translation.wall_blur)
    with pytest.raises(ValueError, match="wall_blur"):
        candidates.SearchMaps(
            first, second, replace(DEFAULT_PARAMS, translation=blurred), begun=maps
        )


def test_the_truth_held_against_the_search_meets_the_rival_the_search_ranked_first(
    maps_folder,
) -> None:
    # Windows of intel sharing 3-15 % (bench_real_maps.py low-overlap, seed 2026, pair
    # 22): the search's winner lies 355 cells off and is refused. Refined from the truth
    # the overlap vouches for the placement (no search, no rival); judged in the place
    # of the search's winner, the placement the search ranked first is a rival that
    # explains as much, turned half a turn: a perfect search would be refused there. In
    # the pool ranked by fit alone (step 7) that rival shares too little open space to
    # be as good: accepted, as the search itself now is.
    whole = merging.load_map(maps_folder / "intel.yaml").data
    pair = cut_window_pairs(whole, count=23, overlap_range=(0.03, 0.15), rng=2026)[22]
    alone = search.refine_from(pair.map1, pair.map2, pair.truth)
    assert alone.accepted
    first_look = replace(DEFAULT_PARAMS, fit_ranked=False)
    refused = search.refine_from(
        pair.map1, pair.map2, pair.truth, held_against_search=True, params=first_look
    )
    assert not refused.accepted
    assert refused.reason.startswith("ambiguous: another placement about as good lies 355 cells")
    assert transform_error(refused.matrix, pair.truth, pair.map2)[0] < 1.0
    held = search.refine_from(pair.map1, pair.map2, pair.truth, held_against_search=True)
    assert held.accepted and held.evidence["ranked_by_fit"] == 1.0
    assert transform_error(held.matrix, pair.truth, pair.map2)[0] < 1.0
