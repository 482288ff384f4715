"""``scripts/study_exploration.py``'s report: the tomographic merger against the oracle."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from tests.support import REPO_ROOT


@pytest.fixture
def study(monkeypatch: pytest.MonkeyPatch):  # the study's package lives among the scripts
    monkeypatch.syspath_prepend(str(REPO_ROOT / "scripts"))
    from exploration_study import report, summary, worlds

    return report, summary, worlds


def rows(method: str, times: list[float], links: list[int | None]) -> list[dict[str, str]]:
    """Results rows of 4-robot episodes of one method, seeds 0, 1, ..."""
    zero = {
        "path_length_m": "1",
        "overlap_rate": "0",
        "pairs_wrong": "0",
        "pairs_gross_wrong": "0",
        "pairs_gross_wrong_confirmed": "0",
        "pairs_accepted": "0",
    }
    return [
        {
            **zero,
            "robots": "4",
            "policy": "utility",
            "method": method,
            "seed": str(seed),
            "time_to_target_s": "" if math.isinf(t) else str(t),
            "first_link_step": "" if link is None else str(link),
        }
        for seed, (t, link) in enumerate(zip(times, links, strict=True))
    ]


THREE_METHODS = (
    rows("none", [100.0, 80.0, 120.0], [None] * 3)
    + rows("tomographic", [60.0, 50.0, 70.0], [150, 200, None])
    + rows("oracle", [50.0, 50.0, 60.0], [100, 100, 100])
)
"""Three seeds of each method: medians none 100 s, tomographic 60 s, oracle 50 s; the
tomographic team links at steps 150 and 200 and once never, the oracle at 100."""


def test_the_oracle_figures_pair_episodes_and_show_first_links(study) -> None:
    report, summary, worlds = study
    floor = worlds.resolve("0", 400)
    table = summary.cells(THREE_METHODS)
    none, tomo, oracle = (table[(4, "utility", m)] for m in ("none", "tomographic", "oracle"))
    episodes = report.paired_episodes(none, tomo, oracle)
    assert episodes == [(100.0, 60.0, 50.0), (80.0, 50.0, 50.0), (120.0, 70.0, 60.0)]
    # Medians: none 100, tomographic 60, oracle 50.
    assert report.oracle_ratio_of(episodes) == pytest.approx(1.2)
    assert report.oracle_share_of(episodes) == pytest.approx(0.8)
    low, high = report.interval(episodes, report.oracle_ratio_of)
    assert low <= 1.2 <= high
    assert report.interval(episodes, report.oracle_ratio_of) == (low, high)  # seeded
    text = report.criterion_table([floor], {floor.label: table}, "utility", 4)
    assert "| floor0 | 3 | 1.20 (" in text
    # Files without the all-linked column: unknown, not never.
    assert "| 175 (150-200), 1 never | 100 (100-100) | - | - | 0 |" in text
    linked = [{**row, "all_linked_step": row["first_link_step"]} for row in THREE_METHODS]
    table = summary.cells(linked)
    text = report.criterion_table([floor], {floor.label: table}, "utility", 4)
    links = "| 175 (150-200), 1 never | 100 (100-100) "
    assert f"{links}{links}| 0 |" in text
    each = report.first_links_table([floor], {floor.label: table}, "utility", 4)
    assert "| floor0 | 2 | - | 100 | - | 100 | 120 | 70 | 60 | 1.17 |" in each.splitlines()
    unknown = summary.cells(THREE_METHODS)
    each = report.first_links_table([floor], {floor.label: unknown}, "utility", 4)
    assert "| floor0 | 0 | 150 | 100 | - | - | 100 | 60 | 50 | 1.20 |" in each.splitlines()


def test_the_checks_hold_the_merger_to_the_projects_exploration_target(study) -> None:
    report, summary, worlds = study
    floor = worlds.resolve("0", 400)
    table = summary.cells(THREE_METHODS)
    found = {c.name: c for c in report.checks([floor], {floor.label: table}, "utility", [4])}
    ratio = next(c for name, c in found.items() if "tomographic / oracle <= 1.05" in name)
    share = next(c for name, c in found.items() if "share of the oracle's saving" in name)
    assert not ratio.passed and "= 1.20" in ratio.figure
    assert not share.passed and "= 0.80" in share.figure


def test_the_report_only_run_writes_the_oracle_section(study, tmp_path: Path) -> None:
    from tests.support import load_script

    script = load_script("study_exploration")
    assert (
        script.main(
            [
                "--worlds",
                "0",
                "--robots",
                "4",
                "--report-only",
                "--out",
                str(tmp_path),
                "--comm-ranges",
            ]
        )
        == 0
    )
    written = (tmp_path / "study_exploration.md").read_text()
    assert "## Against the oracle (generated floors, 4 robots)" in written


def test_team_settings_reach_the_episodes_and_a_folder_keeps_one_team(
    study, tmp_path: Path
) -> None:
    from tests.support import load_script
    from tomosim.commands import UsageError

    script = load_script("study_exploration")
    every_method = list(script.METHODS)
    from exploration_study.runs import plans
    from exploration_study.worlds import resolve

    team = script.study_team(
        ["merger.robust.margin=0.2", "confirmations=3"], tmp_path, every_method
    )
    assert team.merger.robust.margin == 0.2 and team.confirmations == 3
    grid = script.Grid((4,), ("utility",), ("tomographic",), (0,), "utility", 5.0, team)
    (plan,) = plans(resolve("0", 20), grid)
    assert plan.team.confirmations == 3 and plan.team.merger.robust.margin == 0.2
    assert plan.team.comms.range == 5.0  # the study's own range, over --team's
    script.record_team(team, tmp_path)
    (tmp_path / "episodes_floor0.csv").write_text("key\n")
    assert (
        script.study_team(["confirmations=3", "merger.robust.margin=0.2"], tmp_path, every_method)
        == team
    )
    with pytest.raises(UsageError, match="give another --out"):
        script.study_team([], tmp_path, every_method)
    with pytest.raises(UsageError, match="--team: no team setting named 'confirm'"):
        script.study_team(["confirm=3"], tmp_path / "new", every_method)
    with pytest.raises(UsageError, match="--comm-ranges"):
        script.study_team(["comms.range=5"], tmp_path / "new", every_method)
    # Every other team setting, those explore has options for included.
    assert (
        script.study_team(["merge_interval=25"], tmp_path / "new", every_method).merge_interval
        == 25
    )
    # A setting of the oracle's acts on the oracle's episodes; without them it is refused.
    waiting = script.study_team(["oracle_min_shared_m2=10"], tmp_path / "new", every_method)
    grid = script.Grid(
        (4,), ("utility",), ("tomographic", "oracle"), (0,), "utility", None, waiting
    )
    (plan,) = plans(resolve("0", 20), grid)
    teams = {e.config.team.method: e.config.team for e in plan.episodes()}
    assert teams["oracle"].oracle_min_shared_m2 == 10.0
    with pytest.raises(UsageError, match="only the 'oracle' method uses it"):
        script.study_team(["oracle_min_shared_m2=10"], tmp_path / "new", ["none", "tomographic"])
    # Teams of one run with merging off only: no method's setting acts on them.
    with pytest.raises(UsageError, match=r"--robots 1 \(a robot alone"):
        script.study_team(["oracle_min_shared_m2=10"], tmp_path / "new", every_method, (1,))
    # A setting of the whole team is still taken.
    alone = script.study_team(["confirmations=3"], tmp_path / "new", every_method, (1,))
    assert alone.confirmations == 3
    # A run that recorded its settings but wrote no episode, then one with the defaults:
    # the folder says the defaults, and resuming it with the first settings is refused.
    empty = tmp_path / "empty"
    empty.mkdir()
    script.record_team(team, empty)
    script.record_team(script.study_team([], empty, every_method), empty)
    (empty / "episodes_floor0.csv").write_text("key\n")
    assert script.study_team([], empty, every_method) == script.TeamConfig()
    with pytest.raises(UsageError, match="give another --out"):
        script.study_team(["confirmations=3", "merger.robust.margin=0.2"], empty, every_method)
