"""Benchmark scripts: a missing map is refused before any work, in one line; their tables."""

from __future__ import annotations

import pytest

from merging.catalog import MAPS_ENV
from tests.support import REPO_ROOT, load_script

ASKED = [
    ("bench_merge", ["--maps", "aces3", "nosuch", "--pairs-per-map", "1"], "--maps"),
    ("reproduce_paper", ["--extra-maps", "nosuch"], "--sim-maps/--extra-maps"),
]


@pytest.mark.parametrize(("script", "argv", "option"), ASKED)
def test_a_missing_map_is_named_before_the_run(
    maps_folder, monkeypatch, script: str, argv: list[str], option: str, tmp_path, capsys
) -> None:
    monkeypatch.setenv(MAPS_ENV, str(maps_folder))
    monkeypatch.syspath_prepend(str(REPO_ROOT / "scripts"))  # the scripts' own packages
    status = load_script(script).main([*argv, "--out", str(tmp_path / "out")])
    assert status == 2
    err = capsys.readouterr().err
    assert f"{option}: no map 'nosuch'" in err and "tomosim maps" in err
    assert not (tmp_path / "out").exists()  # nothing written, no pair run


def test_calibration_refuses_a_missing_map_before_emptying_its_results(
    maps_folder, monkeypatch, tmp_path, capsys
) -> None:
    monkeypatch.setenv(MAPS_ENV, str(maps_folder))
    results = tmp_path / "kept.csv"
    results.write_text("earlier results\n")
    with pytest.raises(SystemExit) as stopped:
        load_script("calibrate_confidence").main(["--maps", "nosuch", "--out", str(results)])
    assert stopped.value.code == 2 and "--maps: no map 'nosuch'" in capsys.readouterr().err
    assert results.read_text() == "earlier results\n"


def test_the_scaling_table_holds_every_size_any_method_was_timed_at() -> None:
    # The sizes came from the first method alone: a method dropped after its first size
    # hid the others' timings at the larger ones.
    times = {"slow": {200: [1.0]}, "tomographic": {200: [0.01], 400: [0.02], 800: [0.04]}}
    table = load_script("bench_merge").markdown({}, {}, times, 1.0)
    rows = [line for line in table.splitlines() if line.startswith("| 800 |")]
    assert len(rows) == 1 and "not timed" in rows[0] and "| 40 (40-40) |" in rows[0]
