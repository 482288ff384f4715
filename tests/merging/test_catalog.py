"""Maps by name: the maps path, its order, the names of nested maps, and what a miss says."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import merging
from merging import catalog
from merging.grid import OccupancyGrid
from merging.mapio import save_map


def write(folder: Path, name: str, *, rows: int = 6, cols: int = 9, resolution: float = 0.1):
    """A small map called ``name`` under ``folder``; returns its YAML file."""
    path = folder / f"{name}.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    cells = np.zeros((rows, cols), dtype=np.int8)
    cells[0, :] = 100
    return save_map(OccupancyGrid(cells, resolution=resolution), path, image_format="png")


@pytest.fixture
def maps_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    """Two folders on the maps path, the first holding ``a`` and ``lab/b``, the second ``a``."""
    first, second = tmp_path / "first", tmp_path / "second"
    write(first, "a", rows=6)
    write(first, "lab/b", rows=7, cols=4, resolution=0.05)
    write(second, "a", rows=8)
    monkeypatch.setenv(catalog.MAPS_ENV, os.pathsep.join([str(first), str(second)]))
    return first, second


def test_a_name_is_found_in_the_first_folder_that_holds_it(maps_path) -> None:
    first, _ = maps_path
    assert catalog.find_map("a") == first / "a.yaml"
    assert catalog.find_map("lab/b") == first / "lab" / "b.yaml"
    assert merging.load_map("a").data.shape == (6, 9)
    assert merging.load_map("lab/b").resolution == 0.05


def test_an_unknown_name_lists_the_folders_searched(maps_path) -> None:
    first, second = maps_path
    with pytest.raises(FileNotFoundError) as raised:
        merging.load_map("c")
    message = str(raised.value)
    assert "no map named 'c'" in message
    assert str(first) in message and str(second) in message and catalog.MAPS_ENV in message
    assert "did you mean" not in message  # nothing near 'c'


def test_an_unknown_name_suggests_the_maps_meant(maps_path) -> None:
    with pytest.raises(FileNotFoundError, match=r"no map named 'b' \(did you mean lab/b\?\)"):
        merging.load_map("b")  # the folder left out
    first, _ = maps_path
    write(first, "halls/corridor")
    with pytest.raises(FileNotFoundError, match=r"\(did you mean halls/corridor\?\)"):
        catalog.find_map("coridor")  # a typo, and the folder left out


def test_only_map_files_are_suggested(maps_path) -> None:
    first, _ = maps_path
    (first / "old").mkdir()
    (first / "old" / "gone.yaml").symlink_to(first / "nowhere.yaml")  # a broken link
    (first / "folder.yaml").mkdir()  # a folder, not a map
    for name in ("old/gone", "folder"):
        with pytest.raises(FileNotFoundError) as raised:
            catalog.find_map(name)
        assert "did you mean" not in str(raised.value)


def test_paths_are_taken_as_they_are(maps_path, tmp_path: Path) -> None:
    assert catalog.find_map(tmp_path / "x.yaml") == tmp_path / "x.yaml"
    assert catalog.find_map("elsewhere/x.yaml") == Path("elsewhere/x.yaml")
    with pytest.raises(FileNotFoundError, match="map file not found"):
        merging.load_map("elsewhere/x.yaml")  # a path that is not there is named as a path
    assert catalog.is_map_path("./a") and not catalog.is_map_path("a")
    # A map's image given for its YAML file is a path too, named as one when missing.
    assert catalog.is_map_path("map.png") and catalog.is_map_path("lab/b.PGM")
    with pytest.raises(FileNotFoundError, match=r"map file not found: map\.png"):
        merging.load_map("map.png")


def test_the_list_holds_every_map_once_with_its_size(maps_path, tmp_path: Path) -> None:
    first, _ = maps_path
    (first / "notes.yaml").write_text("just: text\n")  # not a map: skipped
    # Maps load_map refuses are skipped too (they were listed, sized by a bad header).
    image = (first / "a.yaml").read_text().split("image:")[1].split()[0]
    for name, entries in (("odd_mode", "mode: odd\n"), ("negative", "")):
        resolution = "-0.05" if name == "negative" else "0.05"
        (first / f"{name}.yaml").write_text(
            f"image: {image}\nresolution: {resolution}\norigin: [0, 0, 0]\n{entries}"
        )
    entries = catalog.list_maps()
    assert [entry.name for entry in entries] == ["a", "lab/b"]
    a, b = entries
    assert (a.rows, a.cols, a.resolution) == (6, 9, 0.1)  # the first folder's a
    assert b.size_m == pytest.approx((0.2, 0.35))


def test_without_settings_the_shared_folder_beside_the_checkout_is_searched(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(catalog.MAPS_ENV, raising=False)
    monkeypatch.delenv(catalog.SHARED_ENV, raising=False)
    folders = catalog.map_folders()
    assert len(folders) == 1 and folders[0].parts[-2:] == ("shared", "maps")
    assert "the default" in catalog.describe_folders()


def test_the_shared_folder_setting_names_its_maps(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv(catalog.MAPS_ENV, raising=False)
    monkeypatch.setenv(catalog.SHARED_ENV, str(tmp_path))
    write(tmp_path / "maps", "z")
    assert catalog.find_map("z") == tmp_path / "maps" / "z.yaml"
    monkeypatch.setenv(catalog.SHARED_ENV, str(tmp_path / "absent"))
    assert catalog.map_folders() == (tmp_path / "absent" / "maps",)


def test_a_name_that_is_not_text_is_refused() -> None:
    with pytest.raises(TypeError, match="a map is a name or a path"):
        catalog.find_map(3)  # type: ignore[arg-type]  # the wrong type on purpose
