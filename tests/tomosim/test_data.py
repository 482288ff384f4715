"""Locating the shared data folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from tomosim import data


def test_environment_variables_override(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "maps").mkdir()
    (tmp_path / "datasets").mkdir()
    monkeypatch.setenv(data.SHARED_ENV, str(tmp_path))
    monkeypatch.delenv(data.MAPS_ENV, raising=False)
    assert data.shared_dir() == tmp_path
    assert data.maps_dir() == tmp_path / "maps"
    assert data.datasets_dir() == tmp_path / "datasets"
    other = tmp_path / "elsewhere"
    other.mkdir()
    monkeypatch.setenv(data.MAPS_ENV, str(other))
    assert data.maps_dir() == other


def test_missing_folders_give_none(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(data.SHARED_ENV, str(tmp_path / "absent"))
    monkeypatch.delenv(data.MAPS_ENV, raising=False)
    assert data.shared_dir() is None
    assert data.maps_dir() is None
    assert data.datasets_dir() is None


def test_default_finds_a_shared_folder_beside_the_checkout(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(data.SHARED_ENV, raising=False)
    monkeypatch.delenv(data.MAPS_ENV, raising=False)
    beside = Path(data.__file__).resolve().parents[2] / "shared"
    if not (beside / "maps").is_dir():
        pytest.skip(f"no shared folder at {beside}")
    assert data.shared_dir() == beside
    assert data.maps_dir() == beside / "maps"
