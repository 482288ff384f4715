"""Episode figures: path lengths, overlap rate, time to the target, merge statistics."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tomosim.commands.explore_report import render_summary
from tomosim.episode import EpisodeMetrics, MergeRound
from tomosim.episode.exploration_tracker import ExplorationTracker, overlap_rate
from tomosim.team import PairQuality, TeamConfig, TeamSession
from tomosim.worlds import generate_floorplan

DT = 0.1
"""Seconds per step of the synthetic episodes."""


def test_overlap_rate_is_the_redundant_share_of_what_robots_know() -> None:
    assert overlap_rate((0.3, 0.3), 0.6) == pytest.approx(0.0)  # disjoint
    assert overlap_rate((0.4, 0.4), 0.4) == pytest.approx(1.0)  # the same cells twice
    assert overlap_rate((0.3, 0.3, 0.3), 0.3) == pytest.approx(2.0)
    assert overlap_rate((0.0, 0.0), 0.0) == 0.0
    # Disjoint shares summing a rounding below the team's once gave -3e-15 ("-0.00").
    assert overlap_rate((0.1, 0.2), 0.3 + 1e-15) == 0.0


def test_tracker_sums_each_robots_true_travel() -> None:
    world = generate_floorplan(4, width=15.0, height=10.0)
    session = TeamSession(world, robots=2, config=TeamConfig(merge=False), rng=3)
    tracker = ExplorationTracker(session)
    travelled = np.zeros(2)
    last = session.simulation.true_poses[:, :2]
    for _ in range(30):
        session.step(np.array([[0.6, 0.2], [0.4, -0.3]]))
        figures = tracker.update(session)
        now = session.simulation.true_poses[:, :2]
        travelled += np.hypot(*(now - last).T)
        last = now
    np.testing.assert_allclose(figures.path_lengths, travelled, rtol=1e-12)
    assert figures.path_length == pytest.approx(float(travelled.sum()))
    assert len(tracker.team_curve) == 31 and all(len(c) == 31 for c in tracker.robot_curves)
    assert figures.team_coverage == session.coverage.fraction
    own = [session.coverage.robot_fraction(k) for k in range(2)]
    assert figures.overlap_rate == pytest.approx(sum(own) / figures.team_coverage - 1.0)
    assert [curve[-1] for curve in tracker.robot_curves] == own


def test_tracker_advance_keeps_what_update_gives() -> None:
    world = generate_floorplan(4, width=15.0, height=10.0)
    sessions = [TeamSession(world, robots=3, config=TeamConfig(merge=False), rng=5) for _ in "ab"]
    updated, advanced = (ExplorationTracker(session) for session in sessions)
    for step in range(12):
        for session in sessions:
            session.step(np.array([[0.6, 0.2], [0.4, -0.3], [0.9, math.cos(step)]]))
        figures = updated.update(sessions[0])
        advanced.advance(sessions[1])
        assert advanced.last == figures  # built when asked, from the same numbers
    assert advanced.team_curve == updated.team_curve
    assert advanced.robot_curves == updated.robot_curves
    assert advanced.path_lengths == updated.path_lengths == figures.path_lengths


def pair(
    *, accepted: bool, confirmed: bool, used: bool, errors: tuple[float, float]
) -> PairQuality:
    nothing = (0.0, 0.0, 0.0)
    return PairQuality(0, 1, accepted, confirmed, used, 0.9, 0.5, nothing, nothing, *errors)


def metrics(rounds: list[MergeRound], curve: list[float]) -> EpisodeMetrics:
    return EpisodeMetrics(
        settings={"coverage_target": 0.9},
        steps=len(curve) - 1,
        sim_seconds=(len(curve) - 1) * DT,
        wall_seconds=1.0,
        coverage=curve[-1],
        coverage_curve=tuple(curve),
        stop_reason="test",
        merges=tuple(rounds),
        drift=(),
        dt=DT,
        robot_coverage_curves=(tuple(curve), tuple(0.5 * c for c in curve)),
        path_lengths=(3.0, 1.0),
        free_area=100.0,
    )


def test_merge_statistics_count_what_the_merger_did() -> None:
    right = pair(accepted=True, confirmed=True, used=True, errors=(0.3, 0.05))
    drifted = pair(accepted=True, confirmed=True, used=True, errors=(0.5, 0.3))
    false = pair(accepted=True, confirmed=False, used=False, errors=(90.0, 2.0))
    refused = pair(accepted=False, confirmed=False, used=False, errors=(math.inf, math.inf))
    rounds = [
        MergeRound(50, (refused,), (0,), 0.9, 0.1),
        MergeRound(100, (false,), (0,), 0.9, 0.1),
        MergeRound(150, (right,), (0, 1), 0.9, 0.1),
        MergeRound(200, (drifted,), (0, 1), 0.9, 0.1),
    ]
    stats = metrics(rounds, [0.2, 0.5, 0.95]).merge_stats()
    assert (stats.rounds, stats.estimates, stats.accepted, stats.confirmed) == (4, 4, 3, 2)
    assert (stats.wrong, stats.gross_wrong, stats.gross_wrong_confirmed) == (2, 1, 0)
    assert stats.first_link_step == 150 and stats.linked_robots == 2
    assert stats.all_linked_step == 150  # both robots' maps in one group
    assert stats.rotation_error_deg_max == 90.0
    three = metrics(rounds, [0.2, 0.5, 0.95])
    three = replace(three, settings={**three.settings, "robots": 3})
    assert three.merge_stats().all_linked_step is None  # robot 2 was never linked


def test_a_false_match_counts_as_linking_maps_unless_the_linking_dropped_it() -> None:
    false = pair(accepted=True, confirmed=True, used=True, errors=(180.0, 25.0))
    dropped = replace(false, used=False, dropped=True)
    rounds = [
        MergeRound(50, (false,), (0, 1), 0.9, 0.1),
        MergeRound(100, (dropped,), (0,), 0.9, 0.1),
    ]
    stats = metrics(rounds, [0.2, 0.5, 0.95]).merge_stats()
    assert (stats.confirmed, stats.gross_wrong, stats.gross_wrong_confirmed) == (2, 2, 1)


def test_time_to_target_curves_and_efficiency() -> None:
    episode = metrics([], [0.2, 0.5, 0.8, 0.91, 0.95])
    assert episode.steps_to(0.9) == 3 and episode.seconds_to(0.9) == pytest.approx(0.3)
    assert episode.steps_to(0.99) is None and episode.seconds_to(0.99) is None
    assert episode.robot_coverage == (0.95, 0.475)
    assert episode.overlap_rate == pytest.approx((0.95 + 0.475) / 0.95 - 1.0)
    assert episode.efficiency == pytest.approx(0.95 * 100.0 / 4.0)
    curves = episode.curves(stride=3)
    assert curves["steps"] == [0, 3, 4]  # the last step always
    assert curves["robots"][1] == [0.1, 0.455, 0.475]
    report = episode.as_dict()
    assert report["seconds_to_target"] == pytest.approx(0.3)
    assert report["path_length_m"] == 4.0 and len(report["robots"]) == 2


def test_summary_says_when_no_link_held_at_the_end() -> None:
    linked = pair(accepted=True, confirmed=True, used=True, errors=(0.3, 0.05))
    lost = pair(accepted=False, confirmed=False, used=False, errors=(math.inf, math.inf))
    settings = {
        "coverage_target": 0.9,
        "world": "floorplan seed=0",
        "robots": 2,
        "merge": True,
        "merge_interval": 50,
        "method": "tomographic",
        "seed": 0,
    }
    for last, expected in (
        (MergeRound(150, (linked,), (0, 1), 0.9, 0.1), "first link at step 100;"),
        (MergeRound(150, (lost,), (0,), 0.9, 0.1), "first link at step 100, none held"),
    ):
        rounds = [MergeRound(100, (linked,), (0, 1), 0.9, 0.1), last]
        episode = replace(metrics(rounds, [0.2, 0.5, 0.95]), settings=settings)
        [merged] = [
            line for line in render_summary(episode).splitlines() if line.startswith("merged")
        ]
        assert expected in merged
    # A team of three: the third map joins later, and the line names that round too.
    three = {**settings, "robots": 3}
    rounds = [
        MergeRound(100, (linked,), (0, 1), 0.9, 0.1),
        MergeRound(150, (linked, linked), (0, 1, 2), 0.9, 0.1),
    ]
    episode = replace(metrics(rounds, [0.2, 0.5, 0.95]), settings=three)
    [merged] = [line for line in render_summary(episode).splitlines() if line.startswith("merged")]
    assert "r0, r1, r2; first link at step 100, all linked at step 150;" in merged
