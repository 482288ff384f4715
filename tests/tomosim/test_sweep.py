"""Sweeps: the same rows on every executor, and nothing lost or repeated when killed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tomosim.sweep import ROW_FIELDS, ResultsFile, SweepPlan, run_sweep
from tomosim.sweep.rows import TIMING_FIELDS

SMALL = {"world_size": (15.0, 10.0), "steps": 120, "merge_interval": 40}
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
    assert all(not config.merge for config in no_merge)
    assert [e.config.policy for e in plan.episodes()][:4] == ["nearest"] * 2 + ["utility"] * 2


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("methods", ("nope",), "unknown merging method"),
        ("policies", ("greedy",), "unknown exploration policy"),
        ("seeds", (), "at least one"),
        ("robots", (2, 2), "twice"),
    ],
)
def test_plan_rejects_bad_values(field: str, value: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SweepPlan(**{field: value})


def test_process_and_ray_give_the_same_rows(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason='Ray is optional: pip install "tomosim[ray]"')
    plan = four_episodes()
    local = run_sweep(plan, tmp_path / "process.csv", executor="process", workers=2)
    remote = run_sweep(plan, tmp_path / "ray.csv", executor="ray", workers=2)
    assert local.ran == remote.ran == 4
    rows = without_timing(ResultsFile(local.results).rows())
    assert rows == without_timing(ResultsFile(remote.results).rows())
    assert {row["method"] for row in rows} == {"tomographic", "none"}


def test_killed_sweep_resumes_without_repeating(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    command = [
        sys.executable, "-c", "from tomosim.cli import main; raise SystemExit(main())",
        "sweep", "--worlds", "1", "--robots", "2", "--methods", "tomographic", "none",
        "--seeds", "0", "1", "2", "--steps", str(SMALL["steps"]), "--merge-interval",
        str(SMALL["merge_interval"]), "--world-size", "15", "10", "--workers", "1",
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
    out = tmp_path / "rows.csv"
    ResultsFile(out).append({name: "" for name in ROW_FIELDS} | {"key": "x", "steps_limit": 7})
    with pytest.raises(ValueError, match="--resume"):
        run_sweep(four_episodes(), out)
    with pytest.raises(ValueError, match="steps_limit=7"):
        run_sweep(four_episodes(), out, resume=True)


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
