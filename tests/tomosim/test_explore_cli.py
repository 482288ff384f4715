"""``tomosim explore`` and ``tomosim review``: a recorded run read back, and bad input."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from merging import OccupancyGrid, save_map
from tests.tomosim.test_recording import verify
from tomosim.cli import main

from .cli_support import assert_one_line_error, run

SHORT_RUN = ["--robots", "2", "--steps", "60", "--merge-interval", "20", "--seed", "3"]
"""A run short enough for the suite: two robots, three merge rounds on the default floor."""
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def explored(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """``tomosim explore --json`` of the short run, and what it printed."""
    folder = tmp_path_factory.mktemp("explore")
    record = folder / "short.rrd"
    out = io.StringIO()  # capsys is per test; this run is shared by the module's tests
    with contextlib.redirect_stdout(out):
        status = main(["explore", *SHORT_RUN, "--record", str(record), "--json"])
    assert status == 0
    return record, json.loads(out.getvalue())


def test_explore_reports_a_run_and_records_it(explored: tuple[Path, dict]) -> None:
    record, report = explored
    assert report["steps"] == 60 and report["stop_reason"] == "step limit reached"
    assert report["settings"]["robots"] == 2 and report["settings"]["world"] == "floorplan seed=0"
    assert [m["step"] for m in report["merges"]] == [20, 40, 60]
    assert 0.0 < report["coverage"] < 1.0
    assert report["record"] == str(record)
    verify(record)


def test_review_reads_back_what_explore_reported(
    explored: tuple[Path, dict], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    record, report = explored
    png = tmp_path / "summary.png"
    status, out, _ = run(["review", str(record), "--json", "--png", str(png)], capsys)
    assert status == 0
    review = json.loads(out)
    assert review["steps"] == report["steps"]
    assert review["coverage"] == report["coverage"]
    assert review["settings"] == report["settings"]
    assert [m["step"] for m in review["merges"]] == [m["step"] for m in report["merges"]]
    for seen, ran in zip(review["merges"], report["merges"], strict=True):
        assert seen["agreement"] == ran["agreement"]
        for name, pair in ran["pairs"].items():
            back = seen["pairs"][name]
            for key in ("accepted", "confirmed", "confidence", "matching_index"):
                assert back[key] == pair[key], (name, key)
            if pair["accepted"]:
                assert back["rotation_error_deg"] == pair["rotation_error_deg"]
                assert back["translation_error_m"] == pair["translation_error_m"]
            else:
                assert "rotation_error_deg" not in back
    figures = review["exploration"]
    assert figures["path_length_m"] == pytest.approx(report["path_length_m"])
    assert figures["overlap_rate"] == pytest.approx(report["overlap_rate"])
    assert figures["steps_to_target"] == report["steps_to_target"]
    for seen_robot, ran_robot in zip(figures["robots"], report["robots"], strict=True):
        assert seen_robot == pytest.approx(ran_robot)
    assert png.read_bytes()[:8] == PNG_SIGNATURE


def test_review_prints_the_timeline_and_final_figures(
    explored: tuple[Path, dict], capsys: pytest.CaptureFixture[str]
) -> None:
    record, report = explored
    status, out, _ = run(["review", str(record), "--no-png"], capsys)
    assert status == 0
    assert "merge-quality timeline" in out
    assert f"{'steps':<16}60" in out
    assert f"{report['coverage']:.3f}" in out
    assert "r0-r1" in out and "summary image" not in out
    assert f"{report['path_length_m']:.1f} m" in out and "overlap rate" in out


def test_explore_text_summary(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    record = tmp_path / "text.rrd"
    argv = [
        "explore",
        "--robots",
        "2",
        "--steps",
        "12",
        "--merge-interval",
        "5",
        "--record",
        str(record),
    ]
    status, out, _ = run(argv, capsys)
    assert status == 0
    assert "team coverage" in out and "merge rounds      2:" in out
    assert "pair" in out and "r0-r1" in out
    assert f"recording: {record}" in out


def test_explore_reports_exploration_figures(explored: tuple[Path, dict]) -> None:
    _, report = explored
    robots = report["robots"]
    assert len(robots) == 2 and report["settings"]["policy"] == "utility"
    assert report["path_length_m"] == pytest.approx(sum(r["path_length_m"] for r in robots))
    own = sum(r["coverage"] for r in robots)
    assert report["overlap_rate"] == pytest.approx(own / report["coverage"] - 1.0)
    curve = report["coverage_curve"]
    assert curve["steps"][0] == 0 and curve["steps"][-1] == report["steps"]
    assert curve["team"][-1] == pytest.approx(report["coverage"], abs=1e-5)
    assert report["merge_stats"]["rounds"] == len(report["merges"])


def test_explore_with_the_oracle_and_a_communication_range(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["explore", *SHORT_RUN, "--method", "oracle", "--comm-range", "4", "--line-of-sight"]
    status, out, _ = run([*argv, "--record", str(tmp_path / "o.rrd"), "--json"], capsys)
    assert status == 0
    report = json.loads(out)
    assert report["settings"]["method"] == "oracle"
    assert report["settings"]["comm_range"] == 4.0 and report["settings"]["line_of_sight"]
    for merge in report["merges"]:
        for pair in merge["pairs"].values():
            # Right wherever accepted; refused only when out of reach.
            if pair["accepted"]:
                assert pair["rotation_error_deg"] < 1e-6 and pair["translation_error_m"] < 1e-6
            else:
                assert "out of communication reach" in pair["reason"]


def write_map(folder: Path, data: np.ndarray) -> Path:
    path = folder / "map.yaml"
    save_map(OccupancyGrid(data), path)
    return path


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (["explore", "--robots", "0"], ["--robots must be at least 1, got 0"]),
        (["explore", "--steps", "0"], ["--steps"]),
        (["explore", "--merge-interval", "0"], ["--merge-interval"]),
        (["explore", "--method", "nope"], ["unknown method 'nope'"]),
        (["explore", "--record", "run.txt"], [".rrd"]),
        (["explore", "--world", "map.png"], ["--world must be a seed or a map_server .yaml"]),
        (["explore", "--coverage-target", "1.5"], ["--coverage-target"]),
        (["explore", "--seed", "-1"], ["--seed"]),
        (["explore", "--policy", "greedy"], ["unknown policy 'greedy'", "utility"]),
        (["explore", "--comm-range", "0"], ["--comm-range must be a positive number"]),
        (["explore", "--line-of-sight"], ["--line-of-sight needs --comm-range"]),
        (["review", "run.txt"], [".rrd"]),
        (["review", "run.rrd", "--png", "a.png", "--no-png"], ["not both"]),
    ],
)
def test_usage_errors_exit_2_with_one_line(
    argv: list[str], fragments: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(argv, capsys)
    assert status == 2 and out == ""
    assert_one_line_error(err, *fragments)


def test_missing_map_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nowhere.yaml"
    status, _, err = run(
        ["explore", "--world", str(missing), "--record", str(tmp_path / "r.rrd")], capsys
    )
    assert status == 1
    assert_one_line_error(err, "not found", "nowhere.yaml")


def test_bad_yaml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: [unclosed\nresolution: 0.05\n")
    status, _, err = run(
        ["explore", "--world", str(bad), "--record", str(tmp_path / "r.rrd")], capsys
    )
    assert status == 1
    assert_one_line_error(err, "cannot explore", "not valid YAML")


def test_world_without_free_space(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    solid = write_map(tmp_path, np.full((40, 40), 100, np.int8))
    status, _, err = run(
        ["explore", "--world", str(solid), "--record", str(tmp_path / "r.rrd")], capsys
    )
    assert status == 1
    assert_one_line_error(err, "cannot explore", "no free region")


def test_unwritable_recording(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, _, err = run(["explore", "--record", str(tmp_path / "no" / "such" / "r.rrd")], capsys)
    assert status == 1
    assert_one_line_error(err, "does not exist")


def test_review_of_a_missing_or_foreign_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, _, err = run(["review", str(tmp_path / "absent.rrd")], capsys)
    assert status == 1
    assert_one_line_error(err, "no such recording")
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"\x00" * 64)
    status, _, err = run(["review", str(junk)], capsys)
    assert status == 1
    assert_one_line_error(err, "cannot read")
