"""``scripts/bench_env.py --against``: each checkout's own code is timed, the ratios printed."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

from tests.support import REPO_ROOT, load_script


@pytest.fixture
def bench(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """The script's module (its sibling ``bench_env_runner`` importable, as when run)."""
    monkeypatch.syspath_prepend(str(REPO_ROOT / "scripts"))
    return load_script("bench_env")


def test_a_folder_that_is_no_checkout_is_refused_by_name(bench: ModuleType, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=str(tmp_path)):
        bench.Checkout(tmp_path)


def test_a_checkout_whose_environment_is_imported_from_elsewhere_is_refused(
    bench: ModuleType, tmp_path: Path
) -> None:
    # The folder's envs/ is this checkout's, linked: the code imported lies elsewhere.
    (tmp_path / "envs").symlink_to(REPO_ROOT / "envs", target_is_directory=True)
    with pytest.raises(ValueError, match="imported the environment from"):
        bench.Checkout(tmp_path)


@pytest.mark.slow
def test_against_times_both_checkouts_in_turn_and_prints_ratios() -> None:
    command = [sys.executable, "scripts/bench_env.py", "--against", str(REPO_ROOT)]
    command += ["--robots", "1", "--steps", "3", "--repeats", "2"]
    done = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True, check=True)
    lines = done.stdout.splitlines()
    rows = [line for line in lines if line.startswith((f"this {REPO_ROOT}", str(REPO_ROOT)))]
    assert len(rows) == 3  # this checkout, the other, and the ratio line
    ratio = rows[-1].split()
    medians, pair_median, low, high = (float(v) for v in ratio[-4:])
    assert medians > 0 and low <= pair_median <= high
