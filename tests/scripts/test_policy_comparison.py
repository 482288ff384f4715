"""``scripts/policy_comparison``: what both training scripts share about their output folder."""

from __future__ import annotations

import argparse
from pathlib import Path
from types import ModuleType

import pytest

from tests.support import REPO_ROOT


@pytest.fixture
def report(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """``policy_comparison.report``, importable as the scripts import it."""
    monkeypatch.syspath_prepend(str(REPO_ROOT / "scripts"))
    import policy_comparison.report

    return policy_comparison.report


def test_a_folder_holding_a_run_is_refused_with_its_files(
    report: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = argparse.ArgumentParser(prog="train")
    report.refuse_used_folder(parser, tmp_path, ("summary.json", "model.zip"))  # empty: fine
    (tmp_path / "model.zip").touch()
    with pytest.raises(SystemExit) as stopped:
        report.refuse_used_folder(parser, tmp_path, ("summary.json", "model.zip"))
    assert stopped.value.code == 2
    assert f"--out {tmp_path} already holds a run (model.zip)" in capsys.readouterr().err
