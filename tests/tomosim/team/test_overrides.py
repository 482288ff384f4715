"""Team settings by dotted name: every leaf reachable, values by type, changes recorded."""

from __future__ import annotations

import pytest

from tests.tomosim.commands.cli_support import assert_one_line_error, run
from tomosim.episode import EpisodeConfig
from tomosim.team import TeamConfig
from tomosim.team.overrides import changed_settings, setting_names, with_settings


def test_every_leaf_of_the_team_has_a_name() -> None:
    names = setting_names()
    assert names["confirmations"] is int and names["tracking"] is bool
    assert names["tracker.keep_confidence"] is float
    assert names["comms.range"] is float  # an optional number
    assert names["simulation.lidar.beams"] is int
    assert not any(name.endswith(("tracker", "simulation", "lidar")) for name in names)


def test_settings_change_nested_copies_and_are_listed() -> None:
    base = TeamConfig()
    team = with_settings(base, {"simulation.lidar.beams": "180", "merge_worker": "off"})
    assert team.simulation.lidar.beams == 180 and team.merge_worker is False
    assert base.simulation.lidar.beams == 360  # the original is untouched
    assert changed_settings(team) == {"merge_worker": False, "simulation.lidar.beams": 180}
    assert with_settings(base, {"comms.range": "none"}).comms.range is None
    assert changed_settings(base) == {}


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"confirm": "3"}, "no team setting named 'confirm'"),
        ({"confirmations": "three"}, "confirmations takes int values"),
        ({"tracking": "maybe"}, "tracking is a switch"),
        ({"tracker.keep_confidence": "1.5"}, "keep_confidence"),
    ],
)
def test_bad_settings_are_named(settings: dict[str, str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        with_settings(TeamConfig(), settings)


def test_an_episode_records_the_team_settings_it_changed() -> None:
    world = type("World", (), {"name": "w"})()
    default = EpisodeConfig().settings(world)  # type: ignore[arg-type]  # only .name is read
    assert "team" not in default
    changed = EpisodeConfig(team=TeamConfig(confirmations=1)).settings(world)  # type: ignore[arg-type]
    assert changed["team"] == {"confirmations": 1}


def test_the_command_line_sets_team_settings_by_name(capsys) -> None:
    status, _, err = run(["explore", "--team", "merge_interval=3", "--no-record"], capsys)
    assert status == 2
    assert_one_line_error(err, "--team merge_interval: use --merge-interval instead")
    status, _, err = run(["explore", "--team", "confirmations", "--no-record"], capsys)
    assert status == 2
    assert_one_line_error(err, "--team takes NAME=VALUE")
    status, _, err = run(["sweep", "--team", "confirmations=0", "--out", "x.csv"], capsys)
    assert status == 2
    assert_one_line_error(err, "--team: confirmations must be a whole number")
    status, _, err = run(
        ["explore", "--method", "spectral", "--team", "merger.robust.margin=0.2", "--no-record"],
        capsys,
    )
    assert status == 2
    assert_one_line_error(
        err, "--team merger.*: only the 'tomographic' method uses it", "--method spectral"
    )
    status, _, err = run(
        ["explore", "--team", "oracle_min_shared_m2=10", "--no-record"],
        capsys,
    )
    assert status == 2
    assert_one_line_error(err, "--team oracle_min_shared_m2: only the 'oracle' method uses it")
    status, _, err = run(
        ["sweep", "--methods", "tomographic", "none", "--team", "oracle_error_m=0.1", "--out", "x"],
        capsys,
    )
    assert status == 2
    assert_one_line_error(
        err, "--team oracle_error_m", "--methods tomographic none does not", "add oracle to"
    )
    status, _, err = run(
        ["sweep", "--methods", "oracel", "--team", "oracle_error_m=0.1", "--out", "x"], capsys
    )
    assert status == 2
    assert_one_line_error(err, "unknown merging method 'oracel'")
    status, _, err = run(
        ["explore", "--no-merge", "--team", "merger.robust.margin=0.2", "--no-record"], capsys
    )
    assert status == 2
    assert_one_line_error(err, "--team merger.*", "--no-merge does not run it")
