"""The scripts' shared argument types and entry point: bad input named at once, in one line."""

from __future__ import annotations

import argparse
import subprocess
import sys

import pytest

from tests.support import REPO_ROOT
from tomosim.commands.script_args import (
    TRACEBACK_VARIABLE,
    non_negative_int,
    positive_float,
    positive_int,
    run_script,
)

SCRIPTS = REPO_ROOT / "scripts"
"""The checkout's scripts folder."""


@pytest.mark.parametrize(
    ("kind", "text", "message"),
    [
        (positive_int, "0", "whole number >= 1, got 0"),
        (positive_int, "-2", "whole number >= 1, got -2"),
        (positive_int, "2.5", "whole number, got '2.5'"),
        (non_negative_int, "-1", "whole number >= 0, got -1"),
        (positive_float, "nan", "positive number, got nan"),
        (positive_float, "-5", "positive number, got -5"),
        (positive_float, "far", "a number, got 'far'"),
    ],
)
def test_argument_types_name_the_bad_value(kind, text: str, message: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match=message):
        kind(text)


def test_argument_types_take_good_values() -> None:
    assert positive_int("3") == 3 and non_negative_int("0") == 0 and positive_float("2.5") == 2.5


def test_a_script_s_error_is_one_line_and_status_1(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(TRACEBACK_VARIABLE, raising=False)

    def main() -> int:
        raise FileNotFoundError("map file not found:\n  nosuch.yaml")

    with pytest.raises(SystemExit) as stopped:
        run_script(main, "/somewhere/bench.py")
    assert stopped.value.code == 1
    assert capsys.readouterr().err == "bench.py: error: map file not found: nosuch.yaml\n"
    monkeypatch.setenv(TRACEBACK_VARIABLE, "1")
    with pytest.raises(FileNotFoundError):
        run_script(main, "/somewhere/bench.py")


@pytest.mark.slow
def test_a_negative_pair_count_is_refused_before_any_work() -> None:
    # It used to run the window search for minutes, keeping every pair it found.
    run = subprocess.run(
        [sys.executable, str(SCRIPTS / "bench_merge.py"), "--pairs-per-map", "-2", "--sizes"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2
    assert "--pairs-per-map: must be a whole number >= 1, got -2" in run.stderr
    assert "Traceback" not in run.stderr
