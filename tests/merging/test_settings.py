"""The merger's settings by dotted name: every leaf named, nested copies, errors that name."""

from __future__ import annotations

import dataclasses

import pytest

from merging.params import DEFAULT_PARAMS, TomographicParams
from merging.settings import (
    changed_settings,
    parse_assignments,
    setting_names,
    setting_value,
    unknown_setting,
    with_settings,
)


def test_every_single_valued_setting_has_a_name_and_a_type() -> None:
    names = setting_names(DEFAULT_PARAMS)
    assert names["confidence.accept"] is float and names["robust.tolerance"] is int
    assert names["translation.peaks"] is int and names["from_start.local"] is bool
    assert names["distinct_cells"] is float  # a setting of the top level
    # Settings holding several values (the schedule, field widths) have no name.
    assert "stages" not in names and not any(name.startswith("stages") for name in names)
    assert "compromise.sigmas" not in names
    assert not any(name in ("confidence", "robust", "verify") for name in names)
    for name in names:
        assert setting_value(DEFAULT_PARAMS, name) is not None


def test_settings_change_nested_copies_and_are_listed() -> None:
    params = with_settings(DEFAULT_PARAMS, {"robust.margin": "0.2", "from_start.local": "off"})
    assert params.robust.margin == 0.2 and params.from_start.local is False
    assert DEFAULT_PARAMS.robust.margin == 0.3  # the original is untouched
    assert params.confidence is DEFAULT_PARAMS.confidence  # untouched parts are shared
    assert changed_settings(params, DEFAULT_PARAMS) == {
        "robust.margin": 0.2,
        "from_start.local": False,
    }
    assert with_settings(params, {"robust.margin": 0.3, "from_start.local": True}) == DEFAULT_PARAMS
    assert changed_settings(DEFAULT_PARAMS, TomographicParams()) == {}


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"confidence.acept": "0.5"}, "no merger setting named 'confidence.acept'.*accept"),
        ({"translation.peaks": "three"}, "translation.peaks takes int values"),
        ({"from_start.local": "maybe"}, "from_start.local is a switch"),
        ({"confidence.accept": "2"}, "accept"),  # the settings object's own check
        # Each of these once passed its check and failed deep in the search, with
        # words that named no setting, or asked for terabytes.
        ({"translation.wall_blur": "0"}, r"wall_blur must be a number of blocks in \(0, 160\]"),
        ({"translation.wall_blur": "1e9"}, r"wall_blur must be a number of blocks in \(0, 160\]"),
        ({"rotation.angle_step_deg": "1e-9"}, r"angle_step_deg must be a number in \[0.01, 90\]"),
        ({"gauss_newton.curvature_points": "1"}, "curvature_points must be a whole number >= 3"),
        ({"gauss_newton.damping": "-1"}, "damping must be a non-negative number"),
        ({"gauss_newton.backtracks": "1000000"}, r"backtracks must be a whole number in \[0, 52\]"),
        ({"distinct_cells": "-1"}, "distinct_cells must be a positive number"),
    ],
)
def test_bad_settings_are_named(settings: dict[str, str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        with_settings(DEFAULT_PARAMS, settings, what="merger setting")


TEAM_LIKE = {
    "confirmations": int,
    "confirm_rotation_deg": float,
    "merge": bool,
    "tracker.keep_confidence": float,
    "merger.confidence.accept": float,
    "merger.confidence.mirror_margin": float,
    "merger.robust.margin": float,
    "simulation.lidar.beams": int,
}


@pytest.mark.parametrize(
    ("name", "message"),
    [
        # a typo within a group, and a name's last part alone
        ("merger.confidence.acept", "did you mean merger.confidence.accept?"),
        ("beams", "did you mean simulation.lidar.beams?"),
        ("lidar.beams", "did you mean simulation.lidar.beams?"),
        # the start of a name
        ("confirm", "did you mean confirmations or confirm_rotation_deg?"),
        # a trailing dot; a name in the wrong group is looked for in all
        ("beams.", "did you mean simulation.lidar.beams?"),
        ("merger.beams", "did you mean simulation.lidar.beams?"),
        # nothing near: the group's settings, or the groups with their sizes
        (
            "merger.confidence.nothing",
            "the merger.confidence.* settings are: merger.confidence.accept, "
            "merger.confidence.mirror_margin",
        ),
        ("tracker", "the tracker.* settings are: tracker.keep_confidence"),
        # a group by its last part
        ("lidar", "the simulation.lidar.* settings are: simulation.lidar.beams"),
        ("robust", "the merger.robust.* settings are: merger.robust.margin"),
        (
            "zzz",
            "the settings are: confirm_rotation_deg, confirmations, merge, merger.* (3), "
            "simulation.* (1), tracker.* (1)",
        ),
    ],
)
def test_an_unknown_setting_suggests_the_names_meant(name: str, message: str) -> None:
    assert unknown_setting(name, TEAM_LIKE, what="team setting") == (
        f"no team setting named {name!r}; {message}"
    )


def test_assignments_are_name_value_pairs() -> None:
    assert parse_assignments([" robust.margin=0.2", "a.b=c=d"], option="--x", example="a=1") == {
        "robust.margin": "0.2",
        "a.b": "c=d",
    }
    for bad in ("robust.margin", "=0.2", "robust.margin= "):
        with pytest.raises(ValueError, match=r"--x takes NAME=VALUE \(e.g. a=1\)"):
            parse_assignments([bad], option="--x", example="a=1")


def test_only_a_dataclass_holds_settings() -> None:
    with pytest.raises(TypeError, match="dataclass instance"):
        setting_names(TomographicParams)
    with pytest.raises(TypeError, match="dict"):
        setting_names({"accept": 0.6})
    assert dataclasses.is_dataclass(DEFAULT_PARAMS)
