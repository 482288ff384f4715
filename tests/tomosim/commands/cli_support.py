"""Helpers shared by the command-line tests: run ``tomosim`` in-process, check its errors."""

from __future__ import annotations

import pytest

from tomosim.cli import main


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run ``tomosim argv``; return its exit status, standard output and standard error."""
    status = main(argv)
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def assert_one_line_error(err: str, *fragments: str) -> None:
    """``err`` is one ``tomosim: error:`` line, no traceback, holding every fragment."""
    assert err.count("\n") == 1 and err.endswith("\n"), f"not one line: {err!r}"
    assert err.startswith("tomosim: error: ")
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in err, err
