"""Running one episode with the built-in policy: ``run_episode(config) -> metrics``.

:func:`run_episode` builds everything from an :class:`EpisodeConfig` (the
world, a :class:`~tomosim.team.TeamSession`, a
:class:`~tomosim.exploration.TeamExplorer` running the configured policy,
an :class:`~tomosim.episode.exploration_tracker.ExplorationTracker` and, when asked, a
recording) and runs until the first of

* the team knows ``coverage_target`` of the world's free space,
* ``steps`` steps have been taken,
* no robot has a reachable frontier left.

Each step every robot acts on its pose estimate and its *best map*: its own
grid, or, once merges link it to teammates, its own grid with the cells it has
not observed filled in from theirs, in its frame (:mod:`tomosim.team.sharing`);
a coordinated policy also uses its linked teammates' poses and targets
(:mod:`tomosim.exploration.team`). The same configuration and seed always
give the same episode.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from tomosim.episode.config import EpisodeConfig, load_world
from tomosim.episode.exploration_tracker import ExplorationTracker
from tomosim.episode.outcome import EpisodeMetrics, MergeRound, odometry_drift
from tomosim.exploration import TeamExplorer
from tomosim.team.session import TeamSession

if TYPE_CHECKING:
    from tomosim.recording import Recorder
    from tomosim.team.quality import RoundQuality

STOP_TARGET = "coverage target reached"
STOP_STEPS = "step limit reached"
STOP_FINISHED = "no reachable frontier left"

Progress = Callable[[int, float], None]
"""``progress(step, team_coverage)``, called after every step."""
MergeObserver = Callable[["TeamSession", "RoundQuality"], None]
"""``on_merge(session, merge)``, called after every merge round with the session as the
round left it (its grids, ``session.grids()``, are those the round merged) and the
round scored against the truth."""


def run_episode(
    config: EpisodeConfig,
    *,
    recorder: Recorder | None = None,
    progress: Progress | None = None,
    on_merge: MergeObserver | None = None,
) -> EpisodeMetrics:
    """Run one episode (module docstring).

    Parameters
    ----------
    config : EpisodeConfig
        The episode.
    recorder : Recorder, optional
        Where to log the episode; when None and ``config.record`` is set, a
        recorder writing that file is made here and closed at the end, also
        when the episode fails, so that the file keeps what was logged.
    progress : callable, optional
        ``progress(step, team_coverage)`` after every step.
    on_merge : callable, optional
        ``on_merge(session, merge)`` after every merge round (:data:`MergeObserver`),
        to study the rounds beyond what the metrics keep.

    Raises
    ------
    FileNotFoundError, ValueError
        From :func:`load_world` and from placing the robots (a world without
        room for them).
    """
    clock = time.perf_counter()
    world = load_world(config.world, size=config.world_size)
    session = TeamSession(world, robots=config.robots, config=config.team, rng=config.seed)
    settings = config.settings(world)
    owned = None
    if recorder is None and config.record is not None:
        from tomosim.recording import Recorder  # rerun is needed only to record

        owned = recorder = Recorder.to_file(config.record)
    try:
        if recorder is not None:
            recorder.log_start(session, settings)
        tracker, merges, reason = _explore(session, config, recorder, progress, on_merge)
        if recorder is not None:
            recorder.log_end(session, reason)
    finally:
        if owned is not None:
            owned.close()
    return EpisodeMetrics(
        settings=settings,
        steps=session.steps,
        sim_seconds=session.simulation.time,
        wall_seconds=time.perf_counter() - clock,
        coverage=session.coverage.fraction,
        coverage_curve=tuple(tracker.team_curve),
        stop_reason=reason,
        merges=tuple(merges),
        drift=odometry_drift(session),
        dt=session.config.simulation.dt,
        record=None if config.record is None else str(config.record),
        robot_coverage_curves=tuple(tuple(curve) for curve in tracker.robot_curves),
        path_lengths=tracker.path_lengths,
        free_area=session.coverage.total * session.coverage.cell_area,
    )


def _explore(
    session: TeamSession,
    config: EpisodeConfig,
    recorder: Recorder | None,
    progress: Progress | None,
    on_merge: MergeObserver | None,
) -> tuple[ExplorationTracker, list[MergeRound], str]:
    """The episode's loop: the tracked figures, the merge rounds, the stop reason."""
    explorer = TeamExplorer(session.count, policy=config.policy)
    tracker = ExplorationTracker(session)
    if recorder is not None:
        recorder.log_figures(session, tracker.last)
    merges: list[MergeRound] = []
    reason = STOP_STEPS
    while session.steps < config.steps:
        if tracker.team_curve[-1] >= config.coverage_target:
            reason = STOP_TARGET
            break
        commands = explorer.act(session)
        if explorer.finished:
            reason = STOP_FINISHED
            break
        merge = session.step(commands)
        figures = tracker.update(session)
        if merge is not None:
            merges.append(MergeRound.of(merge, session))
            if on_merge is not None:
                on_merge(session, merge)
        if recorder is not None:
            recorder.log_step(session, merge)
            recorder.log_figures(session, figures)
        if progress is not None:
            progress(session.steps, figures.team_coverage)
    else:
        if tracker.team_curve[-1] >= config.coverage_target:
            reason = STOP_TARGET
    return tracker, merges, reason
