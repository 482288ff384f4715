"""``scripts/bench_cycles.py``: cycles of three accepted answers, and how far they miss."""

from __future__ import annotations

import numpy as np
import pytest

from merging.result import MergeResult
from merging.transforms import rigid_matrix
from tests.support import load_script

B_IN_A, C_IN_B = rigid_matrix(12.0, -3.0, 0.2), rigid_matrix(-4.0, 7.0, -0.5)
"""Two accepted answers: session b placed in a, c placed in b."""


def sessions(names: str) -> dict[str, np.ndarray]:
    """Sessions named by the letters of ``names``, each an L of walls (an answer's error is
    measured over them) and nothing else known: the answers are made up, and no open
    space contradicts them when the linking lays one session on another."""
    walls = np.full((60, 60), -1, dtype=np.int8)
    walls[10, 5:55] = walls[5:55, 40] = 100
    return {name: walls for name in names}


def answer(bench, first: str, second: str, matrix, accepted: bool = True):
    """An answer of method ``m`` placing ``second`` in ``first`` by ``matrix``."""
    result = MergeResult(matrix=matrix, confidence=0.9, accepted=accepted, method="m")
    return bench.Answer("F", first, second, "m", 0.01, result)


def test_a_cycle_closes_on_consistent_answers_and_misses_on_a_wrong_one() -> None:
    bench = load_script("bench_cycles")
    grids = sessions("abcd")
    b_in_a, c_in_b = B_IN_A, C_IN_B
    consistent = [
        answer(bench, "a", "b", b_in_a),
        answer(bench, "b", "c", c_in_b),
        answer(bench, "a", "c", b_in_a @ c_in_b),
        answer(bench, "a", "d", np.eye(3), accepted=False),  # no cycle through a refused pair
    ]
    [(a, b, c, error)] = bench.cycles(consistent, grids)
    assert (a, b, c) == ("a", "b", "c") and error < 1e-9
    far = rigid_matrix(300.0, 0.0, 0.0) @ b_in_a @ c_in_b
    wrong = [*consistent[:2], answer(bench, "a", "c", far)]
    [(_, _, _, error)] = bench.cycles(wrong, grids)
    assert error > bench.WRONG_CELLS
    lines = bench.report(wrong, {("F", "m"): bench.cycles(wrong, grids)}, {}, 30.0)
    assert "| F | m | 3 | 3 | 1 |" in lines[2] and any("a -> b -> c" in line for line in lines)


def test_refused_answers_are_held_against_chains_of_accepted_ones() -> None:
    bench = load_script("bench_cycles")
    grids = sessions("abcde")
    b_in_a, c_in_b = B_IN_A, C_IN_B
    answers = [
        answer(bench, "a", "b", b_in_a),
        answer(bench, "b", "c", c_in_b),
        # Refused but right: it agrees with a <- b <- c to a few cells.
        answer(bench, "a", "c", rigid_matrix(3.0, 0.0, 0.0) @ b_in_a @ c_in_b, accepted=False),
        # Refused and wrong: hundreds of cells from the chain c <- b <- d.
        answer(bench, "c", "d", rigid_matrix(0.0, 0.0, 0.0), accepted=False),
        answer(bench, "b", "d", rigid_matrix(300.0, 0.0, 0.0) @ np.linalg.inv(c_in_b)),
        answer(bench, "d", "e", np.eye(3), accepted=False),  # no chain of accepted answers
    ]
    checked = {(a, c): error for a, c, error, _ in bench.refused_against_cycles(answers, grids)}
    assert set(checked) == {("a", "c"), ("c", "d"), ("d", "e")}
    assert checked[("a", "c")] == pytest.approx(3.0, abs=1e-6)
    assert checked[("c", "d")] > bench.WRONG_CELLS and checked[("d", "e")] is None
    refused = {("F", "m"): bench.refused_against_cycles(answers, grids)}
    lines = bench.report(answers, {("F", "m"): bench.cycles(answers, grids)}, refused, 30.0)
    assert "| F | m | 3 | 1 | 0 | 1 | 1 |" in lines


def test_the_linking_places_a_refused_pair_through_the_accepted_ones() -> None:
    bench = load_script("bench_cycles")
    grids = sessions("abc")
    right = B_IN_A @ C_IN_B
    off = rigid_matrix(4.0, 0.0, 0.0) @ right  # refused, 4 cells from the chain through b
    answers = [
        answer(bench, "a", "b", B_IN_A),
        answer(bench, "b", "c", C_IN_B),
        answer(bench, "a", "c", off, accepted=False),
    ]
    groups, distances = bench.linked_against_answers(answers, ["a", "b", "c"], grids)
    assert groups == ((0, 1, 2),)
    assert [accepted for accepted, _ in distances] == [True, True, False]
    assert distances[0][1] == pytest.approx(0.0, abs=1e-6)
    assert distances[2][1] == pytest.approx(4.0, abs=1e-6)
    lines = bench.linking_table({("F", "m"): (groups, distances)}, 30.0)
    assert "| F | m | 3 | 3 | 3 of 3 | 2 of 2 | 1 of 1 |" in lines
    nothing = bench.linking_table({("F", "m"): (((0,), (1,), (2,)), [(False, None)])}, 30.0)
    assert "| F | m | 3 | 1 | 0 of 1 | - | - |" in nothing
    # A refused pair with no accepted path between its sessions stays apart.
    alone = [answers[0], answer(bench, "a", "c", right, accepted=False)]
    groups, distances = bench.linked_against_answers(alone, ["a", "b", "c"], grids)
    assert sorted(groups) == [(0, 1), (2,)] and distances[1] == (False, None)


def test_unknown_methods_are_named(capsys, tmp_path, maps_folder) -> None:
    bench = load_script("bench_cycles")
    status = bench.main(["--methods", "nonesuch", "--floors", "HIH", "--out", str(tmp_path)])
    assert status == 2 and "nonesuch" in capsys.readouterr().err
    assert not (tmp_path / "pairs.csv").exists()


def test_a_look_past_the_wrong_answers_bar_is_refused(capsys, tmp_path) -> None:
    # --look-cells 150 counted a refused answer 120 cells off as within the look (right).
    with pytest.raises(SystemExit) as stopped:
        load_script("bench_cycles").main(["--look-cells", "150", "--out", str(tmp_path)])
    assert stopped.value.code == 2 and "must be below 100" in capsys.readouterr().err


def test_without_the_shared_maps_the_scripts_say_where_they_looked(monkeypatch) -> None:
    from tomosim.commands import CommandError, script_args

    monkeypatch.setattr("tomosim.data.maps_dir", lambda: None)
    with pytest.raises(CommandError, match="maps"):
        script_args.shared_maps()


@pytest.mark.slow
def test_sessions_linked_at_once_are_judged_against_the_floor_s_truth(
    maps_folder, tmp_path, capsys
) -> None:
    bench = load_script("bench_linking")
    sessions = ["E5_01", "E5_02", "E5_03"]
    assert bench.main(["--sessions", *sessions, "--out", str(tmp_path)]) == 0
    report = (tmp_path / "linking.md").read_text()
    rows = (tmp_path / "linking.csv").read_text().splitlines()
    assert "| implied by the linking (sessions linked) |" in report
    known = [line for line in rows[1:] if line.split(",")[0].count("E5_") == 2]
    assert len(known) == len(rows) - 1 >= 3
    assert bench.main(["--sessions", "E5_01", "E5_99", "--out", str(tmp_path)]) == 2
    assert "E5_99" in capsys.readouterr().err
