"""``scripts/merger_answers.py``: the record of the merger's answers, and its comparison."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from merging.catalog import MAPS_ENV
from tests.support import REPO_ROOT

SCRIPT = REPO_ROOT / "scripts" / "merger_answers.py"


def run(maps_folder: Path, *args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, str(SCRIPT), "--suites", "paper", "sessions", "--limit", "2", *args]
    environment = {**os.environ, MAPS_ENV: str(maps_folder)}
    return subprocess.run(command, capture_output=True, text=True, env=environment, check=False)


@pytest.mark.slow
def test_answers_compare_identical_and_a_moved_one_is_named(maps_folder, tmp_path) -> None:
    record = tmp_path / "answers.jsonl"
    written = run(maps_folder, "--out", str(record))
    assert written.returncode == 0, written.stderr
    lines = [json.loads(line) for line in record.read_text().splitlines()]
    names = [(e["suite"], e["pair"]) for e in lines]
    assert names[:2] == [("paper", "aces3#0"), ("paper", "aces3#1")]
    assert len(names) == 4 and names[2][0] == "sessions"
    same = run(maps_folder, "--compare", str(record))
    assert same.returncode == 0, same.stdout + same.stderr
    assert "4 identical, 0 different" in same.stdout
    # A setting changed by name: every pair it refuses now is counted.
    held = sum(e["accepted"] and float.fromhex(e["confidence"]) < 1.0 for e in lines)
    assert held > 0
    stricter = run(maps_folder, "--compare", str(record), "--merger", "confidence.accept=1.0")
    assert stricter.returncode == 1
    assert f"(0 now accepted, {held} now refused)" in stricter.stdout
    # One transform moved by a hair and its verdict flipped: named, and the status is 1.
    moved = lines[0]
    moved["matrix"][2] = float.hex(float.fromhex(moved["matrix"][2]) + 1e-9)
    moved["accepted"] = not moved["accepted"]
    record.write_text("".join(json.dumps(e) + "\n" for e in lines))
    changed = run(maps_folder, "--compare", str(record))
    assert changed.returncode == 1
    assert "paper aces3#0: matrix entries moved by up to 1e-09, accepted" in changed.stdout
    assert "3 identical, 1 different" in changed.stdout


@pytest.mark.slow
def test_a_missing_record_is_a_clear_error(maps_folder, tmp_path) -> None:
    missing = run(maps_folder, "--compare", str(tmp_path / "none.jsonl"))
    assert missing.returncode == 2
    assert "no such file; write one with --out first" in missing.stderr


def test_a_file_of_another_kind_is_refused_not_a_traceback(maps_folder, tmp_path) -> None:
    foreign = tmp_path / "other.jsonl"
    foreign.write_text('{"pair": "aces3#0"}\n')  # JSON lines, but no suite: a KeyError once
    refused = run(maps_folder, "--compare", str(foreign))
    assert refused.returncode == 2
    assert "line 1: not a record this script wrote with --out" in refused.stderr
