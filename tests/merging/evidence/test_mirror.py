"""Evidence that looks the same in a mirror is refused: it cannot tell a place from its twin."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import merging
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from merging.evidence.mirror import (
    MirrorCandidates,
    mirror_share,
    mirrored_part,
    overlap_region,
    region_net,
    twin_ground,
)
from merging.evidence.verdict import MIRROR_REASON
from merging.evidence.verify import prepare_map
from merging.grid import observed_part
from merging.params import DEFAULT_PARAMS
from merging.tomographic import judging
from merging.transforms import rigid_matrix
from tests.merging.builders import synthetic_building

TWIN_WALLS = Path(__file__).parent / "data" / "twin_walls.npz"
"""Grids of two robots of a simulated team (generated floor 2, six robots, seed 0, step
350) and the true transform between them (map 2 cells -> map 1 cells): the rooms each
mapped lie side by side, a corridor apart, and their outer walls run parallel."""

SEAM_MARGIN = 12
"""Cells cut off the synthetic building's bottom and right, so that the mirrored copies
joined there form one building, open across the seams."""


def mirror_symmetric_building(seed: int) -> np.ndarray:
    """A building symmetric about a horizontal and a vertical axis through its centre.

    A quarter of a synthetic (chiral) building, mirrored across its bottom and
    right edges: like a round crossing of corridors, each half is the other
    turned by half a turn, and each window straddling an axis looks the same
    in a mirror.
    """
    quarter = synthetic_building(seed, shape=(200, 240))[:-SEAM_MARGIN, :-SEAM_MARGIN]
    top = np.hstack([quarter, quarter[:, ::-1]])
    return np.vstack([top, top[::-1, :]])


def side_by_side(world: np.ndarray, half_height: int, width: int, overlap: int):
    """Windows left and right of the vertical axis, straddling the horizontal one.

    Returns map 1, map 2 and the truth (map 2 cells -> map 1 cells): map 2 is
    map 1's mirror twin across the vertical axis, overlapping it by
    ``overlap`` columns.
    """
    rows, cols = world.shape
    centre_row, centre_col = rows // 2, cols // 2
    top, bottom = centre_row - half_height, centre_row + half_height
    left = centre_col - width + overlap // 2
    first = world[top:bottom, left : left + width]
    second = world[top:bottom, centre_col - overlap // 2 : centre_col - overlap // 2 + width]
    shift = (centre_col - overlap // 2) - left
    return first, second, rigid_matrix(float(shift), 0.0, 0.0)


def test_mirror_symmetric_windows_are_each_others_half_turn() -> None:
    # The premise of the case: map 2 is exactly map 1 turned by half a turn.
    world = mirror_symmetric_building(5)
    first, second, _ = side_by_side(world, 80, 160, 20)
    assert np.array_equal(second, first[::-1, ::-1])


def test_half_turn_of_mirror_twins_is_refused_as_ambiguous() -> None:
    world = mirror_symmetric_building(5)
    first, second, truth = side_by_side(world, 80, 160, 20)
    result = merging.estimate_transform(first, second)
    # The half turn fits wall for wall; the truth overlaps 20 columns.
    assert transform_error(result.matrix, truth, second)[0] > 50.0
    assert abs(abs(np.degrees(result.rotation)) - 180.0) < 1.0
    assert not result.accepted
    assert result.reason == MIRROR_REASON
    assert result.evidence["mirror_share"] > 0.9
    assert "mirror" in result.timings


def test_a_chiral_half_turned_copy_is_accepted() -> None:
    # The same window turned by half a turn, but of a building that differs from its
    # mirror image: the mirrored map explains little of the evidence.
    grid = synthetic_building(5, shape=(200, 240))
    first = grid[20:180, 30:190]
    second = np.ascontiguousarray(first[::-1, ::-1])
    result = merging.estimate_transform(first, second)
    truth = rigid_matrix(159.0, 159.0, np.pi)
    assert transform_error(result.matrix, truth, second)[0] < 1.0
    assert result.accepted
    assert result.evidence["mirror_share"] < 0.5


def test_mirror_share_measures_how_alike_the_evidence_is_in_a_mirror() -> None:
    world = mirror_symmetric_building(5)
    centre_row = world.shape[0] // 2
    symmetric = world[centre_row - 80 : centre_row + 80, 60:220]  # across one axis only
    assert np.array_equal(symmetric, symmetric[::-1])
    chiral = synthetic_building(5)
    for grid, low, high in ((symmetric, 0.95, 1.0001), (chiral, 0.0, 0.5)):
        prepared = prepare_map(grid)
        part = mirrored_part(prepared, prepared, np.eye(3), margin=5)
        crop, (left, top) = observed_part(grid)
        assert np.array_equal(part.mirrored.cells, crop[:, ::-1])
        rows, cols = crop.shape
        # A window symmetric across its horizontal axis, seen in a mirror, is itself
        # turned by half a turn: that rigid placement lays the mirrored part on it.
        half_turn = rigid_matrix(left + cols - 1.0, top + rows - 1.0, np.pi)
        candidates = MirrorCandidates(part, (half_turn,))
        share = mirror_share(prepared, prepared, np.eye(3), candidates)
        assert low <= share <= high, share
        nothing = MirrorCandidates(part, ())
        assert mirror_share(prepared, prepared, np.eye(3), nothing) == 0.0


def test_mirrored_part_keeps_what_the_placement_lays_on_map_1() -> None:
    grid = synthetic_building(6)
    prepared = prepare_map(grid)
    shift = rigid_matrix(100.0, 0.0, 0.0)  # map 2's column x lies on map 1's x + 100
    part = mirrored_part(prepared, prepared, shift, margin=5)
    assert np.array_equal(part.overlap, overlap_region(prepared, prepared, shift))
    # Map 2 keeps its left part, up to 5 columns beyond what lands on map 1.
    known_cols = np.flatnonzero((grid >= 0).any(axis=0))
    assert part.mirrored.shape[1] == known_cols[-1] - 100 + 5 - known_cols[0] + 1
    # Unmirrored and placed, the part shows the evidence inside the overlap that the
    # whole map 2 does.
    kept = region_net(prepared, part.mirrored, shift @ part.unmirror, part.overlap)
    assert kept == pytest.approx(region_net(prepared, prepared, shift, part.overlap), rel=0.02)


def test_region_net_counts_only_inside_the_region() -> None:
    grid = synthetic_building(6)
    prepared = prepare_map(grid)
    everywhere = overlap_region(prepared, prepared, np.eye(3))
    assert np.array_equal(everywhere, grid >= 0)
    whole = region_net(prepared, prepared, np.eye(3), everywhere)
    # Identical maps: every wall cell agrees, both ways.
    assert whole == pytest.approx(2 * np.count_nonzero(grid >= 65), rel=0.01)
    left = everywhere.copy()
    left[:, grid.shape[1] // 2 :] = False
    assert 0.2 * whole < region_net(prepared, prepared, np.eye(3), left) < 0.8 * whole
    # Walls counted as met within a wider tolerance: the same for identical maps.
    assert region_net(prepared, prepared, np.eye(3), everywhere, tolerance=3) == whole


def test_twin_ground_is_map_1_around_a_small_overlap() -> None:
    grid = synthetic_building(6)
    prepared = prepare_map(grid)
    shift = rigid_matrix(300.0, 0.0, 0.0)  # map 2's column x on map 1's x + 300
    part = mirrored_part(prepared, prepared, shift, margin=5)
    ground = twin_ground(prepared, part)
    assert ground is not None
    cells, (left, top) = ground
    overlap_cols = np.flatnonzero(part.overlap.any(axis=0))
    assert left == overlap_cols[0] - 5
    window = grid[int(top) : int(top) + cells.shape[0], int(left) : int(left) + cells.shape[1]]
    assert np.array_equal(cells.cells, window)
    # Around (nearly) the whole map 1, map 1 is searched whole.
    assert twin_ground(prepared, mirrored_part(prepared, prepared, np.eye(3), margin=5)) is None


def test_a_twin_beside_a_shared_wall_is_refused(monkeypatch) -> None:
    # The best placement lays map 2's rooms beside map 1's, sharing one outer wall and a
    # corridor's walls, a corridor's width from the truth. That evidence looks the same
    # in a mirror (a straight wall mirrored about itself), but the mirrored part's best
    # fits on the whole map 1 lie elsewhere: only a search around the overlap finds
    # its twin there.
    data = np.load(TWIN_WALLS)
    first, second, truth = data["map1"], data["map2"], data["truth"]
    # The pair was drawn for the search taking shifts by the collected mass alone,
    # without map 1's walls counted against map 2's clear space, whose best placement
    # is the twin's; with either, a rival placement refuses it before the mirror is
    # looked at.
    by_mass = replace(DEFAULT_PARAMS.translation, significant_peaks=0, reverse_penalty=0.0)
    params = replace(DEFAULT_PARAMS, translation=by_mass)
    result = merging.estimate_transform(first, second, params=params)
    assert transform_error(result.matrix, truth, second)[0] > 30.0
    assert not result.accepted
    assert result.reason == MIRROR_REASON
    assert result.evidence["mirror_share"] > 0.7
    # Searched for on the whole map 1, the twin is missed and the placement accepted.
    monkeypatch.setattr(judging, "twin_ground", lambda *args, **kwargs: None)
    missed = merging.estimate_transform(first, second, params=params)
    assert missed.accepted and missed.evidence["mirror_share"] < 0.1


def test_a_narrow_vouch_is_not_refused_in_the_mirrors_name(maps_folder) -> None:
    # A window pair of intel sharing 15-20 % (the benchmark's moderate-overlap suite,
    # seed 41, pair 19): the close fit vouches for the right placement narrowly (its
    # constraint is weak), and map 2 seen in a mirror explains under half of the
    # evidence, a clear pass. The mirror check caps the confidence; as a sixth factor of
    # the fit it took the last thousandth off and refused the pair in the mirror's name.
    # (The suite cuts 50 pairs; the first 20 of the same seed are the same pairs.)
    whole = merging.load_map(maps_folder / "intel.yaml").data
    pair = cut_window_pairs(whole, count=20, overlap_range=(0.15, 0.20), rng=41)[19]
    result = merging.estimate_transform(pair.map1, pair.map2)
    assert transform_error(result.matrix, pair.truth, pair.map2)[0] < 1.0
    assert result.evidence["mirror_share"] < 0.5
    accept = DEFAULT_PARAMS.confidence.accept
    assert accept <= result.evidence["close_confidence"] < result.evidence["close_mirror"]
    # Refined the other way round it lands 0.4 cells away: accepted. (Before the
    # significant shifts counted map 1's walls in map 2's clear space, the search
    # placed it where that took it to 0.598, just short of the threshold.)
    assert result.accepted
    assert result.reason != MIRROR_REASON
