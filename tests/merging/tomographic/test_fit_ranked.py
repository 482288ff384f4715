"""Step 7 of the default method: a refused pool ranked again by fit alone."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import merging
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from merging.evidence.verify import Verification, confidence_factors
from merging.params import DEFAULT_PARAMS
from merging.tomographic import search
from tests.merging.builders import turned

WALLS_ONLY = Verification(1.0, 0.0, 1000.0, 1000.0, shared_space=800.0)
"""A rival laying as many walls on walls as the best, with a tenth of its open space."""
BEST = Verification(1.0, 0.0, 1000.0, 1000.0, shared_space=8000.0)


def test_a_rival_sharing_little_open_space_is_distinct_only_when_space_counts() -> None:
    confidence = DEFAULT_PARAMS.confidence
    by_walls = confidence_factors(BEST, WALLS_ONLY, params=confidence)[2]
    by_space = confidence_factors(
        BEST, WALLS_ONLY, params=replace(confidence, distinct_by_space=True)
    )[2]
    assert by_walls < 0.01  # the same net wall cells: a coin toss
    assert by_space > 0.99  # a tenth of the open space: 1 - 0.1 is far past the margin
    # A rival sharing more open space than the best is held to its walls as before.
    wider = replace(WALLS_ONLY, shared_space=80000.0)
    spaced = confidence_factors(BEST, wider, params=replace(confidence, distinct_by_space=True))
    assert spaced[2] == by_walls


def test_the_fit_ranking_drops_the_space_preference_and_holds_rivals_to_open_space() -> None:
    ranked = search.fit_ranking(DEFAULT_PARAMS)
    assert ranked.verify.space_preference == 0.0
    assert ranked.confidence.distinct_by_space
    assert replace(ranked, verify=DEFAULT_PARAMS.verify, confidence=DEFAULT_PARAMS.confidence) == (
        DEFAULT_PARAMS
    )
    # Ranking by fit already: no second look to take.
    assert search.fit_ranking(ranked) == ranked


def test_a_small_exact_overlap_ranked_below_a_loose_one_is_accepted_by_fit(maps_folder) -> None:
    # Windows of intel sharing 3-15 % (bench_real_maps.py low-overlap, seed 2026, pair 53).
    # The default ranking's winner is the truth, but a rival 38 cells away, turned a
    # degree, explains about as many wall cells: refused as ambiguous. Ranked by fit
    # alone, the rival shares far less open space than the truth: accepted, to the cell.
    whole = merging.load_map(maps_folder / "intel.yaml").data
    pair = cut_window_pairs(whole, count=54, overlap_range=(0.03, 0.15), rng=2026)[53]
    first_look = merging.estimate_transform(
        pair.map1, pair.map2, params=replace(DEFAULT_PARAMS, fit_ranked=False)
    )
    assert not first_look.accepted
    assert first_look.reason.startswith("ambiguous: another placement about as good lies 38")
    result = merging.estimate_transform(pair.map1, pair.map2)
    assert result.accepted and result.evidence["ranked_by_fit"] == 1.0
    assert "fit_ranked" in result.timings
    assert transform_error(result.matrix, pair.truth, pair.map2)[0] < 1.0
    assert transform_error(first_look.matrix, pair.truth, pair.map2)[0] < 1.0


def test_a_refusal_both_looks_agree_on_keeps_the_first_look_s_reason() -> None:
    # A bare square room looks the same after every quarter turn, however it is ranked.
    grid = np.full((120, 120), -1, dtype=np.int8)
    grid[10:110, 10:110] = 0
    grid[10, 10:110] = grid[109, 10:110] = 100
    grid[10:110, 10] = grid[10:110, 109] = 100
    map2, _ = turned(grid, 90.0, (0.0, 0.0))
    first_look = merging.estimate_transform(
        grid, map2, params=replace(DEFAULT_PARAMS, fit_ranked=False)
    )
    result = merging.estimate_transform(grid, map2)
    assert not result.accepted
    assert result.reason == first_look.reason
    assert 0.0 <= result.evidence["fit_ranked_confidence"] < DEFAULT_PARAMS.confidence.accept
    assert "fit_ranked_confidence" not in first_look.evidence
    np.testing.assert_array_equal(result.matrix, first_look.matrix)


def test_a_second_look_a_rival_outexplains_is_refused() -> None:
    # The square room of the test above, prepared; the looks are stubbed.
    from merging.evidence.verify import prepare_map
    from merging.result import MergeResult
    from merging.tomographic.candidates import SearchMaps

    grid = np.full((60, 60), -1, dtype=np.int8)
    grid[10:50, 10:50] = 0
    grid[10, 10:50] = grid[49, 10:50] = grid[10:50, 10] = grid[10:50, 49] = 100
    prepared = prepare_map(grid)
    maps = SearchMaps(prepared, prepared, DEFAULT_PARAMS)
    refused = MergeResult(np.eye(3), 0.2, False, "tomographic", reason="first look's")
    placed = np.eye(3)
    placed[0, 2] = 5.0
    for margins, accepted in (
        ({"margin": 0.2, "tolerant_margin": 0.2}, True),
        ({"margin": 0.2}, True),  # the robust way was not asked: no tolerant rival
        ({"margin": -0.01, "tolerant_margin": 0.3}, False),  # the close fit's runner-up
        ({"margin": 0.16, "tolerant_margin": -0.01}, False),  # the robust way's
        # a tie to the finest the score ranks (keep_refined_margin, 0.02)
        ({"margin": 0.002, "tolerant_margin": 0.002}, False),
        ({"margin": 0.025, "tolerant_margin": 0.025}, True),
    ):
        looked = MergeResult(placed, 0.85, True, "tomographic", evidence=dict(margins))
        result = search.ranked_by_fit(maps, refused, lambda _maps, looked=looked: looked)
        assert result.accepted is accepted
        if accepted:
            assert result.evidence["ranked_by_fit"] == 1.0
            np.testing.assert_array_equal(result.matrix, placed)
        else:
            assert result.reason == "first look's"
            assert result.evidence["fit_ranked_outexplained"] == 1.0
            assert result.evidence["fit_ranked_confidence"] == 0.85
    # A look refused anyway is not said to be outexplained.
    looked = MergeResult(placed, 0.3, False, "tomographic", evidence={"margin": -0.01})
    result = search.ranked_by_fit(maps, refused, lambda _maps: looked)
    assert not result.accepted and "fit_ranked_outexplained" not in result.evidence
    assert result.evidence["fit_ranked_confidence"] == 0.3
