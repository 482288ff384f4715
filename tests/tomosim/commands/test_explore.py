"""``tomosim explore`` and ``tomosim review``: a recorded run read back, and bad input."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from merging import OccupancyGrid, save_map
from tests.tomosim.commands.cli_support import assert_one_line_error, run
from tests.tomosim.recording.test_recording import free_port, verify, write_foreign
from tomosim.cli import main
from tomosim.commands import progress, review
from tomosim.commands.explore_report import recorded_figures, render_figures
from tomosim.commands.review import describe_status
from tomosim.recording import RecordedRun, Series, read_recording
from tomosim.recording.paths import (
    COVERAGE,
    OVERLAP_RATE,
    PATH_LENGTH_TOTAL,
    path_length_path,
    robot_coverage_path,
)

SHORT_RUN = ["--robots", "2", "--steps", "60", "--merge-interval", "20", "--seed", "3"]
"""A run short enough for the suite: two robots on the default floor, merge rounds every 20
steps, and every 10 while their maps are not linked."""
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
STOP_TIMEOUT_S = 120.0
"""Longest wait for a run in its own process to get going, or to stop once signalled."""
RECORDED_BYTES = 800_000
"""Bytes of recording after which a run is stopped: the world and some steps."""


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


@pytest.mark.slow
def test_explore_reports_a_run_and_records_it(explored: tuple[Path, dict]) -> None:
    record, report = explored
    assert report["steps"] == 60 and report["stop_reason"] == "step limit reached"
    assert report["settings"]["robots"] == 2 and report["settings"]["world"] == "floorplan seed=0"
    assert [m["step"] for m in report["merges"]] == [10, 20, 30, 40, 50, 60]
    assert 0.0 < report["coverage"] < 1.0
    assert report["record"] == str(record)
    verify(record)


@pytest.mark.slow
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
            for key in ("accepted", "confirmed", "used", "dropped", "confidence", "matching_index"):
                assert back[key] == pair[key], (name, key)
            if pair["accepted"]:
                assert back["rotation_error_deg"] == pair["rotation_error_deg"]
                assert back["translation_error_m"] == pair["translation_error_m"]
            else:
                assert "rotation_error_deg" not in back
    assert review["first_link_step"] == report["merge_stats"]["first_link_step"]
    assert review["all_linked_step"] == report["merge_stats"]["all_linked_step"]
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


def test_review_names_the_first_round_that_used_a_link(explored: tuple[Path, dict]) -> None:
    record, _ = explored
    report = review.summary(read_recording(record))
    for merge in report["merges"]:
        for pair in merge["pairs"].values():
            pair["used"] = pair["dropped"] = False
    assert review.first_link_step(report["merges"]) is None
    report["first_link_step"] = None
    assert "first link" not in review.render(report)
    linked = report["merges"][2]
    next(iter(linked["pairs"].values()))["used"] = True
    report["first_link_step"] = review.first_link_step(report["merges"])
    assert report["first_link_step"] == linked["step"]
    text = review.render(report)
    assert f"{'first link':<16}step {linked['step']}" in text
    row = next(line for line in text.splitlines() if line.startswith(f"{linked['step']:>6}  r0-r1"))
    assert row.split()[5] == "yes"  # step, pair, confidence, accepted, confirmed, used


@pytest.mark.slow
def test_review_finds_the_round_that_linked_all_three_maps(tmp_path: Path) -> None:
    """On the default world the third map joins after the first link (the README's run):
    review reads the round from the recording as the run counted it."""
    record = tmp_path / "three.rrd"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["explore", "--steps", "400", "--record", str(record), "--json"]) == 0
    stats = json.loads(out.getvalue())["merge_stats"]
    assert stats["first_link_step"] < stats["all_linked_step"]
    recorded = read_recording(record)
    back = review.summary(recorded)
    assert back["all_linked_step"] == stats["all_linked_step"]
    assert back["first_link_step"] == stats["first_link_step"]
    from tomosim.commands.review_plot import plot_summary  # the two steps marked in the PNG

    plot_summary(recorded, back, tmp_path / "three.png")
    assert (tmp_path / "three.png").read_bytes()[:8] == PNG_SIGNATURE


def test_review_names_the_first_round_whose_links_join_every_robot(
    explored: tuple[Path, dict],
) -> None:
    def rounds(*used: tuple[str, ...]) -> list[dict]:
        names = ("r0-r1", "r0-r2", "r1-r2", "r2-r3")
        return [
            {"step": 10 * (k + 1), "pairs": {n: {"used": n in names_used} for n in names}}
            for k, names_used in enumerate(used)
        ]

    # Two pairs of robots linked apart, then joined; then a round that lost a link.
    timeline = rounds(("r0-r1",), ("r0-r1", "r2-r3"), ("r0-r1", "r1-r2", "r2-r3"), ("r0-r1",))
    assert review.all_linked_step(timeline, 4) == 30
    assert review.all_linked_step(timeline, None) == 30  # four robots, by the pairs' names
    assert review.all_linked_step(timeline, 5) is None  # robot 4 never linked
    assert review.all_linked_step(timeline[:2], 4) is None
    assert review.all_linked_step(timeline, 1) is None
    report = review.summary(read_recording(explored[0]))
    report["all_linked_step"] = 30
    assert f"{'all linked':<16}step 30" in review.render(report)
    report["all_linked_step"] = None
    assert "all linked" not in review.render(report)


def test_review_of_a_recording_without_the_linking_s_choice_says_it_does_not_know(
    explored: tuple[Path, dict],
) -> None:
    record, _ = explored
    report = review.summary(read_recording(record))
    for merge in report["merges"]:
        for pair in merge["pairs"].values():
            pair["used"] = pair["dropped"] = None  # as read from an older recording
    report["first_link_step"] = review.first_link_step(report["merges"])
    assert report["first_link_step"] is None
    rows = [line for line in review.render(report).splitlines() if " r0-r1 " in line]
    assert rows and all(line.split()[5] == "-" for line in rows)


def test_review_never_writes_its_image_over_the_recording_or_under_another_suffix(
    explored: tuple[Path, dict], capsys: pytest.CaptureFixture[str]
) -> None:
    record, _ = explored
    before = record.read_bytes()
    status, _, err = run(["review", str(record), "--png", str(record)], capsys)
    assert status == 2
    assert_one_line_error(err, "is the recording itself")
    status, _, err = run(["review", str(record), "--png", str(record.with_suffix(".jpg"))], capsys)
    assert status == 2
    assert_one_line_error(err, "--png must name a .png file")
    assert record.read_bytes() == before
    assert not record.with_suffix(".jpg").exists()


def test_review_of_a_file_cut_to_its_header_names_the_user_s_file(
    explored: tuple[Path, dict], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    record, _ = explored
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(record.read_bytes()[:100])
    status, _, err = run(["review", str(cut)], capsys)
    assert status == 1
    assert_one_line_error(err, str(cut))
    assert "tomosim-review-" not in err  # not the repaired copy's temporary path


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
    # 12 steps link no maps: the merged map line names no first link (the README's
    # default run, checked line for line, names one).
    [merged] = [line for line in out.splitlines() if line.startswith("merged map")]
    assert "agreement with the truth" in merged and "first link" not in merged
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


@pytest.mark.slow
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
        (["explore", "--robots", "0"], ["--robots must be from 1 to 16, got 0"]),
        (["explore", "--robots", "5000"], ["--robots must be from 1 to 16, got 5000", "pairs"]),
        (["explore", "--spawn", "--serve-web"], ["not allowed with"]),
        (["explore", "--steps", "0"], ["--steps"]),
        (["explore", "--serve-web", "--web-port", "70000"], ["--web-port must be from 1"]),
        (
            ["explore", "--serve-web", "--web-port", "9000", "--grpc-port", "9000"],
            ["--web-port and --grpc-port must differ"],
        ),
        (["explore", "--merge-interval", "0"], ["--merge-interval"]),
        (["explore", "--method", "nope"], ["unknown merging method 'nope'"]),
        (["explore", "--record", "run.txt"], [".rrd"]),
        (["explore", "--world", "map.png"], ["--world must be a seed", "map_server .yaml"]),
        (["explore", "--coverage-target", "1.5"], ["--coverage-target"]),
        (["explore", "--seed", "-1"], ["--seed"]),
        (["explore", "--policy", "greedy"], ["unknown policy 'greedy'", "utility"]),
        (["explore", "--comm-range", "0"], ["--comm-range must be a positive number"]),
        (["explore", "--line-of-sight"], ["--line-of-sight needs --comm-range"]),
        (["explore", "--record", "x.rrd", "--no-record"], ["--record or --no-record, not both"]),
        (["explore", "--no-merge", "--method", "oracle"], ["drop --method oracle"]),
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
    earlier = tmp_path / "r.rrd"
    earlier.write_bytes(b"an earlier run's recording")
    status, _, err = run(["explore", "--world", str(missing), "--record", str(earlier)], capsys)
    assert status == 1
    assert_one_line_error(err, "--world", "nowhere.yaml: no such map file")
    assert earlier.read_bytes() == b"an earlier run's recording"  # a run that never started


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
    (tmp_path / "folder.rrd").mkdir()
    status, _, err = run(["review", str(tmp_path / "folder.rrd")], capsys)
    assert status == 1
    assert_one_line_error(err, "folder.rrd is a directory")
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"\x00" * 64)
    status, _, err = run(["review", str(junk)], capsys)
    assert status == 1
    assert_one_line_error(err, "junk.rrd is not a rerun recording", "tomosim explore")
    other = tmp_path / "other.rrd"
    write_foreign(other, "somebody_else", "{}")
    status, _, err = run(["review", str(other)], capsys)
    assert status == 1
    assert_one_line_error(err, "other.rrd", "'somebody_else', not of 'tomosim'")
    odd = tmp_path / "odd.rrd"
    write_foreign(odd, "tomosim", "not json")
    status, _, err = run(["review", str(odd)], capsys)
    assert status == 1
    assert_one_line_error(err, "odd.rrd", "run/config is not JSON")


def test_a_world_without_room_for_the_team(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    room = np.full((60, 60), 100, np.int8)
    room[5:-5, 5:-5] = 0  # 2.5 m square of free space
    path = write_map(tmp_path, room)
    argv = ["explore", "--world", str(path), "--robots", "16", "--no-record"]
    status, _, err = run(argv, capsys)
    assert status == 1
    assert_one_line_error(err, "map.yaml", "has room for only", "use --robots")
    assert "min_separation" not in err


def test_a_recording_that_cannot_be_created(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dangling = tmp_path / "run.rrd"
    dangling.symlink_to(tmp_path / "gone" / "run.rrd")
    status, _, err = run(["explore", "--steps", "3", "--record", str(dangling)], capsys)
    assert status == 1
    assert_one_line_error(err, "cannot write the recording", "run.rrd")


def test_a_recording_that_fails_while_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Writes to /dev/full fail as on a full disk: one line naming the file, no traceback."""
    if not Path("/dev/full").exists():
        pytest.skip("needs /dev/full to stand for a full disk")
    full = tmp_path / "full.rrd"
    full.symlink_to("/dev/full")
    status, _, err = run(
        ["explore", "--robots", "2", "--steps", "30", "--record", str(full)], capsys
    )
    assert status == 1
    assert_one_line_error(err, "full.rrd")


def test_no_record_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    status, out, _ = run(["explore", "--robots", "2", "--steps", "5", "--no-record"], capsys)
    assert status == 0 and "team coverage" in out
    assert list(tmp_path.iterdir()) == []


def test_connect_without_a_viewer_fails_before_running(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url = f"rerun+http://127.0.0.1:{free_port()}/proxy"
    argv = ["explore", "--connect", url, "--record", str(tmp_path / "r.rrd")]
    status, out, err = run(argv, capsys)
    assert status == 1 and out == ""
    assert_one_line_error(err, "no viewer listens at", url, "rerun")


def test_progress_lines_when_not_on_a_terminal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(progress, "LINE_INTERVAL_S", 0.0)
    argv = ["explore", *SHORT_RUN, "--steps", "12", "--record", str(tmp_path / "p.rrd")]
    status, _, err = run(argv, capsys)
    assert status == 0
    lines = err.splitlines()
    assert "explore: 1/12 steps, team coverage" in lines[0]
    assert lines[-1].startswith("explore: 12/12 steps, team coverage")


def explore_in_background(record: Path) -> subprocess.Popen[str]:
    """``tomosim explore`` in its own process, long enough to be stopped midway."""
    command = [
        sys.executable, "-m", "tomosim.cli", "explore", "--robots", "2", "--steps", "1500",
        "--coverage-target", "1.0", "--record", str(record),
    ]  # fmt: skip
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_steps(record: Path, process: subprocess.Popen[str]) -> None:
    """Wait until the run has flushed part of its recording, well before it ends."""
    deadline = time.monotonic() + STOP_TIMEOUT_S
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        if record.is_file() and record.stat().st_size > RECORDED_BYTES:
            return
        time.sleep(0.1)
    process.kill()
    pytest.fail(f"the run wrote less than {RECORDED_BYTES} bytes in {STOP_TIMEOUT_S} s")


@pytest.mark.slow
def test_sigterm_stops_explore_cleanly(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    record = tmp_path / "stopped.rrd"
    process = explore_in_background(record)
    wait_for_steps(record, process)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=STOP_TIMEOUT_S)
    assert process.returncode == 128 + signal.SIGTERM, err
    assert out == ""
    line = [line for line in err.splitlines() if line.startswith("tomosim:")]
    assert line == [line[0]] and "terminated (SIGTERM)" in line[0]
    assert f"tomosim review {record}" in line[0] and "Traceback" not in err
    verify(record)  # closed properly: footer and all
    status, report_text, _ = run(["review", str(record), "--json", "--no-png"], capsys)
    assert status == 0
    report = json.loads(report_text)
    assert report["finished"] is False
    assert report["status"].startswith("did not finish: interrupted at step")
    assert report["status"].endswith("SIGTERM")
    assert 0 < report["steps"] < 1500
    # The message and the recording name the same last step.
    said = re.search(r"up to step (\d+)", line[0])
    recorded = re.search(r"interrupted at step (\d+)", report["status"])
    assert said is not None and recorded is not None and said[1] == recorded[1]


@pytest.mark.slow
def test_review_marks_a_killed_run_unfinished_and_reads_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    record = tmp_path / "killed.rrd"
    process = explore_in_background(record)
    wait_for_steps(record, process)
    process.kill()
    process.communicate(timeout=STOP_TIMEOUT_S)
    status, out, err = run(["review", str(record), "--no-png"], capsys)
    assert status == 0
    assert "run did not finish" in out and "killed" in out
    assert "tomosim: warning:" in err and "killed.rrd" in err
    steps = int(out.split("\nsteps")[1].split()[0])
    assert steps > 0


def test_a_signal_inside_a_compiled_call_stops_explore_cleanly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # A signal handler's exception raised while a numba function hands back its result
    # reaches Python as a SystemError caused by it; the run must stop as on any step.
    from tomosim.commands.stopping import Stopped
    from tomosim.team.session import TeamSession

    step = TeamSession.step
    calls = []

    def step_then_signal(self: TeamSession, commands: object) -> object:
        calls.append(1)
        if len(calls) == 5:
            try:
                raise Stopped(signal.SIGTERM)
            except Stopped as interrupt:
                raise SystemError("returned a result with an exception set") from interrupt
        return step(self, commands)

    monkeypatch.setattr(TeamSession, "step", step_then_signal)
    record = tmp_path / "signalled.rrd"
    status, out, err = run(["explore", *SHORT_RUN, "--record", str(record)], capsys)
    assert status == 128 + signal.SIGTERM and out == ""
    assert "terminated (SIGTERM)" in err and f"tomosim review {record}" in err
    verify(record)


def signal_lost_at_step(at: int, monkeypatch: pytest.MonkeyPatch, then: Exception | None) -> None:
    """Make step ``at`` of a run receive a real SIGTERM whose exception is swallowed.

    As when the signal lands in a ctypes callback (numba compiling a kernel on a
    first run), which prints "Exception ignored" and goes on; ``then`` is an
    error the step raises afterwards, as an unfinished compilation might.
    """
    from tomosim.commands.stopping import Stopped
    from tomosim.team.session import TeamSession

    step = TeamSession.step
    calls = []

    def step_losing_a_signal(self: TeamSession, commands: object) -> object:
        calls.append(1)
        if len(calls) == at:
            with contextlib.suppress(Stopped):
                os.kill(os.getpid(), signal.SIGTERM)
                for _ in range(1000):  # the handler runs between bytecodes, soon
                    time.sleep(0.001)
            assert len(calls) == at  # the handler ran and raised, and it was swallowed
            if then is not None:
                raise then
        return step(self, commands)

    monkeypatch.setattr(TeamSession, "step", step_losing_a_signal)


@pytest.mark.parametrize("then", [None, ValueError("kernel left half compiled")])
def test_a_signal_whose_exception_was_lost_still_stops_explore(
    then: Exception | None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    signal_lost_at_step(5, monkeypatch, then)
    record = tmp_path / "lost.rrd"
    status, out, err = run(["explore", *SHORT_RUN, "--record", str(record)], capsys)
    assert status == 128 + signal.SIGTERM and out == "", err
    assert "terminated (SIGTERM)" in err and f"tomosim review {record}" in err
    assert "error" not in err
    verify(record)
    status, report_text, _ = run(["review", str(record), "--json", "--no-png"], capsys)
    report = json.loads(report_text)
    assert report["status"].endswith("SIGTERM") and report["steps"] <= 5


def test_other_system_errors_are_not_taken_for_signals() -> None:
    from tomosim.kernels.jit import interrupts_unwrapped

    with pytest.raises(SystemError, match="not a signal"), interrupts_unwrapped():
        raise SystemError("not a signal")


def test_an_interrupt_before_the_run_began_says_nothing_was_recorded(tmp_path: Path) -> None:
    # It said the file "keeps the run up to step 0", while an earlier run's file of
    # that name stood untouched (or there was none).
    from tomosim.commands.explore import kept
    from tomosim.recording import Recorder

    earlier = tmp_path / "earlier.rrd"
    earlier.write_bytes(b"an earlier run")
    assert kept(earlier, 0, started=False) == (
        f"stopped before the run began; nothing was recorded ({earlier} is an earlier "
        "run's, left as it was)"
    )
    missing = tmp_path / "new.rrd"
    assert kept(missing, 0, started=False).endswith("nothing was recorded")
    assert "keeps the run up to step 12" in kept(missing, 12)
    recorder = Recorder.open(record=missing)
    assert not recorder.started
    recorder.close()
    assert not missing.exists()


def test_the_settings_line_names_the_policy_and_the_radios_reach() -> None:
    from tomosim.commands.explore_report import settings_line

    settings = {"world": "floorplan seed=0", "robots": 1, "policy": "nearest", "merge": True,
                "merge_interval": 50, "method": "tomographic", "comm_range": 5.0,
                "line_of_sight": True, "seed": 3}  # fmt: skip
    assert settings_line(settings) == (
        "world floorplan seed=0, 1 robot, nearest policy, merging every 50 steps "
        "(tomographic), talking within 5 m in line of sight, seed 3"
    )
    plain = {**settings, "robots": 3, "merge": False, "comm_range": None}
    assert (
        settings_line(plain)
        == "world floorplan seed=0, 3 robots, nearest policy, no merging, seed 3"
    )


def test_the_command_line_builds_the_episode_s_team() -> None:
    from tomosim.cli import build_parser
    from tomosim.commands.explore import build_config
    from tomosim.team import CommsConfig, TeamConfig

    argv = ["explore", "--merge-interval", "30", "--method", "oracle", "--comm-range", "4",
            "--line-of-sight", "--no-record"]  # fmt: skip
    config = build_config(build_parser().parse_args(argv))
    assert config.team == TeamConfig(
        method="oracle", merge_interval=30, comms=CommsConfig(4.0, line_of_sight=True)
    )
    plain = build_config(build_parser().parse_args(["explore", "--no-merge"]))
    assert plain.team == TeamConfig(merge=False)  # every other setting the team's default


def test_a_recording_cut_between_its_series_is_summarised_at_one_step() -> None:
    # rerun writes a robot's coverage before its path length: a file cut between them
    # failed with a KeyError, and the figures mixed the series' last steps.
    def series(last: int, scale: float) -> Series:
        steps = np.arange(last + 1)
        return Series(steps, steps * scale)

    run = RecordedRun(
        Path("cut.rrd"),
        {"coverage_target": 0.9, "dt": 0.1},
        {
            COVERAGE: series(279, 0.001),
            robot_coverage_path(0): series(279, 0.001),
            path_length_path(0): series(278, 0.1),
            robot_coverage_path(1): series(279, 0.002),  # its path length was not written
            PATH_LENGTH_TOTAL: series(278, 0.2),
            OVERLAP_RATE: series(300, 0.0),
        },
        {},
        notes=("cut.rrd is cut short",),
    )
    figures = recorded_figures(run)
    assert figures["at_step"] == 278
    assert figures["path_length_m"] == pytest.approx(55.6)
    assert figures["robots"] == [
        {"coverage": pytest.approx(0.278), "path_length_m": pytest.approx(27.8)},
        {"coverage": pytest.approx(0.556), "path_length_m": None},
    ]
    assert "r1 -" in "\n".join(render_figures(figures))
    assert describe_status(run).startswith("did not finish: the recording was cut short")
