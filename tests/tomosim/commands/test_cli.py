"""The ``tomosim`` command line, driven through ``main([...])``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from merging import OccupancyGrid, available_methods, load_map, save_map
from merging.evaluation.metrics import transform_error
from tests.support import run_python
from tests.tomosim.commands.cli_support import assert_one_line_error, run
from tomosim.commands.demo_maps import demo_pair
from tomosim.commands.merge_report import format_table

MAX_ERROR_CELLS = 2.0
"""RMS error, in cells, the merger is held to (the project's accuracy target for merges)."""


def write_grid(path: Path, seed: int) -> Path:
    rng = np.random.default_rng(seed)
    save_map(OccupancyGrid(rng.choice(np.array([-1, 0, 100], np.int8), (20, 20))), path)
    return path


@pytest.fixture(scope="module")
def demo_files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, np.ndarray]:
    """The demo pair of floor plan 9 written with save_map, and the true transform."""
    folder = tmp_path_factory.mktemp("pair")
    map1, map2, truth = demo_pair(9)
    save_map(map1, folder / "robot_a.yaml")
    save_map(map2, folder / "robot_b.yaml", image_format="png")
    return folder / "robot_a.yaml", folder / "robot_b.yaml", truth


def test_help_lists_merge(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(["--help"], capsys)
    assert status == 0
    assert "merge" in out


def test_help_before_a_command_describes_every_command(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, out, _ = run(["-h", "explore"], capsys)
    assert status == 0
    assert "merge map_server maps" in out  # the merge command's line, not only its name


def test_no_command_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = run([], capsys)
    assert status == 2
    assert out == ""
    assert_one_line_error(err, "COMMAND")


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["merge", "-o", "m.yaml"], "at least two maps to merge (got 0)"),
        (["merge", "a.yaml", "-o", "m.yaml"], "at least two maps to merge (got 1)"),
        (["merge", "a.yaml", "b.yaml"], "-o/--output"),
        (["merge", "a.yaml", "b.yaml", "-o", "m.yaml", "--seed", "x"], "--seed"),
        (["merge", "a.yaml", "b.yaml", "-o", "m.yaml", "--seed", "-3"], "non-negative"),
        (
            ["merge", "a.yaml", "b.yaml", "-o", "m.yaml", "--method", "nope"],
            "unknown merging method",
        ),
        (["merge", "a.yaml", "b.yaml", "-o", "m.pgm"], "give e.g. m.yaml"),
        (["merge", "a.yaml", "b.yaml", "-o", "merged"], "got merged; give e.g. merged.yaml"),
        (["merge", "a.yaml", "b.yaml", "-o", "."], "got .; give e.g. merged.yaml"),
        (["merge", "a.yaml", "b.yaml", "-o", ".yaml"], "got .yaml; give e.g. merged.yaml\n"),
        (["merge", "a.yaml", "b.yaml", "-o", "a.yaml"], "also an input"),
        (["merge", "a.yaml", "--demo", "-o", "m.yaml"], "not both"),
        (["merge", "--bogus", "-o", "m.yaml"], "--bogus"),
    ],
)
def test_usage_errors_exit_2_with_one_line(
    argv: list[str],
    fragment: str,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    status, out, err = run(argv, capsys)
    assert status == 2
    assert out == ""
    assert_one_line_error(err, fragment)
    assert not (tmp_path / "m.yaml").exists()


def test_missing_file_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = write_grid(tmp_path / "good.yaml", 1)
    status, out, err = run(
        ["merge", str(good), str(tmp_path / "gone.yaml"), "-o", str(tmp_path / "m.yaml")], capsys
    )
    assert status == 1
    assert out == ""
    assert_one_line_error(err, "gone.yaml", "not found")


def test_bad_yaml_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = write_grid(tmp_path / "good.yaml", 1)
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: [unclosed\nresolution: 0.05\n")
    status, _, err = run(["merge", str(good), str(bad), "-o", str(tmp_path / "m.yaml")], capsys)
    assert status == 1
    assert_one_line_error(err, "bad.yaml", "not valid YAML")


def test_unreadable_image_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = write_grid(tmp_path / "good.yaml", 1)
    broken = write_grid(tmp_path / "broken.yaml", 2)
    (tmp_path / "broken.pgm").write_bytes(b"this is not an image")
    status, _, err = run(["merge", str(good), str(broken), "-o", str(tmp_path / "m.yaml")], capsys)
    assert status == 1
    assert_one_line_error(err, "cannot read map", "broken.yaml")


def test_unwritable_output_folder_exits_1_before_merging(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second = write_grid(tmp_path / "a.yaml", 1), write_grid(tmp_path / "b.yaml", 2)
    blocker = tmp_path / "file"
    blocker.write_text("a file where a folder should be")
    status, out, err = run(
        ["merge", str(first), str(second), "-o", str(blocker / "m.yaml")], capsys
    )
    assert status == 1
    assert out == ""
    assert_one_line_error(err, "cannot write", "not a directory")


def test_a_missing_output_folder_is_not_created(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second = write_grid(tmp_path / "a.yaml", 1), write_grid(tmp_path / "b.yaml", 2)
    output = tmp_path / "no" / "such" / "m.yaml"
    status, out, err = run(["merge", str(first), str(second), "-o", str(output)], capsys)
    assert status == 1 and out == ""
    assert_one_line_error(err, "folder", "does not exist", "-o")
    assert not (tmp_path / "no").exists()


def test_output_that_is_a_directory_exits_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second = write_grid(tmp_path / "a.yaml", 1), write_grid(tmp_path / "b.yaml", 2)
    (tmp_path / "m.yaml").mkdir()
    status, out, err = run(
        ["merge", str(first), str(second), "-o", str(tmp_path / "m.yaml")], capsys
    )
    assert status == 1
    assert out == ""
    assert_one_line_error(err, "is a directory")


def test_merge_never_writes_over_an_input_s_image(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second = write_grid(tmp_path / "a.yaml", 1), write_grid(tmp_path / "b.yaml", 2)
    # The output's image goes beside it with its name: shared.yaml writes shared.pgm,
    # which here is the image of input a.yaml.
    (tmp_path / "a.pgm").rename(tmp_path / "shared.pgm")
    first.write_text(first.read_text().replace("a.pgm", "shared.pgm"))
    before = (tmp_path / "shared.pgm").read_bytes()
    output = tmp_path / "shared.yaml"
    status, _, err = run(["merge", str(first), str(second), "-o", str(output)], capsys)
    assert status == 2
    assert_one_line_error(err, "shared.pgm, the image of input", "choose another output")
    assert (tmp_path / "shared.pgm").read_bytes() == before
    assert not output.exists()


def test_merge_two_saved_maps_end_to_end(
    demo_files: tuple[Path, Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second, truth = demo_files
    output = tmp_path / "merged.YAML"  # a suffix in any case, as maps are read
    status, out, err = run(["merge", str(first), str(second), "-o", str(output), "--json"], capsys)
    assert status == 0, err
    report = json.loads(out)
    (pair,) = report["pairs"]
    assert (pair["i"], pair["j"], pair["accepted"], pair["in_tree"]) == (0, 1, True, True)
    estimate = np.linalg.inv(report["maps"][0]["matrix"]) @ np.array(report["maps"][1]["matrix"])
    rms, _ = transform_error(estimate, truth, load_map(second).data)
    assert rms < MAX_ERROR_CELLS
    merged = load_map(output)
    assert merged.shape == (report["fused"]["rows"], report["fused"]["cols"])
    # map 0's cells keep their place in metres in the merged map
    grid0 = load_map(first)
    cell = np.array([[5.0, 7.0]])
    into = np.array(report["maps"][0]["matrix"])
    np.testing.assert_allclose(
        merged.cell_to_world(cell @ into[:2, :2].T + into[:2, 2]),
        grid0.cell_to_world(cell),
        atol=1e-6,
    )
    assert report["unlinked"] == [] and report["reference"]["index"] == 0


def test_merge_takes_the_default_merger_s_settings_by_name(
    demo_files: tuple[Path, Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second, _ = demo_files
    output = tmp_path / "merged.yaml"
    maps = ["merge", str(first), str(second), "-o", str(output)]
    status, out, err = run([*maps, "--json", "--merger", "confidence.accept=0.5"], capsys)
    assert status == 0, err
    report = json.loads(out)
    assert report["merger_settings"] == {"confidence.accept": 0.5}
    (pair,) = report["pairs"]
    assert pair["accepted"] and pair["confidence"] < 0.999
    output.unlink()
    # Asked for more confidence than the pair has, the merger refuses it: nothing written.
    status, _, err = run([*maps, "--merger", "confidence.accept=0.999"], capsys)
    assert status == 1
    assert_one_line_error(err, "could not link any two of the 2 maps")
    assert not output.exists()
    status, _, err = run([*maps, "--merger", "confidence.acept=0.5"], capsys)
    assert status == 2
    assert_one_line_error(err, "--merger: no merger setting named 'confidence.acept'")
    status, _, err = run([*maps, "--method", "spectral", "--merger", "robust.margin=0.2"], capsys)
    assert status == 2
    assert_one_line_error(err, "the 'spectral' method takes none")
    status, _, err = run([*maps, "--merger", "robust.margin"], capsys)
    assert status == 2
    assert_one_line_error(err, "--merger takes NAME=VALUE")


def test_merge_maps_of_different_resolutions(
    demo_files: tuple[Path, Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Map 2 saved at half the resolution (each 2 x 2 block as one cell): merged, and
    # the pair's transform in metres matches the one between the full-resolution maps.
    first, second, _ = demo_files
    fine = load_map(second)
    blocks = fine.data[: fine.shape[0] // 2 * 2, : fine.shape[1] // 2 * 2]
    coarse = blocks.reshape(fine.shape[0] // 2, 2, fine.shape[1] // 2, 2).max(axis=(1, 3))
    halved = tmp_path / "coarse.yaml"
    save_map(OccupancyGrid(coarse, resolution=2 * fine.resolution, origin=fine.origin), halved)
    runs = {}
    for name, path in (("fine", second), ("coarse", halved)):
        output = tmp_path / f"{name}_merged.yaml"
        status, out, err = run(
            ["merge", str(first), str(path), "-o", str(output), "--json"], capsys
        )
        assert status == 0, err
        report = json.loads(out)
        assert report["unlinked"] == []
        runs[name] = report["maps"][1]["metres"]
    fine_pose, coarse_pose = runs["fine"], runs["coarse"]
    assert np.hypot(fine_pose["x"] - coarse_pose["x"], fine_pose["y"] - coarse_pose["y"]) < 0.15
    assert abs(fine_pose["theta_deg"] - coarse_pose["theta_deg"]) < 0.5


def test_merge_maps_whose_resolutions_have_no_ratio_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Resampling once ran outside the command's error handling: a raw traceback.
    cells = np.zeros((20, 20), dtype=np.int8)
    cells[5, :] = 100
    paths = [tmp_path / "tiny.yaml", tmp_path / "huge.yaml"]
    for path, resolution in zip(paths, (1e-300, 1e300), strict=True):
        save_map(OccupancyGrid(cells, resolution=resolution), path)
    status, _, err = run(["merge", *map(str, paths), "-o", str(tmp_path / "m.yaml")], capsys)
    assert status == 1
    assert_one_line_error(err, "cannot bring the maps to one resolution")
    assert not (tmp_path / "m.yaml").exists()


def test_table_output_is_aligned(
    demo_files: tuple[Path, Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, second, _ = demo_files
    status, out, _ = run(["merge", str(first), str(second), "-o", str(tmp_path / "m.yaml")], capsys)
    assert status == 0
    lines = out.splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("map "))
    header, *rows = lines[start : start + 3]
    # numeric columns are right-aligned under their headers: every line ends at the same place
    assert {len(line) for line in rows} == {len(header)}
    linked_end = header.index("linked") + len("linked")
    assert all(row[linked_end - 3 : linked_end] == "yes" for row in rows)
    assert any(line.startswith("0-1 ") for line in lines)


def test_format_table_pads_columns() -> None:
    table = format_table(["a", "value"], [["xyz", "1.5"], ["q", "10.25"]])
    assert table.splitlines() == ["a    value", "xyz    1.5", "q    10.25"]


def test_demo_writes_its_pair_and_prints_the_truth(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    output = tmp_path / "merged.yaml"
    status, out, err = run(["merge", "--demo", "2", "-o", str(output), "--json"], capsys)
    assert status == 0, err
    report = json.loads(out)
    assert {Path(entry["path"]).name for entry in report["maps"]} == {
        "merged_demo1.yaml",
        "merged_demo2.yaml",
    }
    assert (tmp_path / "merged_demo2.pgm").is_file() and output.is_file()
    demo = report["demo"]
    assert demo["accepted"]
    assert demo["error_rms_cells"] < MAX_ERROR_CELLS
    assert abs(demo["truth"]["theta_deg"] - demo["estimate"]["theta_deg"]) < 1.0


def test_demo_table_shows_truth_beside_estimate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, _ = run(["merge", "--demo", "-o", str(tmp_path / "merged.yaml")], capsys)
    assert status == 0
    lines = out.splitlines()
    true_line = next(line for line in lines if line.strip().startswith("true"))
    estimated = next(line for line in lines if line.strip().startswith("estimated"))
    assert lines.index(estimated) == lines.index(true_line) + 1


def test_unlinkable_maps_exit_1_and_write_nothing(
    demo_files: tuple[Path, Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A map without walls cannot be placed: the merge fails unless --partial is given."""
    first, second, _ = demo_files
    empty = tmp_path / "empty.yaml"
    save_map(OccupancyGrid(np.zeros((30, 30), np.int8)), empty)
    output = tmp_path / "m.yaml"
    argv = ["merge", str(first), str(second), str(empty), "-o", str(output)]
    status, out, err = run(argv, capsys)
    assert status == 1
    assert "not written" in out  # the report still shows the pairs, to see why
    assert_one_line_error(err, "could not link", "empty.yaml", "--partial")
    assert str(first) not in err and str(second) not in err
    assert not output.exists() and not output.with_suffix(".pgm").exists()
    # With two maps and no link, neither is to blame, and neither is shown as linked.
    argv = ["merge", str(first), str(empty), "-o", str(output), "--json"]
    status, out, err = run(argv, capsys)
    assert status == 1
    assert_one_line_error(err, "could not link any two of the 2 maps", "--partial to write map 0")
    assert [entry["linked"] for entry in json.loads(out)["maps"]] == [False, False]


def test_partial_merge_writes_the_linked_maps(
    demo_files: tuple[Path, Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first, _, _ = demo_files
    empty = tmp_path / "empty.yaml"
    save_map(OccupancyGrid(np.zeros((30, 30), np.int8)), empty)
    output = tmp_path / "m.yaml"
    argv = ["merge", str(first), str(empty), "-o", str(output), "--json", "--partial"]
    status, out, err = run(argv, capsys)
    assert status == 0
    report = json.loads(out)
    assert report["unlinked"] == [1] and report["written"] is True
    assert [entry["linked"] for entry in report["maps"]] == [False, False]
    assert any(note.startswith("map 1 not linked") for note in report["notes"])
    np.testing.assert_array_equal(load_map(output).data, load_map(first).data)
    assert err.count("\n") == 1 and "empty.yaml" in err and "warning" in err


def test_help_lists_methods_and_version(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(["merge", "--help"], capsys)
    assert status == 0
    assert all(method in out for method in available_methods())
    assert "available_methods()" not in out
    status, out, _ = run(["--version"], capsys)
    assert status == 0 and out.startswith("tomosim ") and out.strip() != "tomosim"


def test_a_command_imports_its_own_module_alone() -> None:
    # `tomosim maps` needs neither the simulator nor the viewer's SDK: only the module
    # of the command named is imported (0.6 s instead of 1.4 s on the command line).
    script = (
        "import sys; from tomosim.cli import main; status = main(['maps', '--help']); "
        "print(status, 'rerun' in sys.modules, 'tomosim.commands.explore' in sys.modules)"
    )
    printed = run_python(script)
    assert "--json" in printed  # the maps command's own options were added
    assert printed.splitlines()[-1] == "0 False False"


def test_a_misspelt_command_is_refused_with_every_name(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, _, err = run(["explor"], capsys)
    assert status == 2
    for name in ("explore", "review", "merge", "sweep", "maps"):
        assert name in err
