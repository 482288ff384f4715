"""map_server I/O: exact round trips, the row flip, real maps, and errors that name the problem."""

from __future__ import annotations

import errno
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from merging import mapio
from merging.grid import OccupancyGrid
from merging.mapio import (
    MAX_YAML_BYTES,
    PIXEL_FREE,
    PIXEL_OCCUPIED,
    PIXEL_UNKNOWN,
    load_map,
    map_image,
    save_map,
)
from tests.support import maps_absent_reason, real_maps_dir


@pytest.fixture(scope="module")
def maps_dir() -> Path:
    """The folder of real ``map_server`` maps; skips the test when it is absent."""
    folder = real_maps_dir()
    if folder is None:
        pytest.skip(maps_absent_reason())
    return folder


def write_map(folder: Path, pixels: np.ndarray, **meta: object) -> Path:
    """Write ``pixels`` (image rows, top first) as a PNG and a YAML naming it."""
    Image.fromarray(pixels.astype(np.uint8)).save(folder / "map.png")
    fields = {"image": "map.png", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], **meta}
    path = folder / "map.yaml"
    path.write_text(yaml.safe_dump(fields))
    return path


@pytest.mark.parametrize("image_format", ["pgm", "png"])
def test_save_then_load_is_exact(tmp_path: Path, image_format: str) -> None:
    rng = np.random.default_rng(7)
    data = rng.choice(np.array([-1, 0, 100], dtype=np.int8), size=(37, 53))
    grid = OccupancyGrid(data, resolution=0.1, origin=(-2.5, 3.25, 0.3))
    (tmp_path / "sub").mkdir()
    image = save_map(grid, tmp_path / "sub" / "m.yaml", image_format=image_format)
    assert image == tmp_path / "sub" / f"m.{image_format}"
    loaded = load_map(tmp_path / "sub" / "m.yaml")
    np.testing.assert_array_equal(loaded.data, grid.data)
    assert loaded.resolution == grid.resolution
    assert loaded.origin == grid.origin


def test_save_writes_intermediate_values_by_threshold(tmp_path: Path) -> None:
    grid = OccupancyGrid(np.array([[10, 19, 20, 64, 65, 90]], dtype=np.int8))
    save_map(grid, tmp_path / "m.yaml")
    np.testing.assert_array_equal(load_map(tmp_path / "m.yaml").data, [[0, 0, -1, -1, 100, 100]])


def test_top_image_row_is_the_last_grid_row(tmp_path: Path) -> None:
    pixels = np.full((4, 3), PIXEL_FREE)
    pixels[0, :] = PIXEL_OCCUPIED  # the top of the picture
    grid = load_map(write_map(tmp_path, pixels))
    expected = np.zeros((4, 3), dtype=np.int8)
    expected[-1, :] = 100
    np.testing.assert_array_equal(grid.data, expected)


def test_grid_row_zero_is_saved_as_the_bottom_image_row(tmp_path: Path) -> None:
    data = np.zeros((3, 2), dtype=np.int8)
    data[0, :] = 100
    data[1, 0] = -1
    image = save_map(OccupancyGrid(data), tmp_path / "m.yaml", image_format="png")
    with Image.open(image) as picture:
        pixels = np.asarray(picture)
    np.testing.assert_array_equal(
        pixels, [[PIXEL_FREE] * 2, [PIXEL_UNKNOWN, PIXEL_FREE], [PIXEL_OCCUPIED] * 2]
    )


@pytest.mark.parametrize(
    ("meta", "expected"),
    [
        ({}, [100, -1, 0]),  # occ = (255 - p) / 255: 1.0, 0.61, 0.0
        ({"negate": 1}, [0, -1, 100]),  # occ = p / 255: 0.0, 0.39, 1.0
        ({"mode": "raw"}, [0, 100, -1]),  # the pixel itself; above 100 is unknown
    ],
)
def test_pixel_interpretation(tmp_path: Path, meta: dict, expected: list[int]) -> None:
    pixels = np.array([[0, 100, 255]])
    np.testing.assert_array_equal(load_map(write_map(tmp_path, pixels, **meta)).data[0], expected)


def test_scale_mode_is_linear_between_the_thresholds(tmp_path: Path) -> None:
    # occ = (255 - p) / 255: p = 128 gives 0.498, (0.498 - 0.196) / (0.65 - 0.196) * 99 = 65.9;
    # p = 200 gives 0.216, 4.3
    pixels = np.array([[0, 128, 200, 255]])
    grid = load_map(write_map(tmp_path, pixels, mode="scale"))
    np.testing.assert_array_equal(grid.data[0], [100, 66, 4, 0])


@pytest.mark.parametrize("mode", ["scale", "trinary"])
def test_scale_mode_reads_see_through_pixels_as_unknown(tmp_path: Path, mode: str) -> None:
    # Grey with alpha: black, mid grey, black and white, the last two see-through
    # (trinary mode does not read the alpha).
    grey = np.array([[0, 128, 0, 255]], dtype=np.uint8)
    alpha = np.array([[255, 255, 0, 128]], dtype=np.uint8)
    Image.fromarray(np.dstack([grey, alpha]), mode="LA").save(tmp_path / "map.png")
    fields = {"image": "map.png", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "mode": mode}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(fields))
    expected = [100, 66, -1, -1] if mode == "scale" else [100, -1, 100, 0]
    np.testing.assert_array_equal(load_map(tmp_path / "map.yaml").data[0], expected)


def test_scale_mode_reads_a_transparent_colour_as_unknown(tmp_path: Path) -> None:
    Image.fromarray(np.array([[0, 0, 254]], np.uint8)).save(tmp_path / "map.png")
    with Image.open(tmp_path / "map.png") as plain:  # black is the transparent colour
        plain.save(tmp_path / "map.png", transparency=0)
    fields = {"image": "map.png", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "mode": "scale"}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(fields))
    np.testing.assert_array_equal(load_map(tmp_path / "map.yaml").data[0], [-1, -1, 0])


def test_real_map_has_its_documented_shape_and_origin(maps_dir: Path) -> None:
    grid = load_map(maps_dir / "brsu_c069.yaml")
    assert grid.shape == (544, 576)
    assert grid.origin == (-8.0, -8.0, 0.0)
    assert grid.resolution == 0.05
    assert set(np.unique(grid.data).tolist()) == {-1, 0, 100}
    assert grid.occupied().sum() > 1000  # a lab's walls, not an empty picture


def test_missing_yaml_is_file_not_found(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nope\.yaml"):
        load_map(tmp_path / "nope.yaml")


def test_missing_image_is_file_not_found(tmp_path: Path) -> None:
    path = write_map(tmp_path, np.zeros((2, 2)))
    (tmp_path / "map.png").unlink()
    with pytest.raises(FileNotFoundError, match=r"map\.png"):
        load_map(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("image: [unclosed\n", "not valid YAML"),
        ("- just\n- a list\n", "mapping"),
        ("image: map.png\nresolution: 0.05\n", "origin"),
        ("image: map.png\norigin: [0, 0, 0]\n", "resolution"),
        ("image: map.png\nresolution: fine\norigin: [0, 0, 0]\n", "resolution must be a positive"),
        # These were read as they were (true as 1 m, 0.7 as 0) or refused without the file.
        ("image: map.png\nresolution: -0.05\norigin: [0, 0, 0]\n", r"bad\.yaml: resolution must"),
        ("image: map.png\nresolution: .nan\norigin: [0, 0, 0]\n", r"bad\.yaml: resolution must"),
        ("image: map.png\nresolution: true\norigin: [0, 0, 0]\n", r"resolution .* got True"),
        ("image: map.png\nresolution: 0.05\norigin: [.nan, 0, 0]\n", "origin must be finite"),
        ("image: map.png\nresolution: 0.05\norigin: [1e12, 0, 0]\n", r"bad\.yaml: origin .* lies"),
        ("image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0.7\n", "negate must be 0"),
        ("image: map.png\nresolution: 0.05\norigin: [0, a, 0]\n", "origin must be numbers"),
        ("image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 'no'\n", "negate must"),
        ("image: map.png\nresolution: 0.05\norigin: [0, 0]\n", r"\[x, y, yaw\]"),
        ("image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\nmode: odd\n", "mode"),
        ("image: map.png\nresolution: 0.05\norigin: '123'\n", r"origin must be a list"),
        (
            "image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\n"
            "occupied_thresh: 0.1\nfree_thresh: 0.9\n",
            "free_thresh < occupied_thresh",
        ),
        # An empty image was "image None ... not found", a folder "not found" though there.
        ("image:\nresolution: 0.05\norigin: [0, 0, 0]\n", "image must name the map's picture"),
        ("image: .\nresolution: 0.05\norigin: [0, 0, 0]\n", "is a folder"),
    ],
)
def test_bad_yaml_is_a_value_error_naming_it(tmp_path: Path, text: str, message: str) -> None:
    Image.fromarray(np.zeros((2, 2), np.uint8)).save(tmp_path / "map.png")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        load_map(path)


def test_save_refuses_arrays_and_unknown_formats(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="OccupancyGrid"):
        save_map(np.zeros((2, 2), np.int8), tmp_path / "m.yaml")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="image_format"):
        save_map(OccupancyGrid(np.zeros((2, 2), np.int8)), tmp_path / "m.yaml", image_format="jpg")


ALIAS_BOMB = "\n".join(
    ["a: &a [x, x, x, x, x, x, x, x, x]"]
    + [f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 9)}]" for k in range(8)]
    + ["image: *i", "resolution: 0.05", "origin: [0, 0, 0]"]
)
"""About 400 bytes of nested aliases: the image name, written out, is 9**9 strings
(gigabytes; a loader that expands aliases spends tens of seconds on it)."""
ALIAS_REFUSAL_S = 1.0
"""Seconds the alias YAML may take to be refused (expanding it takes tens of seconds)."""


def test_nested_aliases_are_refused_quickly(tmp_path: Path) -> None:
    path = tmp_path / "bomb.yaml"
    path.write_text(ALIAS_BOMB)
    assert len(ALIAS_BOMB) < 700
    started = time.perf_counter()
    with pytest.raises(ValueError, match="aliases are not allowed"):
        load_map(path)
    assert time.perf_counter() - started < ALIAS_REFUSAL_S


def test_an_image_passed_as_yaml_is_named(tmp_path: Path) -> None:
    image = save_map(
        OccupancyGrid(np.zeros((4, 4), np.int8)), tmp_path / "m.yaml", image_format="png"
    )
    with pytest.raises(ValueError, match=r"m\.png is a PNG image, not a map_server YAML"):
        load_map(image)
    pgm = save_map(OccupancyGrid(np.zeros((4, 4), np.int8)), tmp_path / "n.yaml")
    with pytest.raises(ValueError, match="PGM image"):
        load_map(pgm)
    # A map's image is mostly larger than a YAML file may be: still named as an image.
    noise = np.random.default_rng(0).choice(np.array([-1, 0, 100], np.int8), (800, 800))
    large = save_map(OccupancyGrid(noise), tmp_path / "large.yaml", image_format="png")
    assert large.stat().st_size > MAX_YAML_BYTES
    with pytest.raises(ValueError, match=r"large\.png is a PNG image"):
        load_map(large)
    binary = tmp_path / "blob.yaml"
    binary.write_bytes(b"image: \xff\xfe\x00")
    with pytest.raises(ValueError, match="not a text file"):
        load_map(binary)


def test_an_oversized_yaml_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    path.write_text("# " + "x" * (MAX_YAML_BYTES + 1))
    with pytest.raises(ValueError, match="too large for a map_server YAML"):
        load_map(path)


def test_a_failed_yaml_write_leaves_the_old_pair_intact(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    old = OccupancyGrid(np.zeros((5, 6), np.int8), resolution=0.05)
    save_map(old, tmp_path / "m.yaml")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def disk_full(path: Path, text: str) -> None:
        path.write_bytes(text.encode()[:3])  # a few bytes land, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(mapio, "_write_text", disk_full)
    new = OccupancyGrid(np.full((9, 9), 100, np.int8), resolution=0.1, origin=(1.0, 2.0, 0.0))
    with pytest.raises(OSError, match="No space left"):
        save_map(new, tmp_path / "m.yaml")
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert after == before  # same files, same bytes, no temporary left behind
    np.testing.assert_array_equal(load_map(tmp_path / "m.yaml").data, old.data)


def test_save_needs_an_existing_folder(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="does not exist"):
        save_map(OccupancyGrid(np.zeros((2, 2), np.int8)), tmp_path / "no" / "m.yaml")
    assert not (tmp_path / "no").exists()


@pytest.mark.parametrize("image_format", ["pgm", "png"])
def test_save_refuses_a_yaml_path_named_like_its_image(tmp_path: Path, image_format: str) -> None:
    target = tmp_path / f"m.{image_format}"
    target.write_bytes(b"an earlier image")
    with pytest.raises(ValueError, match=r"ending in \.yaml"):
        save_map(OccupancyGrid(np.zeros((2, 2), np.int8)), target, image_format=image_format)
    assert target.read_bytes() == b"an earlier image"
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]


def test_save_refuses_a_yaml_path_without_the_yaml_suffix(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"must end in \.yaml"):
        save_map(OccupancyGrid(np.zeros((2, 2), np.int8)), tmp_path / "m.txt")
    assert list(tmp_path.iterdir()) == []
    # In any case, as a map is found and read (merging.catalog.is_map_path).
    grid = OccupancyGrid(np.zeros((2, 2), np.int8))
    save_map(grid, tmp_path / "m.YAML")
    np.testing.assert_array_equal(load_map(tmp_path / "m.YAML").data, grid.data)


def test_a_sixteen_bit_image_reads_as_its_eight_bit_twin(tmp_path: Path) -> None:
    # Pillow's L conversion clips 16-bit values to white: unknown grey read as free.
    eight = np.array([[PIXEL_OCCUPIED, PIXEL_UNKNOWN], [PIXEL_FREE, PIXEL_UNKNOWN]], np.uint8)
    path = write_map(tmp_path, eight)
    expected = load_map(path).data
    Image.fromarray(eight.astype(np.uint16) * 257).save(tmp_path / "map.png")
    with Image.open(tmp_path / "map.png") as image:
        assert image.mode.startswith("I")
    np.testing.assert_array_equal(load_map(path).data, expected)
    assert sorted(np.unique(expected)) == [-1, 0, 100]


def test_map_image_names_the_file_the_yaml_points_at(tmp_path: Path) -> None:
    path = write_map(tmp_path, np.zeros((2, 2)))
    assert map_image(path) == tmp_path / "map.png"


def test_a_yaml_naming_a_file_that_is_not_an_image_is_named(tmp_path: Path) -> None:
    (tmp_path / "notes.png").write_text("not pixels")
    path = tmp_path / "map.yaml"
    path.write_text("image: notes.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match=r"notes\.png named by .*map\.yaml is not an image"):
        load_map(path)


def test_a_quoted_negate_is_read_as_its_number(tmp_path: Path) -> None:
    Image.fromarray(np.array([[0, 254]], np.uint8)).save(tmp_path / "map.png")
    path = tmp_path / "map.yaml"
    path.write_text("image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: '1'\n")
    np.testing.assert_array_equal(load_map(path).data, [[0, 100]])


def test_a_truncated_image_is_named_with_the_map(tmp_path: Path) -> None:
    Image.fromarray(np.zeros((60, 80), np.uint8)).save(tmp_path / "map.png")
    whole = (tmp_path / "map.png").read_bytes()
    (tmp_path / "map.png").write_bytes(whole[: len(whole) // 2])
    path = tmp_path / "map.yaml"
    path.write_text("image: map.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match=r"map\.png named by .*map\.yaml cannot be read"):
        load_map(path)


def test_a_directory_given_as_a_map_is_named_as_one(tmp_path: Path) -> None:
    folder = tmp_path / "maps.yaml"
    folder.mkdir()
    with pytest.raises(ValueError, match="is a directory"):
        load_map(folder)
