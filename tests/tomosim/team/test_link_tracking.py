"""Transform tracking between merge rounds, and global searches in the worker process."""

from __future__ import annotations

import time

import numpy as np
import pytest

from merging.tomographic.tracking import METHOD as TRACKED
from tomosim.exploration import FrontierPolicy
from tomosim.team import TeamConfig, TeamSession, TrackingParams
from tomosim.team.merger import HELD_ONLY
from tomosim.team.quality import RoundQuality
from tomosim.team.worker import InlineSearches, WorkerSearches, searches
from tomosim.worlds import generate_floorplan

STEPS = 250
"""Steps of the tracked episode: merge rounds every 10 steps until the pair is linked, then
every 25."""
RIGHT_DEG, RIGHT_M = 2.0, 0.2
"""An accepted merge must be this close to the truth (the exploration's accuracy goal)."""
STEADY_DEG, STEADY_M = 0.5, 0.05
"""How far a tracked transform may move between two rounds: odometry drift only."""
INLINE = TeamConfig(merge_worker=False)
"""A team whose global searches run inline."""


def explore(*, worker: bool) -> tuple[list[RoundQuality], float]:
    """Two robots exploring a small floor with the frontier policy, merging every 25 steps
    once linked."""
    world = generate_floorplan(1, width=15.0, height=10.0)
    config = TeamConfig(merge_interval=25, merge_worker=worker)
    session = TeamSession(world, robots=2, config=config, rng=3)
    policies = [FrontierPolicy() for _ in range(2)]
    rounds = []
    for _ in range(STEPS):
        sim = session.simulation
        commands = [
            policy.act(sim.odometry[k].pose, session.best_map(k), scan=sim.scans[k])
            for k, policy in enumerate(policies)
        ]
        scored = session.step(commands)
        if scored is not None:
            rounds.append(scored)
    return rounds, session.coverage.fraction


@pytest.fixture(scope="module")
def tracked() -> tuple[list[RoundQuality], float]:
    return explore(worker=True)


@pytest.mark.slow
def test_worker_and_inline_searches_give_the_same_run(
    tracked: tuple[list[RoundQuality], float],
) -> None:
    inline, coverage = explore(worker=False)
    rounds, worker_coverage = tracked
    assert coverage == worker_coverage
    for a, b in zip(rounds, inline, strict=True):
        assert a.pairs == b.pairs
        np.testing.assert_array_equal(a.merge.merged.data, b.merge.merged.data)


def test_a_linked_pair_is_tracked_accurately_and_steadily(
    tracked: tuple[list[RoundQuality], float],
) -> None:
    rounds, _ = tracked
    pairs = [r.pairs[0] for r in rounds]
    methods = [r.merge.pairs[0].result.method for r in rounds]
    # Neither robot is tracked to a teammate yet: the pair is searched in the first
    # round itself (step 10, the interval of robots not linked) and accepted at once.
    assert rounds[0].merge.step == 10 and pairs[0].accepted
    assert TRACKED in methods and sum(p.confirmed for p in pairs) >= 5
    for pair in pairs:
        if pair.accepted:
            assert pair.rotation_error_deg <= RIGHT_DEG and pair.translation_error_m <= RIGHT_M
    for before, after, method in zip(pairs, pairs[1:], methods[1:], strict=False):
        if method == TRACKED and before.accepted:  # tracked on from an accepted transform
            # It moves by odometry drift, and by as much again as it comes nearer the
            # truth (a pair accepted on the small maps of its first seconds, right
            # within a degree, settles as the maps grow).
            turn = abs(after.estimate[2] - before.estimate[2])
            shift = np.hypot(*np.subtract(after.estimate[:2], before.estimate[:2]))
            nearer_deg = max(0.0, before.rotation_error_deg - after.rotation_error_deg)
            nearer_m = max(0.0, before.translation_error_m - after.translation_error_m)
            assert np.degrees(turn) <= STEADY_DEG + nearer_deg
            assert shift <= STEADY_M + nearer_m


def test_searches_are_collected_later_with_their_results() -> None:
    from merging.grid import OccupancyGrid

    walls = np.zeros((60, 80), np.int8)
    walls[5, 5:70] = walls[5:50, 5] = walls[50, 5:40] = walls[20:50, 60] = 100
    grid = OccupancyGrid(walls, resolution=0.05)
    assert isinstance(searches(worker=False), InlineSearches)
    assert isinstance(searches(worker=True), WorkerSearches)
    inline = InlineSearches().submit(grid, grid, method="tomographic", seed=1).result()
    first = WorkerSearches().submit(grid, grid, method="tomographic", seed=1)
    second = WorkerSearches().submit(grid, grid, method="tomographic", seed=1)
    assert first.result(timeout=120).confidence == inline.confidence
    np.testing.assert_array_equal(second.result(timeout=120).matrix, inline.matrix)
    failing = WorkerSearches().submit(grid, grid, method="no such method", seed=1)
    with pytest.raises(ValueError, match="unknown merging method"):
        failing.result(timeout=120)


def test_the_worker_says_when_it_is_ready_and_then_runs_the_searches() -> None:
    from merging.grid import OccupancyGrid

    walls = np.zeros((60, 80), np.int8)
    walls[5, 5:70] = walls[5:50, 5] = walls[50, 5:40] = walls[20:50, 60] = 100
    grid = OccupancyGrid(walls, resolution=0.05)
    with pytest.raises(ValueError, match="timeout"):
        WorkerSearches.wait_ready(-1.0)
    assert WorkerSearches.wait_ready(60.0)
    job = WorkerSearches().submit(grid, grid, method="tomographic", seed=3)
    expected = InlineSearches().submit(grid, grid, method="tomographic", seed=3).result()
    # A ready, idle worker is sent the job at once: it is no longer there to take back.
    deadline = time.monotonic() + 60.0
    while WorkerSearches.worker().queued and time.monotonic() < deadline:
        time.sleep(0.01)
    assert WorkerSearches.worker().take(job) is None
    np.testing.assert_array_equal(job.result(timeout=60.0).matrix, expected.matrix)


def test_a_waiting_caller_runs_the_searches_the_worker_has_not_started() -> None:
    from merging.grid import OccupancyGrid

    walls = np.zeros((60, 80), np.int8)
    walls[5, 5:70] = walls[5:50, 5] = walls[50, 5:40] = walls[20:50, 60] = 100
    grid = OccupancyGrid(walls, resolution=0.05)
    inline = [
        InlineSearches().submit(grid, grid, method="tomographic", seed=seed).result()
        for seed in range(4)
    ]
    worker = WorkerSearches()
    jobs = [worker.submit(grid, grid, method="tomographic", seed=seed) for seed in range(4)]
    # The worker runs one search at a time: waiting for the first, this process runs
    # later ones the worker has not started (which, depends on timing), and wherever
    # a search ran, its result is the same.
    first = worker.wait(jobs[0], jobs[1:])
    assert first.confidence == inline[0].confidence
    for job, expected in zip(jobs[1:], inline[1:], strict=True):
        np.testing.assert_array_equal(worker.wait(job, []).matrix, expected.matrix)
    failing = worker.submit(grid, grid, method="no such method", seed=1)
    with pytest.raises(ValueError, match="unknown merging method"):
        worker.wait(failing, [])


def test_a_search_taken_back_warns_as_in_the_worker_and_does_not_raise(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from concurrent.futures import Future

    from merging.grid import OccupancyGrid
    from merging.result import MergeResult
    from tomosim.team import worker as worker_module

    def overflowing(*args: object, **kwargs: object) -> MergeResult:
        np.exp(np.float64(1000.0))  # a RuntimeWarning: an error under this suite's filters
        return MergeResult(np.eye(3), 0.0, False, "tomographic")

    monkeypatch.setattr(worker_module, "estimate_transform", overflowing)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    taken: Future[MergeResult] = Future()
    with pytest.warns(RuntimeWarning, match="overflow"):
        worker_module._search((grid, grid, "tomographic", 1, {}), taken, as_worker=True)
    assert taken.exception() is None and not taken.result().accepted


@pytest.mark.slow
def test_searches_come_back_when_the_worker_has_ended(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    # A killed worker failed every search with RuntimeError, and `tomosim explore`
    # ended in a traceback; its searches now run here, with the same results.
    from merging.grid import OccupancyGrid
    from tomosim.team import worker as worker_module

    own = worker_module._Worker()  # a worker of this test's own, not the shared one
    monkeypatch.setattr(WorkerSearches, "_worker", own)
    walls = np.zeros((60, 80), np.int8)
    walls[5, 5:70] = walls[5:50, 5] = walls[50, 5:40] = walls[20:50, 60] = 100
    grid = OccupancyGrid(walls, resolution=0.05)
    searches_ = WorkerSearches()
    assert WorkerSearches.wait_ready(60.0)
    sent = searches_.submit(grid, grid, method="tomographic", seed=0)
    own.process.kill()
    own.process.wait(timeout=60)
    later = [searches_.submit(grid, grid, method="tomographic", seed=s) for s in (1, 2)]
    for seed, job in enumerate([sent, *later]):
        expected = InlineSearches().submit(grid, grid, method="tomographic", seed=seed).result()
        np.testing.assert_array_equal(searches_.wait(job, later).matrix, expected.matrix)
    assert "merge search worker ended" in caplog.text
    for pipe in (own.process.stdin, own.process.stdout):
        assert pipe is not None
        pipe.close()


@pytest.mark.parametrize(
    "quality, team, starts",
    [
        (0.95, INLINE, True),
        (0.7, INLINE, False),
        # The bar is the team's tracker setting: lowered below the fit, the track starts.
        (0.7, TeamConfig(merge_worker=False, tracker=TrackingParams(new_track_quality=0.65)), True),
    ],
)
def test_a_searched_placement_starts_a_track_only_when_it_fits_closely(
    monkeypatch: pytest.MonkeyPatch, quality: float, team: TeamConfig, starts: bool
) -> None:
    from merging.grid import OccupancyGrid
    from merging.result import MergeResult
    from tomosim.team import link_tracking as tracking_module
    from tomosim.team import worker as worker_module

    placed = np.eye(3)
    placed[0, 2] = 10.0
    searched = MergeResult(placed, 0.9, True, "tomographic", matrix_metres=placed)
    monkeypatch.setattr(worker_module, "estimate_transform", lambda *a, **k: searched)
    # The track's verdict accepts, fitting as closely as ``quality`` says (a tolerant fit
    # of bent maps can accept what the plain fit does not).
    verdict = MergeResult(placed, 0.8, True, TRACKED, placed, evidence={"quality": quality})
    monkeypatch.setattr(tracking_module, "track_transform", lambda *a, **k: verdict)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    estimator = tracking_module.TrackingEstimator(team, rng=0)
    first = estimator(0, 1, grid, grid)  # submits the search
    second = estimator(0, 1, grid, grid)  # collects it and tracks from it
    assert not first.accepted
    assert second.accepted is starts
    if not starts:
        assert second.reason == (
            "the search's placement fits too loosely to start tracking (plain fit 0.70, "
            "below 0.80); no new walls since the last global search"
        )


def test_a_track_is_kept_at_a_confidence_a_new_placement_would_not_reach(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from merging.grid import OccupancyGrid
    from merging.params import DEFAULT_PARAMS
    from merging.result import MergeResult
    from tomosim.team import link_tracking as tracking_module
    from tomosim.team import worker as worker_module

    placed = np.eye(3)
    placed[0, 2] = 10.0
    searched = MergeResult(placed, 0.9, True, "tomographic", matrix_metres=placed)
    monkeypatch.setattr(worker_module, "estimate_transform", lambda *a, **k: searched)
    confidence = {"now": 0.9}

    def verified(map1: object, map2: object, start: object, *, params: object) -> MergeResult:
        # The verdict track_transform would give at ``params``' threshold.
        accept = params.confidence.accept  # type: ignore[attr-defined]
        value = confidence["now"]
        return MergeResult(
            placed, value, value >= accept, TRACKED, placed, evidence={"quality": 0.9}
        )

    monkeypatch.setattr(tracking_module, "track_transform", verified)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    estimator = tracking_module.TrackingEstimator(INLINE, rng=0)
    estimator(0, 1, grid, grid)  # submits the search
    assert estimator(0, 1, grid, grid).accepted  # collects it: the track starts at 0.9
    between = (INLINE.tracker.keep_confidence + DEFAULT_PARAMS.confidence.accept) / 2
    confidence["now"] = between
    kept = estimator(0, 1, grid, grid)
    assert kept.accepted  # the track is kept, marked as held only: it confirms nothing
    assert kept.evidence.get(HELD_ONLY) == 1.0
    confidence["now"] = DEFAULT_PARAMS.confidence.accept
    assert HELD_ONLY not in estimator(0, 1, grid, grid).evidence  # found again in full
    confidence["now"] = INLINE.tracker.keep_confidence - 0.01
    lost = estimator(0, 1, grid, grid)
    assert not lost.accepted  # and dropped below the keeping threshold
    assert "which was not accepted" not in lost.reason  # the search was; the track is lost


def test_a_new_placement_needs_the_acceptance_threshold_to_start_a_track(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from merging.grid import OccupancyGrid
    from merging.params import DEFAULT_PARAMS
    from merging.result import MergeResult
    from tomosim.team import link_tracking as tracking_module
    from tomosim.team import worker as worker_module

    placed = np.eye(3)
    searched = MergeResult(placed, 0.9, True, "tomographic", matrix_metres=placed)
    monkeypatch.setattr(worker_module, "estimate_transform", lambda *a, **k: searched)
    between = (INLINE.tracker.keep_confidence + DEFAULT_PARAMS.confidence.accept) / 2

    def verified(map1: object, map2: object, start: object, *, params: object) -> MergeResult:
        accept = params.confidence.accept  # type: ignore[attr-defined]
        return MergeResult(
            placed, between, between >= accept, TRACKED, placed, evidence={"quality": 0.9}
        )

    monkeypatch.setattr(tracking_module, "track_transform", verified)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    estimator = tracking_module.TrackingEstimator(INLINE, rng=0)
    estimator(0, 1, grid, grid)
    assert not estimator(0, 1, grid, grid).accepted


def counting_search(monkeypatch: pytest.MonkeyPatch, quality: float = 0.9) -> list[int]:
    """Every global search accepts a placement, and its track verifies at ``quality``;
    returns the list that counts the searches (the seed of each)."""
    from merging.result import MergeResult
    from tomosim.team import link_tracking as tracking_module
    from tomosim.team import worker as worker_module

    placed = np.eye(3)
    seeds: list[int] = []

    def search(*args: object, rng: int, **kwargs: object) -> MergeResult:
        seeds.append(rng)
        return MergeResult(
            placed, 0.9, True, "tomographic", matrix_metres=placed, evidence={"quality": quality}
        )

    monkeypatch.setattr(worker_module, "estimate_transform", search)
    verdict = MergeResult(placed, 0.9, True, TRACKED, placed, evidence={"quality": quality})
    monkeypatch.setattr(tracking_module, "track_transform", lambda *a, **k: verdict)
    return seeds


@pytest.mark.parametrize("at_once", [True, False])
def test_a_pair_no_track_links_is_searched_in_the_round_itself(
    monkeypatch: pytest.MonkeyPatch, at_once: bool
) -> None:
    from merging.grid import OccupancyGrid
    from tomosim.team import link_tracking as tracking_module

    seeds = counting_search(monkeypatch)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    team = TeamConfig(merge_worker=False, tracker=TrackingParams(search_unlinked_at_once=at_once))
    estimator = tracking_module.TrackingEstimator(team, rng=0)
    estimator.prepare([grid, grid])
    first = estimator(0, 1, grid, grid)
    # At once: searched at the round's start, collected and tracked in the same round.
    # Otherwise the round submits the search and the next round collects it.
    assert first.accepted is at_once
    assert len(seeds) == 1
    estimator.prepare([grid, grid])
    assert estimator(0, 1, grid, grid).accepted
    assert estimator.tracked_groups(2) == (0, 0)


def test_pairs_linked_through_tracks_wait_for_the_next_round(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from merging.grid import OccupancyGrid
    from tomosim.team import link_tracking as tracking_module

    seeds = counting_search(monkeypatch)
    small = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    estimator = tracking_module.TrackingEstimator(INLINE, rng=0)
    grids = [small, small, small]
    estimator.prepare(grids)  # nobody tracked: every pair is searched now
    assert len(seeds) == 3
    assert all(estimator(i, j, small, small).accepted for i, j in ((0, 1), (0, 2), (1, 2)))
    # Everyone is tracked now; the tracks verify, nothing is searched at the start.
    estimator.prepare(grids)
    assert len(seeds) == 3
    # A pair the caller says cannot talk is left out (robot 2 is alone, out of reach).
    fresh = tracking_module.TrackingEstimator(INLINE, rng=0)
    fresh.prepare(grids, lambda i, j: 2 not in (i, j))
    assert len(seeds) == 4
    # Two groups, robots 0-1 and 2-3: only the four pairs across them are searched now.
    four = tracking_module.TrackingEstimator(INLINE, rng=0)
    four.prepare([small] * 4, lambda i, j: {i, j} in ({0, 1}, {2, 3}))
    assert four(0, 1, small, small).accepted and four(2, 3, small, small).accepted
    assert four.tracked_groups(4) == (0, 0, 2, 2) and len(seeds) == 6
    four.prepare([small] * 4)
    assert len(seeds) == 10
    assert four(1, 2, small, small).accepted and four.tracked_groups(4) == (0, 0, 0, 0)
    assert not four.round_wanted([small] * 4)  # one group: nothing left to link
    # A pair not linked is due a search when its maps gain walls (or a search is pending).
    other = tracking_module.TrackingEstimator(INLINE, rng=0)
    assert other.round_wanted(grids)
    other.prepare(grids)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        other(i, j, small, small)
    assert not other.round_wanted(grids)


def test_a_search_at_the_rounds_start_is_taken_as_it_found_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from merging.grid import OccupancyGrid
    from merging.result import MergeResult
    from tomosim.team import link_tracking as tracking_module

    seeds = counting_search(monkeypatch)
    placed = np.eye(3)
    # Refined again on the same maps, without the search's rivals, the placement is refused.
    refused = MergeResult(placed, 0.55, False, TRACKED, placed, evidence={"quality": 0.9})
    monkeypatch.setattr(tracking_module, "track_transform", lambda *a, **k: refused)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    estimator = tracking_module.TrackingEstimator(INLINE, rng=0)
    estimator.prepare([grid, grid])
    found = estimator(0, 1, grid, grid)
    assert found.accepted and found.method == "tomographic"  # the search's own verdict
    assert estimator.tracked_groups(2) == (0, 0)
    estimator.prepare([grid, grid])  # tracked: no search at the next round's start
    assert len(seeds) == 1
    lost = estimator(0, 1, grid, grid)  # the track, verified on that round's maps
    assert not lost.accepted
    assert estimator.tracked_groups(2) == (0, 1)


def test_the_team_s_merger_settings_reach_its_searches_and_tracks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from merging.grid import OccupancyGrid
    from merging.result import MergeResult
    from merging.settings import with_settings
    from tomosim.team import link_tracking as tracking_module
    from tomosim.team import worker as worker_module

    placed = np.eye(3)
    placed[0, 2] = 10.0
    searched = MergeResult(placed, 0.9, True, "tomographic", matrix_metres=placed)
    asked: dict[str, object] = {}

    def search(*args: object, **kwargs: object) -> MergeResult:
        asked["search"] = kwargs.get("params")
        return searched

    def track(map1: object, map2: object, start: object, *, params: object) -> MergeResult:
        asked.setdefault("tracks", []).append(params)  # type: ignore[union-attr]
        return MergeResult(placed, 0.8, True, TRACKED, placed, evidence={"quality": 0.9})

    monkeypatch.setattr(worker_module, "estimate_transform", search)
    monkeypatch.setattr(tracking_module, "track_transform", track)
    team = with_settings(INLINE, {"merger.robust.margin": "0.2"})
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.05)
    estimator = tracking_module.TrackingEstimator(team, rng=0)
    estimator(0, 1, grid, grid)  # submits the search
    assert estimator(0, 1, grid, grid).accepted  # collects it and starts a track
    estimator(0, 1, grid, grid)  # keeps the track
    assert asked["search"] == team.merger and team.merger.robust.margin == 0.2
    first, kept = asked["tracks"]  # type: ignore[misc]
    assert first == team.merger
    assert kept.robust.margin == 0.2  # the kept track's: the team's, at keep_confidence
    assert kept.confidence.accept == team.tracker.keep_confidence
    # Other methods take no settings: a sweep over methods leaves them unused there.
    assert TeamConfig(method="spectral", merger=team.merger).search_options() == {}
