"""``tomosim maps`` and maps given by name to ``explore``, ``merge`` and ``sweep``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from merging import catalog
from tests.merging.test_catalog import write
from tests.tomosim.commands.cli_support import assert_one_line_error, run
from tomosim.commands import UsageError, world_spec
from tomosim.episode import load_world
from tomosim.sweep.plan import world_name


@pytest.fixture
def maps_folder_set(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "maps"
    write(folder, "office", rows=20, cols=30, resolution=0.05)
    write(folder, "site/hall", rows=10, cols=10, resolution=0.1)
    monkeypatch.setenv(catalog.MAPS_ENV, str(folder))
    return folder


def test_maps_lists_names_sizes_and_resolutions(maps_folder_set, capsys) -> None:
    status, out, _ = run(["maps"], capsys)
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == f"2 maps in {maps_folder_set}"
    assert lines[3].split() == [
        "office",
        "20",
        "x",
        "30",
        "0.050",
        "m",
        "1.5",
        "m",
        "x",
        "1.0",
        "m",
    ]
    assert lines[4].split()[0] == "site/hall"
    status, out, _ = run(["maps", "--json"], capsys)
    listed = json.loads(out)
    assert [m["name"] for m in listed] == ["office", "site/hall"]
    assert listed[1]["resolution_m"] == 0.1 and listed[1]["width_m"] == 1.0


def test_no_maps_is_an_error_naming_the_folders(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.setenv(catalog.MAPS_ENV, str(tmp_path / "none"))
    status, _, err = run(["maps"], capsys)
    assert status == 1
    assert_one_line_error(err, "no maps found in", str(tmp_path / "none"), catalog.MAPS_ENV)


def test_an_unknown_world_name_says_where_it_looked(maps_folder_set, capsys) -> None:
    status, _, err = run(["explore", "--world", "offce", "--no-record"], capsys)
    assert status == 1
    assert_one_line_error(err, "--world offce", "no map named 'offce'", str(maps_folder_set))
    status, _, err = run(["sweep", "--worlds", "offce", "--out", "x.csv"], capsys)
    assert status == 1
    assert_one_line_error(err, "--worlds offce", "no map named 'offce'")


def test_merge_takes_maps_by_name(maps_folder_set, tmp_path, capsys) -> None:
    status, _, err = run(["merge", "office", "nowhere", "-o", str(tmp_path / "m.yaml")], capsys)
    assert status == 1
    assert_one_line_error(err, "no map named 'nowhere'")


def test_a_world_and_a_sweep_name_a_map_by_its_name(maps_folder_set) -> None:
    world = load_world("office")
    assert world.truth.data.shape == (20, 30)
    assert world_name("office") == "office" and world_name("site/hall") == "site/hall"
    assert world_name("7") == "7"
    assert Path(world_name("office.yaml")).is_absolute()  # a file keeps its whole path


def test_a_world_option_reads_a_yaml_suffix_in_any_case() -> None:
    # As load_map does (merging.catalog.is_map_path): E5.YAML is a map's file, not refused.
    assert world_spec("maps/E5.YAML", option="--world") == Path("maps/E5.YAML")
    with pytest.raises(UsageError, match=r"map_server \.yaml file"):
        world_spec("map.png", option="--world")
