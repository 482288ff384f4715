"""Scripts that take map names refuse a missing one before any work, in one line."""

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
