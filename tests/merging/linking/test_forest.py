"""Linking N grids: the spanning forest, contradictions around cycles, frames, merge_all."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from merging import MergeResult, OccupancyGrid, cells_to_metres, link_maps, merge_all
from merging.linking.forest import MergeAllResult, fuse_group
from merging.params import DEFAULT_LINKING, LinkingParams
from merging.result import Hypothesis
from merging.transforms import apply_transform, rigid_matrix
from merging.warp import warp_cells
from tests.merging.linking.test_fusion import EXACT, random_room_map, translation

BASE = random_room_map((60, 70), seed=11)
"""The world the test robots' grids are cut from."""
WINDOW = (30, 34)
"""Rows, cols of each robot's grid."""
POSES = [
    rigid_matrix(5.0, 4.0, 0.0),
    rigid_matrix(40.0, 8.0, np.pi / 2),
    rigid_matrix(30.0, 55.0, np.pi),
    rigid_matrix(2.0, 50.0, -np.pi / 2),
]
"""Per robot, the matrix taking its grid's cells to BASE's cells (quarter turns stay exact)."""


def robot_grids() -> list[np.ndarray]:
    return [warp_cells(BASE, np.linalg.inv(pose), WINDOW) for pose in POSES]


def truth(i: int, j: int) -> np.ndarray:
    """The true matrix taking grid j's cells to grid i's."""
    return np.linalg.inv(POSES[i]) @ POSES[j]


def table_pairs(table: dict[tuple[int, int], tuple]) -> dict[tuple[int, int], MergeResult]:
    """Pairwise results from ``table[(i, j)] = (matrix, confidence, accepted)``."""
    pairs = {}
    for key, (matrix, confidence, accepted) in table.items():
        reason = "" if accepted else "table says no"
        matrix = np.asarray(matrix, float)
        hypotheses = (Hypothesis(matrix, confidence),)
        pairs[key] = MergeResult(
            matrix, confidence, accepted, "table", reason=reason, hypotheses=hypotheses
        )
    return pairs


def link_table(
    grids: list, table: dict[tuple[int, int], tuple], params: LinkingParams = DEFAULT_LINKING
) -> MergeAllResult:
    """What merge_all returns when the pairwise estimates are ``table``'s."""
    linking = link_maps(grids, table_pairs(table), params=params)
    return MergeAllResult(linking, fuse_group(grids, linking, linking.main))


def test_merge_all_chains_transforms_and_ignores_a_weak_wrong_pair() -> None:
    grids = robot_grids()
    wrong = truth(0, 2) @ translation(25, -12)
    table = {
        (0, 1): (truth(0, 1), 0.9, True),
        (1, 2): (truth(1, 2), 0.8, True),
        (2, 3): (truth(2, 3), 0.7, True),
        (0, 2): (wrong, 0.3, True),  # accepted but wrong: the tree must not use it
        (0, 3): (wrong, 0.95, False),  # confident but not accepted: never used
    }
    result = link_table(grids, table)
    assert result.reference == 0
    assert result.tree == ((0, 1), (1, 2), (2, 3))
    assert result.unlinked == ()
    for k in range(4):
        np.testing.assert_allclose(result.transforms[k], truth(0, k), atol=EXACT)
    np.testing.assert_allclose(result.pair(2, 0).matrix, np.linalg.inv(wrong), atol=EXACT)
    # Asked the other way round, the pair's hypotheses turn round with its matrix.
    (hypothesis,) = result.pair(1, 0).hypotheses
    np.testing.assert_allclose(hypothesis.matrix, np.linalg.inv(truth(0, 1)), atol=EXACT)
    assert any("pair 0-2" in note and "disagrees" in note for note in result.notes)
    # the fused map is BASE seen from grid 0, wherever a robot saw it
    into_base = POSES[0] @ np.linalg.inv(result.fused.offset)
    expected = warp_cells(BASE, np.linalg.inv(into_base), result.fused.cells.shape)
    seen = result.fused.cells >= 0
    assert np.count_nonzero(seen) > 1.5 * WINDOW[0] * WINDOW[1]
    np.testing.assert_array_equal(result.fused.cells[seen], expected[seen])


def test_merge_all_with_a_strong_wrong_pair_would_differ() -> None:
    """Control for the test above: the tree follows confidence, so the outcome can fail."""
    grids = robot_grids()
    wrong = truth(0, 2) @ translation(25, -12)
    table = {(0, 1): (truth(0, 1), 0.9, True), (1, 2): (truth(1, 2), 0.8, True)}
    table[(0, 2)] = (wrong, 0.99, True)
    result = link_table(grids, table)
    np.testing.assert_allclose(result.transforms[2], wrong, atol=EXACT)


def test_merge_all_reports_an_unlinked_grid() -> None:
    grids = robot_grids()
    table = {(0, 1): (truth(0, 1), 0.9, True), (0, 2): (truth(0, 2), 0.6, True)}
    table[(1, 3)] = (truth(1, 3), 0.4, False)
    result = link_table(grids, table)
    assert result.reference == 0
    assert result.unlinked == (3,)
    assert result.transforms[3] is None
    assert result.fused_transform(3) is None
    assert any(
        note.startswith("map 3 not linked") and "1-3" in note and "0.40" in note
        for note in result.notes
    )
    assert result.fused.cells.shape[0] * result.fused.cells.shape[1] > 0


def test_merge_all_uses_the_largest_group_when_grid_0_links_to_nothing() -> None:
    grids = robot_grids()
    table = {(1, 2): (truth(1, 2), 0.9, True), (2, 3): (truth(2, 3), 0.9, True)}
    result = link_table(grids, table)
    assert result.reference == 1
    assert result.unlinked == (0,)
    np.testing.assert_allclose(result.transforms[3], truth(1, 3), atol=EXACT)
    assert "reference is map 1" in result.notes[0]


def test_merge_all_reports_a_group_cut_off_from_the_reference() -> None:
    grids = robot_grids()
    table = {(0, 1): (truth(0, 1), 0.9, True), (2, 3): (truth(2, 3), 0.9, True)}
    result = link_table(grids, table)
    assert result.reference == 0
    assert result.unlinked == (2, 3)
    assert any("map 2 links to map(s) 3" in note for note in result.notes)


def test_merge_all_keeps_the_reference_georeference() -> None:
    grids = [OccupancyGrid(g, resolution=0.05, origin=(1.0, 2.0, 0.0)) for g in robot_grids()]
    table = {(0, 1): (truth(0, 1), 0.9, True)}
    result = link_table(grids, table)
    assert result.fused.grid is not None
    cell = np.array([[3.0, 4.0]])
    np.testing.assert_allclose(
        result.fused.grid.cell_to_world(apply_transform(result.fused.offset, cell)),
        grids[0].cell_to_world(cell),
        atol=EXACT,
    )


def test_merge_all_validates_its_input() -> None:
    cells = np.zeros((5, 5), dtype=np.int8)
    with pytest.raises(ValueError, match="empty"):
        merge_all([])
    with pytest.raises(TypeError, match="sequence"):
        merge_all(cells)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown merging method"):
        merge_all([cells], method="no-such-method")
    with pytest.raises(ValueError, match=r"grids\[1\]"):
        link_maps([cells, np.full((5, 5), 200)], {})
    coarse = OccupancyGrid(cells, resolution=0.1)
    with pytest.raises(ValueError, match=r"grids\[1\] 0.1 m"):
        link_maps([OccupancyGrid(cells), coarse], {})
    with pytest.raises(TypeError, match="MergeResult"):
        link_maps([cells, cells], {(0, 1): None})  # type: ignore[dict-item]
    with pytest.raises(ValueError, match=r"pair \(1, 0\)"):
        link_maps([cells, cells], table_pairs({(1, 0): (np.eye(3), 0.9, True)}))


@pytest.mark.parametrize(
    ("key", "matrix", "confidence", "accepted", "error", "message"),
    [
        ((0, 1), np.zeros((3, 3)), 0.9, True, ValueError, r"matrix of pairs\[\(0, 1\)\] must be"),
        ((0, 1), np.diag([0.0, 0.0, 1.0]), 0.9, True, ValueError, "singular"),
        ((0, 1), np.eye(2), 0.9, True, ValueError, "3x3"),
        ((0, 1), np.full((3, 3), np.nan), 0.9, True, ValueError, "finite"),
        ((0, 1), np.eye(3), 2.0, True, ValueError, r"confidence 2\.0.*in \[0, 1\]"),
        ((0, 1), np.eye(3), float("nan"), True, ValueError, "confidence nan"),
        ((0, 1), np.eye(3), "high", True, ValueError, "confidence 'high'"),
        ((0, 1), np.eye(3), 0.9, "no", TypeError, "accepted='no'"),
        ((0.5, 1), np.eye(3), 0.9, True, ValueError, r"two whole grid indices, got the key \(0\.5"),
        (("0", "1"), np.eye(3), 0.9, True, ValueError, "two whole grid indices"),
        (0, np.eye(3), 0.9, True, ValueError, "keyed by"),
    ],
)
def test_link_maps_refuses_a_pair_it_cannot_link_naming_it(
    key, matrix, confidence, accepted, error, message
) -> None:
    # Such pairs once failed deep in the linking (a singular system, a matmul of the
    # wrong shape) or were linked as they were (a confidence of 2 as no edge at all).
    cells = random_room_map((8, 9), seed=12)
    result = MergeResult(matrix=matrix, confidence=confidence, accepted=accepted, method="own")
    with pytest.raises(error, match=message):
        link_maps([cells, cells], {key: result})


def test_single_grid_is_its_own_fusion() -> None:
    cells = random_room_map((8, 9), seed=12)
    result = merge_all([cells])
    np.testing.assert_array_equal(result.fused.cells, cells)
    assert result.pairs == {} and result.tree == () and result.unlinked == ()


def test_a_confident_wrong_pair_is_outvoted_around_cycles() -> None:
    """Four maps: the wrong pair fails both its triangles, every right pair closes one."""
    grids = robot_grids()
    wrong = truth(0, 2) @ translation(25, -12)
    table = {key: (truth(*key), 0.8, True) for key in [(0, 1), (0, 3), (1, 2), (1, 3), (2, 3)]}
    table[(0, 2)] = (wrong, 0.99, True)  # the most confident pair, and wrong
    result = link_table(grids, table)
    assert result.linking.dropped == ((0, 2),)
    assert any(note.startswith("pair 0-2") and "dropped" in note for note in result.notes)
    for k in range(4):
        np.testing.assert_allclose(result.transforms[k], truth(0, k), atol=EXACT)


def test_a_small_disagreement_is_not_a_contradiction() -> None:
    """Chained transforms of drifting maps differ by a few cells; nothing is dropped."""
    grids = robot_grids()
    nudge = translation(0.3 * LinkingParams().contradiction_cells, 0.0)
    table = {(0, 1): (truth(0, 1), 0.9, True), (1, 2): (truth(1, 2), 0.9, True)}
    table[(0, 2)] = (truth(0, 2) @ nudge, 0.5, True)
    result = link_table(grids, table)
    assert result.linking.dropped == ()
    assert result.tree == ((0, 1), (1, 2))


def test_the_contradiction_tolerance_is_a_setting() -> None:
    """The same nudge, beyond a tolerance set below it, drops the least confident pair."""
    grids = robot_grids()
    shift = 0.3 * LinkingParams().contradiction_cells
    table = {(0, 1): (truth(0, 1), 0.9, True), (1, 2): (truth(1, 2), 0.9, True)}
    table[(0, 2)] = (truth(0, 2) @ translation(shift, 0.0), 0.5, True)
    strict = LinkingParams(contradiction_cells=shift / 2)
    assert link_table(grids, table, strict).linking.dropped == ((0, 2),)
    with pytest.raises(ValueError, match="contradiction_cells must be a positive number"):
        LinkingParams(contradiction_cells=0.0)
    with pytest.raises(TypeError, match="params must be a LinkingParams"):
        link_maps(grids, table_pairs(table), params=0.5)  # type: ignore[arg-type]


def test_every_group_gets_frames_into_its_root() -> None:
    grids = [
        OccupancyGrid(g, resolution=0.05, origin=(0.3 * k, -0.2 * k, 0.1 * k))
        for k, g in enumerate(robot_grids())
    ]
    table = {(0, 1): (truth(0, 1), 0.9, True), (2, 3): (truth(2, 3), 0.9, True)}
    linking = link_maps(grids, table_pairs(table))
    assert linking.groups == ((0, 1), (2, 3))
    assert linking.roots == (0, 0, 2, 2)
    np.testing.assert_allclose(linking.transforms[3], truth(2, 3), atol=EXACT)
    assert linking.relative(0, 2) is None
    metres = linking.transforms_metres
    assert metres is not None
    np.testing.assert_allclose(
        metres[3], cells_to_metres(truth(2, 3), grids[2], grids[3]), atol=EXACT
    )
    np.testing.assert_allclose(metres[0], np.eye(3), atol=EXACT)


def test_merge_all_takes_a_generator_made_from_a_random_state() -> None:
    grids = [random_room_map((40, 50), seed=seed) for seed in (1, 2)]
    result = merge_all(grids, rng=np.random.default_rng(np.random.RandomState(0)))
    assert result.linking.count == 2
    with pytest.raises(KeyError, match="no grid 7"):
        result.linking.group(7)


def bent(result: MergeResult) -> MergeResult:
    """``result`` as vouched for by the evidence for maps that bend."""
    evidence = {"close_confidence": 0.1, "robust_confidence": result.confidence}
    return replace(result, evidence=evidence)


def test_bending_maps_are_placed_by_every_pair_not_a_chain() -> None:
    """Four bent sessions: each pair off by up to 12 cells, all right within that.

    Around cycles they miss each other by up to 34 cells, which would drop right
    pairs as contradictions for maps that fit closely; along the tree 0-1-2-3 the
    errors add up and grid 3 lands 36 cells off, where its own pairs with grids 0
    and 1 are right within 12.
    """
    grids = robot_grids()
    errors = {(0, 1): 12, (1, 2): 12, (2, 3): 12, (0, 2): -10, (0, 3): -12, (1, 3): -6}
    confidence = {(0, 1): 0.99, (1, 2): 0.98, (2, 3): 0.97}  # the tree: 0-1-2-3

    def off_by(i: int, j: int, cells: float) -> np.ndarray:  # shifted along BASE's x
        return np.linalg.inv(POSES[i]) @ translation(cells, 0.0) @ POSES[j]

    table = {key: (off_by(*key, e), confidence.get(key, 0.9), True) for key, e in errors.items()}
    assert link_table(grids, table).linking.dropped  # as close fits they contradict
    pairs = {key: bent(result) for key, result in table_pairs(table).items()}
    linking = link_maps(grids, pairs)
    assert linking.dropped == () and linking.tree == ((0, 1), (1, 2), (2, 3))
    points = np.argwhere(grids[3] == 100)[:, ::-1].astype(float)

    def miss(matrix: np.ndarray) -> float:
        placed = apply_transform(matrix, points) - apply_transform(truth(0, 3), points)
        return float(np.sqrt(np.mean(np.sum(placed**2, axis=1))))

    along_tree = table[(0, 1)][0] @ table[(1, 2)][0] @ table[(2, 3)][0]
    assert miss(along_tree) == pytest.approx(36.0)
    assert miss(linking.transforms[3]) < 12.0  # no farther off than its own pairs


@pytest.mark.slow
def test_sessions_of_one_floor_link_as_their_pairs_are_right(maps_folder) -> None:
    """Five E5 sessions, all pairs: every linked transform right by the floor's rule."""
    import json

    from merging import load_map
    from merging.evaluation.metrics import transform_error

    folder = maps_folder / "halmstad"
    names = ["E5_01", "E5_02", "E5_03", "E5_12", "E5_14"]  # chained along a tree: 6 of 20 off
    grids = [load_map(folder / f"{name}.yaml") for name in names]
    truths = json.loads((folder / "truth_E5.json").read_text())["pairs"]
    linking = merge_all(grids).linking
    judged = 0
    for key, entry in truths.items():
        first, second = key.split("|")
        if first not in names or second not in names:
            continue
        i, j = names.index(first), names.index(second)
        relative = linking.relative(i, j)
        assert relative is not None, key
        error = transform_error(relative, np.array(entry["matrix_cells"]), grids[j].data)[0]
        assert error <= max(1.5 * entry["rms_cells"], entry["rms_cells"] + 10), key
        judged += 1
    assert judged == 20


def test_a_wrong_pair_of_bending_maps_is_dropped_before_it_can_pull_the_group() -> None:
    """A wrong pair in no triangle (the closing edge of a 4-cycle) must not place grids.

    Checked against the tree first, it is dropped; placed by all pairs first, it
    pulled every grid tens of cells off and then agreed with what it had pulled.
    """
    grids = robot_grids()
    table = {(0, 1): (truth(0, 1), 0.99, True), (1, 2): (truth(1, 2), 0.98, True)}
    table[(2, 3)] = (truth(2, 3), 0.97, True)
    table[(0, 3)] = (truth(0, 3) @ translation(300.0, 0.0), 0.5, True)
    linking = link_maps(grids, {key: bent(r) for key, r in table_pairs(table).items()})
    assert linking.dropped == ((0, 3),) and linking.used == linking.tree
    for k in range(4):
        np.testing.assert_allclose(linking.transforms[k], truth(0, k), atol=1e-6)
