"""What every test folder shares: where the repository and the real maps are, the scripts."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from types import ModuleType

from merging.catalog import describe_folders
from tomosim.data import maps_dir

REPO_ROOT = Path(__file__).resolve().parents[1]


def load_script(name: str) -> ModuleType:
    """The module of ``scripts/<name>.py`` (the scripts are not a package)."""
    path = REPO_ROOT / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve their module by name
    spec.loader.exec_module(module)
    return module


def run_python(script: str) -> str:
    """Standard output of ``script`` run by a fresh interpreter, which must succeed: for
    what a test cannot see in its own process (the modules an import loads, a crash)."""
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout


def real_maps_dir() -> Path | None:
    """The folder of real maps (the first of the maps path that exists), or None."""
    return maps_dir()


def maps_absent_reason() -> str:
    """Why tests of real maps are skipped: the folders looked in."""
    return f"real maps not found in {describe_folders()}"
