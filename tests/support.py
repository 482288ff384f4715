"""What every test folder shares: where the repository and the real maps are, the scripts."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType

REPO_ROOT = Path(__file__).resolve().parents[1]
MAPS_ENV = "TOMOSIM_MAPS"
"""Environment variable naming the folder of real maps; default ``<repo root>/../shared/maps``."""


def load_script(name: str) -> ModuleType:
    """The module of ``scripts/<name>.py`` (the scripts are not a package)."""
    path = REPO_ROOT / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve their module by name
    spec.loader.exec_module(module)
    return module


def real_maps_dir() -> Path | None:
    """The folder of real maps, or None when it is absent."""
    configured = os.environ.get(MAPS_ENV)
    folder = Path(configured) if configured else REPO_ROOT.parent / "shared" / "maps"
    return folder if folder.is_dir() else None
