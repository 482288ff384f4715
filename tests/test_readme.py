"""The README's front door: its example output is what the command prints, its
snippets run, and it stays short.

The README states no figure that the code or a benchmark page also holds unless a
test here checks the two agree: the ``tomosim explore`` block is compared with a
real run line for line, the wall clock aside.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
"""The repository's front door."""
MAX_LINES = 250
"""The README's length limit: the documentation site holds the rest."""
OUTPUT_START, OUTPUT_END = "<!-- explore-output-start -->", "<!-- explore-output-end -->"
"""Markers around the README's example output (the documentation includes it too)."""
WALL_CLOCK = re.compile(r"\d+(\.\d+)? s wall clock")
"""The one figure of the summary that varies from run to run."""
EXPLORE_TIMEOUT_S = 600
"""Seconds a default run may take on a loaded machine before the test gives up."""


def readme() -> str:
    return README.read_text(encoding="utf-8")


def explore_block() -> list[str]:
    """The README's ``tomosim explore`` example: the command line, then what it prints."""
    text = readme()
    if OUTPUT_START not in text or OUTPUT_END not in text:
        pytest.fail(f"README.md has lost the markers {OUTPUT_START} ... {OUTPUT_END}")
    block = text.split(OUTPUT_START, 1)[1].split(OUTPUT_END, 1)[0].strip()
    lines = block.splitlines()
    assert lines[0] == "```" and lines[-1] == "```", "the example must be one code block"
    return lines[1:-1]


def python_snippets() -> list[str]:
    """The README's Python code blocks."""
    return re.findall(r"^```python\n(.*?)^```", readme(), flags=re.S | re.M)


def test_readme_is_short():
    lines = readme().splitlines()
    assert len(lines) <= MAX_LINES, f"README.md has {len(lines)} lines, at most {MAX_LINES}"


def test_readme_example_is_the_default_command():
    assert explore_block()[0] == "$ tomosim explore"


@pytest.mark.slow
def test_readme_explore_output_matches_a_real_run(tmp_path):
    """Run the README's example in an empty folder; compare every line but the wall clock."""
    command, *expected = explore_block()
    arguments = command.removeprefix("$ tomosim ").split()
    run = subprocess.run(
        [sys.executable, "-m", "tomosim.cli", *arguments],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=EXPLORE_TIMEOUT_S,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    printed = run.stdout.rstrip("\n").splitlines()
    assert (tmp_path / "explore.rrd").is_file()
    assert [WALL_CLOCK.sub("- s wall clock", line) for line in printed] == [
        WALL_CLOCK.sub("- s wall clock", line) for line in expected
    ]


@pytest.mark.parametrize("index", range(len(python_snippets())))
def test_readme_python_snippet_runs(index, tmp_path, monkeypatch):
    snippet = python_snippets()[index]
    monkeypatch.chdir(tmp_path)
    exec(compile(snippet, f"README.md python snippet {index + 1}", "exec"), {})


def test_readme_has_python_snippets():
    assert len(python_snippets()) >= 2, "the README shows merging and the environment"


def test_the_torch_build_the_readme_installs_is_the_extras_pin() -> None:
    pyproject = (README.parent / "pyproject.toml").read_text(encoding="utf-8")
    pins = set(re.findall(r'"torch==([\d.]+)"', pyproject))
    shown = set(re.findall(r"torch==([\d.]+)", readme()))
    assert len(pins) == 1 and shown == pins, f"README installs torch {shown}, the extras pin {pins}"
