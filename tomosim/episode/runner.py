"""Running one episode with the built-in policy: ``run_episode(config) -> metrics``.

:func:`run_episode` builds everything from an :class:`EpisodeConfig` (the
world, a :class:`~tomosim.team.TeamSession`, one
:class:`~tomosim.exploration.FrontierPolicy` per robot and, when asked, a
recording) and runs until the first of

* the team knows ``coverage_target`` of the world's free space,
* ``steps`` steps have been taken,
* no robot has a reachable frontier left.

Each step every robot acts on its pose estimate and its *best map*: its own
grid, or, once merges link it to teammates, its own grid with the cells it has
not observed filled in from theirs, in its frame (:mod:`tomosim.team.sharing`).
The same configuration and seed always give the same episode.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from tomosim.episode.config import EpisodeConfig, load_world
from tomosim.episode.metrics import EpisodeMetrics, MergeRound, odometry_drift
from tomosim.exploration import FrontierPolicy
from tomosim.team.session import TeamConfig, TeamSession

if TYPE_CHECKING:
    from tomosim.recording import Recorder

STOP_TARGET = "coverage target reached"
STOP_STEPS = "step limit reached"
STOP_FINISHED = "no reachable frontier left"

Progress = Callable[[int, float], None]
"""``progress(step, team_coverage)``, called after every step."""


def run_episode(
    config: EpisodeConfig,
    *,
    recorder: Recorder | None = None,
    progress: Progress | None = None,
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

    Raises
    ------
    FileNotFoundError, ValueError
        From :func:`load_world` and from placing the robots (a world without
        room for them).
    """
    clock = time.perf_counter()
    world = load_world(config.world, size=config.world_size)
    team = TeamConfig(
        merge=config.merge,
        method=config.method,
        merge_interval=config.merge_interval,
        simulation=config.simulation,
    )
    session = TeamSession(world, robots=config.robots, config=team, rng=config.seed)
    settings = config.settings(world)
    owned = None
    if recorder is None and config.record is not None:
        from tomosim.recording import Recorder  # rerun is needed only to record

        owned = recorder = Recorder.to_file(config.record)
    try:
        if recorder is not None:
            recorder.log_start(session, settings)
        curve, merges, reason = _explore(session, config, recorder, progress)
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
        coverage_curve=tuple(curve),
        stop_reason=reason,
        merges=tuple(merges),
        drift=odometry_drift(session),
        dt=session.config.simulation.dt,
        record=None if config.record is None else str(config.record),
    )


def _explore(
    session: TeamSession,
    config: EpisodeConfig,
    recorder: Recorder | None,
    progress: Progress | None,
) -> tuple[list[float], list[MergeRound], str]:
    """The episode's loop: coverage after each step, the merge rounds, the stop reason."""
    policies = [FrontierPolicy() for _ in range(session.count)]
    curve = [session.coverage.fraction]
    merges: list[MergeRound] = []
    reason = STOP_STEPS
    while session.steps < config.steps:
        if curve[-1] >= config.coverage_target:
            reason = STOP_TARGET
            break
        sim = session.simulation
        commands = np.array(
            [
                policy.act(sim.odometry[k].pose, session.best_map(k), scan=sim.scans[k])
                for k, policy in enumerate(policies)
            ]
        )
        if all(policy.finished for policy in policies):
            reason = STOP_FINISHED
            break
        merge = session.step(commands)
        curve.append(session.coverage.fraction)
        if merge is not None:
            merges.append(MergeRound.of(merge, session))
        if recorder is not None:
            recorder.log_step(session, merge)
        if progress is not None:
            progress(session.steps, curve[-1])
    else:
        if curve[-1] >= config.coverage_target:
            reason = STOP_TARGET
    return curve, merges, reason
