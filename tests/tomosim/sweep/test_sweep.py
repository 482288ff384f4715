"""Sweeps: the same rows on every executor, and nothing lost or repeated when killed."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from merging import available_methods
from tests.tomosim.commands.cli_support import assert_one_line_error
from tomosim.cli import main
from tomosim.episode import EpisodeConfig
from tomosim.sweep import ROW_FIELDS, ResultsFile, SweepPlan, run_sweep
from tomosim.sweep.rows import EARLIER_ROW_FIELDS, TIMING_FIELDS
from tomosim.team import CommsConfig, TeamConfig
from tomosim.team.overrides import with_settings

MERGE_INTERVAL = 40
"""Steps between the merge rounds of the small episodes."""
SMALL = {
    "world_size": (15.0, 10.0),
    "steps": 120,
    "team": TeamConfig(merge_interval=MERGE_INTERVAL),
}
"""A small floor and short episodes: about a second each."""
KILL_TIMEOUT_S = 240.0
"""Longest wait for the first row of the sweep that is killed."""


def four_episodes() -> SweepPlan:
    return SweepPlan(
        worlds=("1",), robots=(2,), methods=("tomographic", "none"), seeds=(0, 1), **SMALL
    )  # type: ignore[arg-type]


def without_timing(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    kept = [{k: v for k, v in row.items() if k not in TIMING_FIELDS} for row in rows]
    return sorted(kept, key=lambda row: row["key"])


def test_plan_is_the_full_grid_in_a_fixed_order() -> None:
    plan = SweepPlan(
        worlds=("0", "2"),
        robots=(2, 3),
        policies=("nearest", "utility"),
        methods=("tomographic", "none"),
        seeds=(5,),
    )
    keys = [e.key for e in plan.episodes()]
    assert len(keys) == len(set(keys)) == 16
    assert keys[0] == "0|2|nearest|tomographic|5" and keys[-1] == "2|3|utility|none|5"
    no_merge = [e.config for e in plan.episodes() if e.key.endswith("|none|5")]
    assert all(not config.team.merge for config in no_merge)
    assert [e.config.policy for e in plan.episodes()][:4] == ["nearest"] * 2 + ["utility"] * 2


def test_every_episode_has_the_plan_s_team_with_its_own_method() -> None:
    team = TeamConfig(
        merge_interval=40, confirmations=1, comms=CommsConfig(5.0, line_of_sight=True)
    )
    plan = SweepPlan(methods=("oracle", "none"), team=team)
    oracle, alone = (e.config.team for e in plan.episodes())
    assert oracle == replace(team, method="oracle") and alone == replace(team, merge=False)
    assert plan.settings()["merge_interval"] == 40 and plan.settings()["comm_range"] == "5 los"
    assert SweepPlan().episodes()[0].config == EpisodeConfig(world="0")  # the episode's defaults


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("methods", ("nope",), "unknown merging method"),
        ("policies", ("greedy",), "unknown exploration policy"),
        ("seeds", (), "at least one"),
        ("robots", (2, 2), "twice"),
        ("worlds", "12", "must be a tuple"),  # not worlds "1" and "2"
        ("worlds", ("0", 0), "twice"),  # one key for two episodes
        ("robots", (0,), r"robots\[0\] must be a whole number >= 1"),
        ("seeds", (-1,), r"seeds\[0\] must be a whole number >= 0"),
        ("worlds", ("0", "-3"), r"worlds\[1\] must be a floor plan's seed .* got -3"),
        ("steps", 0, "steps must be a whole number >= 1"),
        ("coverage_target", 2.0, r"coverage_target must be a number in \(0, 1\]"),
        ("world_size", (-1.0, 5.0), r"world_size must be \(width, height\), two positive"),
        ("team", {"merge_interval": 40}, "team must be a TeamConfig"),
    ],
)
def test_plan_rejects_bad_values(field: str, value: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SweepPlan(**{field: value})


@pytest.mark.slow
def test_process_and_ray_give_the_same_rows(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason='Ray is optional: pip install "tomosim[ray]"')
    plan = four_episodes()
    local = run_sweep(plan, tmp_path / "process.csv", executor="process", workers=2)
    reported: set[str] = set()
    remote = run_sweep(
        plan,
        tmp_path / "ray.csv",
        executor="ray",
        workers=2,
        on_step=lambda key, step, coverage: reported.add(key),
    )
    assert local.ran == remote.ran == 4
    assert reported == {e.key for e in plan.episodes()}  # running episodes report on Ray too
    rows = without_timing(ResultsFile(local.results).rows())
    assert rows == without_timing(ResultsFile(remote.results).rows())
    assert {row["method"] for row in rows} == {"tomographic", "none"}


@pytest.mark.slow
def test_killed_sweep_resumes_without_repeating(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    command = [
        sys.executable, "-c", "from tomosim.cli import main; raise SystemExit(main())",
        "sweep", "--worlds", "1", "--robots", "2", "--methods", "tomographic", "none",
        "--seeds", "0", "1", "2", "--steps", str(SMALL["steps"]), "--merge-interval",
        str(MERGE_INTERVAL), "--world-size", "15", "10", "--workers", "1",
        "--out", str(out),
    ]  # fmt: skip
    process = subprocess.Popen(
        command, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    deadline = time.monotonic() + KILL_TIMEOUT_S
    try:
        while time.monotonic() < deadline and len(ResultsFile(out).rows()) < 2:
            assert process.poll() is None, "the sweep ended before it could be killed"
            time.sleep(0.2)
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the pool's workers too
        process.wait()
    before = ResultsFile(out).rows()
    assert 2 <= len(before) < 6
    plan = SweepPlan(
        worlds=("1",), robots=(2,), methods=("tomographic", "none"), seeds=(0, 1, 2), **SMALL
    )  # type: ignore[arg-type]
    outcome = run_sweep(plan, out, workers=1, resume=True)
    after = ResultsFile(out).rows()
    assert outcome.skipped == len(before) and outcome.ran == 6 - len(before)
    assert sorted(row["key"] for row in after) == sorted(e.key for e in plan.episodes())
    assert after[: len(before)] == before  # finished episodes kept, not run again


def test_existing_results_need_resume_and_the_same_settings(tmp_path: Path) -> None:
    # Rows of this sweep's settings: --resume goes on. Rows of another's: it could not,
    # so neither run says to pass it.
    ours, theirs = tmp_path / "ours.csv", tmp_path / "theirs.csv"
    settings = {name: str(value) for name, value in four_episodes().settings().items()}
    ResultsFile(ours).append({name: "" for name in ROW_FIELDS} | settings | {"key": "x"})
    with pytest.raises(ValueError, match="--resume"):
        run_sweep(four_episodes(), ours)
    other = {name: "" for name in ROW_FIELDS} | settings | {"key": "x", "steps_limit": 7}
    ResultsFile(theirs).append(other)
    for resume in (False, True):
        with pytest.raises(ValueError, match="steps_limit=7, not 120; choose another --out"):
            run_sweep(four_episodes(), theirs, resume=resume)


@pytest.mark.parametrize("earlier", EARLIER_ROW_FIELDS)
def test_a_file_of_an_earlier_version_is_resumed_in_its_own_columns(
    tmp_path: Path, earlier: tuple[str, ...]
) -> None:
    # Written before the all_linked_step column (or team_settings): its rows stay whole,
    # new rows leave the column out, so no row of the file claims its episode never
    # linked all the maps.
    out = tmp_path / "earlier.csv"
    plan = four_episodes()
    first = plan.episodes()[0]
    settings = {name: str(value) for name, value in plan.settings().items()}
    out.write_text(",".join(earlier) + "\n")
    ResultsFile(out).append({name: "" for name in ROW_FIELDS} | settings | {"key": first.key})
    with pytest.warns(UserWarning, match="cannot be checked against this sweep's"):
        outcome = run_sweep(plan, out, workers=1, resume=True)
    assert outcome.skipped == 1 and outcome.ran == 3
    rows = ResultsFile(out).rows()
    assert ResultsFile(out).columns() == earlier and len(rows) == 4
    missing = set(ROW_FIELDS) - set(earlier)
    assert missing and all(not missing & set(row) for row in rows)
    fresh = tmp_path / "fresh.csv"
    run_sweep(four_episodes(), fresh, workers=1)
    assert ResultsFile(fresh).columns() == ROW_FIELDS
    by_key = {row["key"]: row for row in ResultsFile(fresh).rows()}
    assert {by_key[k]["first_link_step"] for k in by_key if "|none|" in k} == {""}
    assert {by_key[k]["all_linked_step"] for k in by_key if "|none|" in k} == {""}


def test_a_resumed_file_holds_one_team_per_method(tmp_path: Path) -> None:
    # A setting of the oracle's is recorded in the oracle's rows only; a resume with
    # another team is refused rather than mixing two teams' rows in one file.
    out = tmp_path / "team.csv"
    small = dict(SMALL)
    team = with_settings(small.pop("team"), {"confirmations": "3", "oracle_min_shared_m2": "5"})
    plan = SweepPlan(worlds=("1",), robots=(2,), methods=("tomographic", "oracle"),
                     seeds=(0,), team=team, **small)  # type: ignore[arg-type]  # fmt: skip
    run_sweep(plan, out, workers=1)
    recorded = {row["method"]: row["team_settings"] for row in ResultsFile(out).rows()}
    assert recorded == {
        "tomographic": "confirmations=3",
        "oracle": "confirmations=3; oracle_min_shared_m2=5.0",
    }
    assert run_sweep(plan, out, workers=1, resume=True).ran == 0
    for other in (SMALL["team"], with_settings(team, {"oracle_min_shared_m2": "6"})):
        with pytest.raises(ValueError, match="run with team settings confirmations=3"):
            run_sweep(replace(plan, team=other), out, workers=1, resume=True)


def test_a_torn_last_line_is_dropped(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    results = ResultsFile(out)
    results.append({name: "1" for name in ROW_FIELDS} | {"key": "a"})
    with out.open("a") as handle:
        handle.write("b,1,1")  # a writer killed mid-row
    assert results.repair() == 1
    assert [row["key"] for row in results.rows()] == ["a"]


def test_foreign_csv_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "other.csv"
    out.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a tomosim sweep results file"):
        ResultsFile(out).rows()


@pytest.mark.parametrize(
    "content", [b"name,score\nalice,1\nbob,2", b"\x89PNG\r\n\x1a\n\x00\xb2\xff binary"]
)
@pytest.mark.parametrize("resume", [True, False])
def test_resuming_into_another_file_leaves_it_whole(
    tmp_path: Path, content: bytes, resume: bool
) -> None:
    # Its last line has no newline, as a torn row would: it must not be cut off
    # before the columns show that the file is not a sweep's. Without --resume the
    # message must not advise it: it could not help.
    out = tmp_path / "mine.csv"
    out.write_bytes(content)
    with pytest.raises(ValueError, match="not a tomosim sweep results file"):
        run_sweep(four_episodes(), out, resume=resume)
    assert out.read_bytes() == content


@pytest.mark.slow
def test_a_sweep_that_fails_to_start_leaves_no_empty_file(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    plan = SweepPlan(worlds=(str(tmp_path / "missing.yaml"),), robots=(2,), **SMALL)  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError):
        run_sweep(plan, out)
    assert not out.exists()


def sweep_command(out: Path, *, seeds: int, workers: int, steps: int) -> list[str]:
    """``tomosim sweep`` of ``seeds`` merging episodes on the small floor, in its own process."""
    return [
        sys.executable, "-m", "tomosim.cli", "sweep", "--worlds", "1", "--robots", "2",
        "--seeds", *map(str, range(seeds)), "--steps", str(steps), "--world-size", "15", "10",
        "--coverage-target", "1.0", "--workers", str(workers), "--out", str(out),
    ]  # fmt: skip


def start(command: list[str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        command, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def wait_for_workers(process: subprocess.Popen[str], count: int) -> list[int]:
    """The pids of ``count`` pool workers of ``process``, once they run."""
    psutil = pytest.importorskip("psutil")
    deadline = time.monotonic() + KILL_TIMEOUT_S
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        children = psutil.Process(process.pid).children(recursive=True)
        workers = [c for c in children if "resource_tracker" not in " ".join(c.cmdline())]
        if len(workers) >= count and all(c.create_time() < time.time() - 1 for c in workers):
            return [c.pid for c in workers]
        time.sleep(0.2)
    pytest.fail(f"the sweep did not start {count} workers in {KILL_TIMEOUT_S} s")


def gone(pids: list[int]) -> bool:
    """Whether every process of ``pids`` has ended (a zombie waiting to be reaped counts)."""
    psutil = pytest.importorskip("psutil")
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                return False
        except psutil.NoSuchProcess:
            continue
    return True


def wait_until_gone(pids: list[int]) -> bool:
    deadline = time.monotonic() + WORKERS_END_S
    while time.monotonic() < deadline and not gone(pids):
        time.sleep(0.1)
    return gone(pids)


WORKERS_END_S = 10.0
"""Longest time pool workers may outlive their parent."""


@pytest.mark.slow
def test_a_second_sweep_on_the_same_file_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "rows.csv"
    first = start(sweep_command(out, seeds=2, workers=1, steps=1500))
    try:
        wait_for_workers(first, 1)  # by then the first sweep holds the file
        status = main(sweep_command(out, seeds=2, workers=1, steps=1500)[3:])
        err = capsys.readouterr().err
        assert status == 1
        assert_one_line_error(err, "rows.csv is being written by another sweep", "--out")
    finally:
        os.killpg(first.pid, signal.SIGKILL)
        first.communicate()
    assert ResultsFile(out).rows() == []  # the refused sweep wrote nothing


@pytest.mark.slow
def test_workers_end_with_a_killed_parent(tmp_path: Path) -> None:
    process = start(sweep_command(tmp_path / "rows.csv", seeds=2, workers=2, steps=1500))
    try:
        workers = wait_for_workers(process, 2)
        os.kill(process.pid, signal.SIGKILL)  # the parent alone: its workers are orphaned
        process.communicate()
        assert wait_until_gone(workers), "pool workers outlived their killed parent"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)


@pytest.mark.slow
def test_sigterm_stops_the_sweep_and_says_how_to_resume(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    process = start(sweep_command(out, seeds=2, workers=2, steps=1500))
    try:
        workers = wait_for_workers(process, 2)
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=KILL_TIMEOUT_S)
        assert process.returncode == 128 + signal.SIGTERM
        (line,) = [line for line in err.splitlines() if line.startswith("tomosim:")]
        assert "terminated (SIGTERM)" in line and "--resume" in line and str(out) in line
        assert "Traceback" not in err
        assert wait_until_gone(workers)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)


@pytest.mark.slow
def test_running_episodes_report_their_steps(tmp_path: Path) -> None:
    plan = SweepPlan(worlds=("1",), robots=(2,), methods=("none",), seeds=(0,), **SMALL)  # type: ignore[arg-type]
    reports: list[tuple[str, int, float]] = []
    rows: list[dict] = []
    run_sweep(
        plan,
        tmp_path / "rows.csv",
        workers=1,
        on_step=lambda key, step, coverage: reports.append((key, step, coverage)),
        progress=rows.append,
    )
    assert rows and reports
    assert {key for key, _, _ in reports} == {rows[0]["key"]}
    assert all(0 < step <= int(rows[0]["steps"]) for _, step, _ in reports)
    assert all(0.0 < coverage <= 1.0 for _, _, coverage in reports)


@pytest.mark.parametrize(
    ("argv", "fragments", "status"),
    [
        (["--robots", "40"], ["--robots must be from 1 to 16, got 40"], 2),
        (["--out", "/no/such/folder/rows.csv"], ["/no/such/folder", "does not exist"], 1),
        (["--worlds", "foo.png"], ["--worlds must be a seed", "map's name", "'foo.png'"], 2),
        (["--worlds", "foo"], ["--worlds foo: no map named 'foo'", "tomosim maps"], 1),
        (["--seeds", "-1"], ["--seeds must be non-negative integers, got -1"], 2),
        (["--world-size", "0", "9"], ["--world-size must be two positive numbers"], 2),
        (["--world-size", "3", "3"], ["world_size 3 x 3 m: width 3.0 m is too small"], 2),
        (["--record-dir", __file__], ["--record-dir", "is a file; give a folder"], 2),
        (["--steps", "0"], ["--steps must be a whole number >= 1, got 0"], 2),
        (["--comm-range", "-2"], ["--comm-range must be a positive number"], 2),
        (["--line-of-sight"], ["--line-of-sight needs --comm-range"], 2),
        (["--policies", "foo"], ["unknown exploration policy 'foo'", "utility"], 2),
        (["--methods", "foo"], ["unknown merging method 'foo'", "none"], 2),
    ],
)
def test_sweep_errors_are_one_line(
    argv: list[str], fragments: list[str], status: int, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["sweep", "--out", "rows.csv"] if "--out" not in argv else ["sweep"]
    assert main([*base, *argv]) == status
    assert_one_line_error(capsys.readouterr().err, *fragments)


def test_sweep_help_gives_every_option_a_default(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sweep", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for option in ("--robots", "--seeds", "--steps", "--merge-interval", "--coverage-target"):
        after = text.split(f"{option} ")[-1]
        assert "default" in after.split(" --")[0], option
    assert all(method in text for method in available_methods())


def test_an_unwritable_results_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dangling = tmp_path / "rows.csv"
    dangling.symlink_to(tmp_path / "gone" / "rows.csv")
    assert main(["sweep", "--out", str(dangling), "--steps", "5"]) == 1
    err = capsys.readouterr().err
    assert_one_line_error(err, "cannot write", "rows.csv", "--out")
    assert "Errno" not in err


def test_a_map_has_one_name_however_it_is_typed(tmp_path: Path, monkeypatch) -> None:
    # Keys were the path as typed: a resume with ./odd/a.yaml ran odd/a.yaml again
    # and stored it twice, and a.yaml typed in another folder was skipped as done.
    (tmp_path / "odd").mkdir()
    monkeypatch.chdir(tmp_path)
    typed = ("odd/a.yaml", "./odd/a.yaml", str(tmp_path / "odd" / "a.yaml"))
    names = {SweepPlan(worlds=(world,)).worlds for world in typed}
    assert names == {(str(tmp_path / "odd" / "a.yaml"),)}
    monkeypatch.chdir(tmp_path / "odd")
    assert SweepPlan(worlds=("a.yaml",)).worlds == next(iter(names))
    monkeypatch.chdir(tmp_path)
    assert SweepPlan(worlds=("other/a.yaml",)).worlds != next(iter(names))
    with pytest.raises(ValueError, match="worlds lists a value twice"):
        SweepPlan(worlds=("odd/a.yaml", "./odd/a.yaml"))
    with pytest.raises(ValueError, match="worlds lists a value twice"):
        SweepPlan(worlds=("7", "007"))


def test_an_episode_whose_process_died_is_named_not_awaited() -> None:
    # A pool replaces a killed process but never hands back its episode: the sweep
    # waited for it for ever.
    import queue

    from tomosim.sweep.executors import STARTED, WorkerDied, _check_alive, _drain

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    reports: queue.Queue = queue.Queue()
    reports.put(("a|1", STARTED, os.getpid()))
    reports.put(("b|1", STARTED, gone.pid))
    reports.put(("a|1", 40, 0.5))
    steps: list[tuple[str, int, float]] = []
    running: dict[str, int] = {}
    _drain(reports, lambda key, step, coverage: steps.append((key, step, coverage)), running)
    assert steps == [("a|1", 40, 0.5)]
    assert running == {"a|1": os.getpid(), "b|1": gone.pid}
    with pytest.raises(WorkerDied, match=rf"episode b\|1 \(pid {gone.pid}\) died.*--resume"):
        _check_alive(running)
    del running["b|1"]
    _check_alive(running)  # this process is alive


def test_a_record_folder_that_cannot_be_written_is_named_up_front(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    # It ended in a raw "[Errno 13] Permission denied" (root ignores permissions, so
    # the folder is made unwritable for the check itself).
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(
        os, "access", lambda path, mode: Path(path) != locked and real_access(path, mode)
    )
    argv = ["sweep", "--steps", "5", "--out", str(tmp_path / "s.csv")]
    assert main([*argv, "--record-dir", str(locked / "recs")]) == 1
    err = capsys.readouterr().err
    assert f"folder {locked} is not writable" in err and "--record-dir" in err
    assert main([*argv, "--record-dir", str(locked)]) == 1
    assert not (tmp_path / "s.csv").exists()


def test_a_resume_finds_rows_keyed_by_a_path_as_typed_before(tmp_path: Path, monkeypatch) -> None:
    # Rows written before maps were named by absolute path hold the path as typed:
    # resumed from the same folder, they count as done (not run again and stored twice).
    from tomosim.sweep.executors import _named_as_now
    from tomosim.sweep.plan import recording_name

    monkeypatch.chdir(tmp_path)
    assert _named_as_now("odd/a.yaml|2|utility|none|0") == (
        f"{tmp_path / 'odd' / 'a.yaml'}|2|utility|none|0"
    )
    assert _named_as_now("07|2|utility|none|0") == "7|2|utility|none|0"
    # Recordings are named by the map's stem and a hash of its path: short, and apart.
    deep = "/".join(["folder"] * 60) + "/a.yaml"
    name = recording_name(f"{deep}|2|utility|none|0")
    assert name.startswith("a-") and len(name) < 60
    assert name != recording_name("/elsewhere/a.yaml|2|utility|none|0")
