"""A pair that joins two linked groups is checked against the maps across the join."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from merging import link_maps
from merging.params import DEFAULT_LINKING, LinkingParams
from merging.transforms import rigid_matrix
from merging.warp import warp_cells
from tests.merging.builders import synthetic_building
from tests.merging.linking.test_forest import table_pairs

BUILDING = synthetic_building(5)
"""The floor the grids are cut from (260 x 360 cells)."""
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
BENT = {"robust_confidence": 0.7, "close_confidence": 0.1}
"""Evidence of a placement vouched for as maps that bend (merging.linking.forest.bends)."""


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
    # Of the pairs across (0-2, 0-3, 1-3), maps 0 and 2 lay the most walls on open space.
    (note,) = [n for n in linking.notes if "pair 1-2" in n]
    assert "placed through it and the links already made, maps 0 and 2 lay 44%" in note
    assert note.endswith("on its open space (limit 25%)")
    assert linking.across[(1, 2)] == pytest.approx(0.443, abs=0.005)


def test_a_right_join_of_two_groups_is_kept() -> None:
    linking = link_maps(grids(), table_pairs(two_groups_and(truth(1, 2))))
    assert linking.dropped == ()
    assert linking.groups == ((0, 1, 2, 3),)
    assert linking.across == {(1, 2): 0.0}
    np.testing.assert_allclose(linking.relative(0, 3), truth(0, 3), atol=1e-9)


def test_the_join_of_two_single_maps_is_left_to_the_pair() -> None:
    # Nothing lies across a join of two maps linked to nothing else.
    table = {(1, 2): (truth(1, 2) @ WRONG, 0.7, True)}
    linking = link_maps(grids(), table_pairs(table))
    assert linking.dropped == () and linking.across == {}
    assert (1, 2) in linking.tree


def test_blame_goes_by_confidence() -> None:
    # The wrong pair, more confident than the right ones, joins maps 1 and 2 first,
    # alone. The right pair 0-1 is then judged through it and dropped; 2-3 passes (map 3
    # on map 1 lays 22 % of their walls on open space) and so joins; 0-3, judged through
    # the wrong pair too, is dropped. The notes say why map 0 is linked to nothing.
    table = {
        **two_groups_and(truth(1, 2) @ WRONG, confidence=0.95),
        (0, 3): (truth(0, 3), 0.6, True),
    }
    linking = link_maps(grids(), table_pairs(table))
    assert linking.tree == ((1, 2), (2, 3))
    assert linking.dropped == ((0, 1), (0, 3))
    assert set(linking.across) == {(0, 1), (2, 3), (0, 3)}
    assert linking.across[(2, 3)] < DEFAULT_LINKING.across_conflict < linking.across[(0, 1)]
    assert any(n.startswith("pair 0-1 (accepted, confidence 0.90) dropped") for n in linking.notes)
    assert "map 0 not linked: its accepted pairs (0-1, 0-3) were dropped" in "\n".join(
        linking.notes
    )


def test_a_group_of_maps_that_bend_is_not_judged() -> None:
    pairs = table_pairs(two_groups_and(truth(1, 2) @ WRONG))
    pairs[(0, 1)] = replace(pairs[(0, 1)], evidence=BENT)
    linking = link_maps(grids(), pairs)
    assert linking.dropped == () and linking.across == {}
    # nor a join whose own pair bends
    pairs = table_pairs(two_groups_and(truth(1, 2) @ WRONG))
    pairs[(1, 2)] = replace(pairs[(1, 2)], evidence=BENT)
    assert link_maps(grids(), pairs).dropped == ()


@pytest.mark.parametrize(
    ("setting", "dropped"),
    [({}, ((1, 2),)), ({"across_conflict": 1.0}, ()), ({"across_overlap_cells": 1e6}, ())],
)
def test_the_share_and_the_walls_needed_to_judge_are_settings(setting, dropped) -> None:
    params = replace(DEFAULT_LINKING, **setting)
    table = table_pairs(two_groups_and(truth(1, 2) @ WRONG))
    assert link_maps(grids(), table, params=params).dropped == dropped


TURNED = [
    rigid_matrix(10.0, 10.0, 0.0),
    rigid_matrix(260.0, 20.0, np.pi / 2),
    rigid_matrix(330.0, 240.0, np.pi),
    rigid_matrix(100.0, 250.0, -np.pi / 2),
    rigid_matrix(140.0, 30.0, 0.0),
]
"""Per grid, the matrix taking its cells to the building's: quarter turns, exact."""


def test_groups_joined_in_turns_place_their_maps_through_each_join() -> None:
    # Two groups of two, joined, then a fifth map joined to the second group's far map:
    # judging that last join needs each earlier join composed in the right order.
    turned = [warp_cells(BUILDING, np.linalg.inv(pose), (200, 220)) for pose in TURNED]

    def between(i: int, j: int) -> np.ndarray:
        return np.linalg.inv(TURNED[i]) @ TURNED[j]

    table = {(0, 1): 0.95, (2, 3): 0.9, (1, 2): 0.85, (3, 4): 0.8}
    right = {key: (between(*key), c, True) for key, c in table.items()}
    linking = link_maps(turned, table_pairs(right))
    assert linking.dropped == () and linking.groups == ((0, 1, 2, 3, 4),)
    assert linking.across == {(1, 2): 0.0, (3, 4): 0.0}
    wrong = {**right, (1, 2): (between(1, 2) @ WRONG, 0.85, True)}
    assert link_maps(turned, table_pairs(wrong)).dropped[0] == (1, 2)


@pytest.mark.parametrize(
    ("field", "value"),
    [("across_conflict", 1.5), ("across_conflict", -0.1), ("across_overlap_cells", -1.0)],
)
def test_the_settings_are_checked(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        LinkingParams(**{field: value})
