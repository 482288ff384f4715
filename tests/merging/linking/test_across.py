"""A pair that joins two linked groups is checked against the maps across the join."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from merging import link_maps
from merging.linking.across import conflict_across
from merging.params import DEFAULT_LINKING, LinkingParams
from merging.transforms import rigid_matrix
from tests.merging.builders import synthetic_building
from tests.merging.linking.test_forest import table_pairs

BUILDING = synthetic_building(5)
"""The floor the four grids are cut from (260 x 360 cells)."""
COLUMNS = (0, 60, 120, 160)
"""Per grid, the building's column its window starts at: each window (all rows, 200
columns) overlaps every other one."""


def grids() -> list[np.ndarray]:
    return [BUILDING[:, c : c + 200].copy() for c in COLUMNS]


def truth(i: int, j: int) -> np.ndarray:
    """The matrix taking grid j's cells to grid i's."""
    return rigid_matrix(float(COLUMNS[j] - COLUMNS[i]), 0.0, 0.0)


WRONG = rigid_matrix(0.0, 37.0, 0.0)
"""A wrong placement's error: 37 cells down the building."""


def two_groups_and(join: np.ndarray, confidence: float = 0.7) -> dict:
    """Grids 0-1 and 2-3 linked by right, confident pairs; grid 1 on grid 2 by ``join``."""
    return {
        (0, 1): (truth(0, 1), 0.9, True),
        (2, 3): (truth(2, 3), 0.9, True),
        (1, 2): (join, confidence, True),
    }


def test_a_wrong_join_of_two_groups_is_dropped_by_the_maps_across_it() -> None:
    linking = link_maps(grids(), table_pairs(two_groups_and(truth(1, 2) @ WRONG)))
    assert linking.dropped == ((1, 2),)
    assert linking.groups == ((0, 1), (2, 3))
    (note,) = [n for n in linking.notes if "pair 1-2" in n]
    assert "placed through it" in note and "open space" in note


def test_a_right_join_of_two_groups_is_kept() -> None:
    linking = link_maps(grids(), table_pairs(two_groups_and(truth(1, 2))))
    assert linking.dropped == ()
    assert linking.groups == ((0, 1, 2, 3),)
    np.testing.assert_allclose(linking.relative(0, 3), truth(0, 3), atol=1e-9)


def test_the_join_of_two_single_maps_is_left_to_the_pair() -> None:
    # Nothing lies across a join of two maps linked to nothing else.
    table = {(1, 2): (truth(1, 2) @ WRONG, 0.7, True)}
    linking = link_maps(grids(), table_pairs(table))
    assert linking.dropped == ()
    assert (1, 2) in linking.tree


def test_the_most_confident_pairs_join_first() -> None:
    # The wrong pair, more confident than the right one joining the same groups, joins
    # first; the right one then contradicts it and is dropped: blame goes by confidence.
    table = {
        **two_groups_and(truth(1, 2) @ WRONG, confidence=0.95),
        (0, 3): (truth(0, 3), 0.6, True),
    }
    linking = link_maps(grids(), table_pairs(table))
    assert (1, 2) in linking.tree
    assert (0, 3) in linking.dropped


def test_the_share_of_walls_on_open_space_is_a_setting() -> None:
    lenient = replace(DEFAULT_LINKING, across_conflict=1.0)
    linking = link_maps(grids(), table_pairs(two_groups_and(truth(1, 2) @ WRONG)), params=lenient)
    assert linking.dropped == ()
    assert linking.groups == ((0, 1, 2, 3),)


def test_maps_that_bend_are_not_judged_across() -> None:
    pairs = table_pairs(two_groups_and(truth(1, 2) @ WRONG))
    bent_evidence = {"robust_confidence": 0.7, "close_confidence": 0.1}
    pairs[(1, 2)] = replace(pairs[(1, 2)], evidence=bent_evidence)
    assert link_maps(grids(), pairs).dropped == ()


@pytest.mark.parametrize(
    ("field", "value"),
    [("across_conflict", 1.5), ("across_conflict", -0.1), ("across_overlap_cells", -1.0)],
)
def test_the_settings_are_checked(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        LinkingParams(**{field: value})


def test_conflict_across_measures_what_the_check_weighs() -> None:
    pairs = table_pairs(two_groups_and(truth(1, 2) @ WRONG))
    links = {key: pairs[key] for key in ((0, 1), (2, 3))}
    cells = grids()
    wrong = conflict_across(cells, links, (1, 2), pairs[(1, 2)], params=DEFAULT_LINKING)
    right = replace(pairs[(1, 2)], matrix=truth(1, 2))
    kept = conflict_across(cells, links, (1, 2), right, params=DEFAULT_LINKING)
    assert wrong is not None and kept is not None
    assert wrong >= DEFAULT_LINKING.across_conflict > 0.05 > kept
    # a join of two maps linked to nothing else, or a cycle, has nothing across it
    assert conflict_across(cells, {}, (1, 2), right, params=DEFAULT_LINKING) is None
    cycle = {**links, (1, 2): right}
    assert conflict_across(cells, cycle, (0, 3), pairs[(0, 1)], params=DEFAULT_LINKING) is None
