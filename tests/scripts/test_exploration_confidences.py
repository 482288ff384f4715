"""``scripts/exploration_confidences.py``: the confidences of right and false acceptances."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from tests.support import load_script


@pytest.mark.slow
def test_rows_mark_each_pairs_first_acceptance_and_a_rerun_resumes(tmp_path: Path) -> None:
    confidences = load_script("exploration_confidences")
    # Four robots on the default floor link a first pair by step 40 (seed 0).
    argv = ["--worlds", "0", "--seeds", "0", "--steps", "80", "--workers", "1"]
    argv += ["--out", str(tmp_path)]
    assert confidences.main(argv) == 0
    with (tmp_path / "confidences.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert rows and {r["world"] for r in rows} == {"floor0"}
    firsts = [r["pair"] for r in rows if r["first_acceptance"] == "1"]
    assert sorted(firsts) == sorted({r["pair"] for r in rows})  # one first per pair
    assert all(0.0 < float(r["confidence"]) <= 1.0 and int(r["step"]) <= 80 for r in rows)
    report = (tmp_path / "confidences.md").read_text(encoding="utf-8")
    assert report.startswith(f"episodes: 1; {len(rows)} accepted estimates")
    assert confidences.main(argv) == 0  # the episode is done: nothing runs, nothing doubles
    with (tmp_path / "confidences.csv").open(encoding="utf-8") as handle:
        assert len(list(csv.DictReader(handle))) == len(rows)
    # Another team into the same folder would mix two teams' rows: refused, rows kept.
    with pytest.raises(SystemExit, match="give another --out"):
        confidences.main([*argv, "--team", "confirm_at_once_confidence=none"])
    with (tmp_path / "confidences.csv").open(encoding="utf-8") as handle:
        assert len(list(csv.DictReader(handle))) == len(rows)
    # A folder of an earlier version, without the newer columns: refused, rows kept.
    earlier = [c for c in confidences.COLUMNS if c not in ("dropped", "conflict_across")]
    with (tmp_path / "confidences.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=earlier, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    with pytest.raises(SystemExit, match="earlier version of this script, without the columns"):
        confidences.main(argv)
    with (tmp_path / "confidences.csv").open(encoding="utf-8") as handle:
        assert len(list(csv.DictReader(handle))) == len(rows)


def test_the_summary_counts_first_right_acceptances_and_false_matches_per_threshold() -> None:
    confidences = load_script("exploration_confidences")
    base = {"world": "floor1", "seed": 48, "step": 80, "pair": "r1-r2", "confirmed": 0,
            "dropped": 0, "conflict_across": ""}  # fmt: skip
    rows = [
        base | {"confidence": 0.9, "rotation_error_deg": 0.2, "translation_error_m": 0.1,
                "false_match": 0, "first_acceptance": 1, "conflict_across": 0.01},
        base | {"confidence": 0.7, "rotation_error_deg": 0.2, "translation_error_m": 0.1,
                "false_match": 0, "first_acceptance": 1},
        base | {"confidence": 0.95, "rotation_error_deg": 0.2, "translation_error_m": 0.1,
                "false_match": 0, "first_acceptance": 0, "conflict_across": 0.03},
        base | {"confidence": 0.66, "rotation_error_deg": 179.9, "translation_error_m": 25.6,
                "false_match": 1, "first_acceptance": 1, "confirmed": 1, "dropped": 1,
                "conflict_across": 0.54},
    ]  # fmt: skip
    report = confidences.summarise(rows, 1)
    assert report.startswith("episodes: 1; 4 accepted estimates, 1 false matches")
    assert "1 of them confirmed, 0 of those kept by the linking" in report
    assert "| floor1 seed 48 | 80 | r1-r2 | 0.660 | 179.9 | 25.6 | 1 | 1 | 0.540 |" in report
    assert "judged across: 2 right estimates (walls on open space: median 0.020, " in report
    assert "max 0.030), 1 false matches (0.540)" in report
    assert "first right acceptances of a pair: 2" in report
    assert "| 0.65 | 100.0% | 1 |" in report
    assert "| 0.70 | 100.0% | 0 |" in report
    assert "| 0.85 | 50.0% | 0 |" in report
    assert "| 0.95 | 0.0% | 0 |" in report


def test_workers_must_be_at_least_one(capsys: pytest.CaptureFixture[str]) -> None:
    # The options both scripts share are tested in test_floor_episode_options.py.
    with pytest.raises(SystemExit) as stopped:
        load_script("exploration_confidences").parse_args(["--workers", "0"])
    assert stopped.value.code == 2 and "--workers 0: give at least 1" in capsys.readouterr().err
