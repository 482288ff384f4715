"""``scripts/exploration_precision.py``: accepted estimates against the truth and the best fit."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from tests.support import load_script


@pytest.mark.slow
def test_rows_hold_the_estimate_the_truth_and_the_fit_between_them(tmp_path: Path) -> None:
    precision = load_script("exploration_precision")
    # Four robots on the default floor link a first pair by step 40 (seed 0).
    argv = ["--worlds", "0", "--seeds", "0", "--steps", "60", "--out", str(tmp_path)]
    assert precision.main(argv) == 0
    with (tmp_path / "precision.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert rows and {r["world"] for r in rows} == {"floor0"}
    for row in rows:
        assert int(row["step"]) <= 60 and row["fit_accepted"] in {"0", "1"}
        # Three placements of one frame: the distances between them obey the triangle rule.
        for kind, unit in (("rotation", "deg"), ("translation", "m")):
            est = float(row[f"{kind}_error_{unit}"])
            fit = float(row[f"fit_{kind}_error_{unit}"])
            between = float(row[f"from_fit_{kind}_{unit}"])
            assert all(math.isfinite(v) for v in (est, fit, between))
            assert est <= fit + between + 1e-9 and between <= est + fit + 1e-9
    report = (tmp_path / "precision.md").read_text(encoding="utf-8")
    assert f"{len(rows)} accepted estimates" in report
    assert "| estimate against the best fit |" in report


def test_the_summary_leaves_false_matches_out_and_says_so() -> None:
    precision = load_script("exploration_precision")
    right = dict.fromkeys(precision.COLUMNS, 0.1) | {"fit_accepted": 1, "fit_quality": 0.05}
    right |= {"walls_meeting": 300.0, "fit_walls_meeting": 100.0}
    false = right | {"rotation_error_deg": 179.0}
    report = precision.summarise([right, false])
    assert report.startswith("2 accepted estimates, 1 of them false matches")
    assert "| estimate against the truth | 0.100 |" in report
    assert "accepts 100.0% of the best fits" in report
    assert "fit (a fraction) is at least the best fit's in 100.0% (" in report
    assert "as many walls on walls as the best fit in 100.0% (ratio: median 3.00" in report
    assert "| estimate against the truth | - |" in precision.summarise([false])
