"""What an episode achieved: coverage over time, paths, overlap, merge rounds, odometry drift.

Besides the team's coverage curve and the merge rounds, the figures
multi-robot exploration papers report (Explore-Bench among them): the time to
the coverage target in steps and simulated seconds, each robot's coverage
curve and path length, the overlap rate (:mod:`tomosim.episode.exploration_tracker`),
the exploration efficiency (square metres known per metre travelled) and the
merge statistics (:class:`MergeStats`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tomosim.episode.exploration_tracker import overlap_rate
from tomosim.frames import pose_matrix
from tomosim.team.quality import PairQuality, RoundQuality
from tomosim.team.session import TeamSession


@dataclass(frozen=True, slots=True)
class MergeRound:
    """The figures of one scored merge round (a :class:`~tomosim.team.RoundQuality` without
    its map).

    ``drift`` holds, per robot, the error of its pose estimate when the round
    ran (heading in degrees, position in metres; :func:`odometry_drift`): the
    grids were drawn at drifting poses, so merge errors against the truth of
    the same order are the odometry's, not the merger's.
    """

    step: int
    pairs: tuple[PairQuality, ...]
    merged_robots: tuple[int, ...]
    agreement: float
    seconds: float
    drift: tuple[tuple[float, float], ...] = ()

    @classmethod
    def of(cls, scored: RoundQuality, session: TeamSession) -> MergeRound:
        """The figures of the round ``scored``, run in ``session`` at its current step."""
        return cls(
            scored.step,
            scored.pairs,
            scored.merged_robots,
            scored.agreement,
            scored.merge.seconds,
            odometry_drift(session),
        )


CURVE_STRIDE = 10
"""Steps between two points of the coverage curves in :meth:`EpisodeMetrics.as_dict` (one
simulated second at the default step of 0.1 s; the last step is always included)."""
WRONG_ROTATION_DEG = 2.0
"""An accepted estimate further off than this in rotation counts as wrong (the main
job's accuracy bar; right merges here are within a degree)."""
WRONG_TRANSLATION_M = 0.2
"""An accepted estimate further off than this in translation counts as wrong, same bar.
Long runs drift: on ``aces3`` right merges of maps drawn at drifting poses land up to
0.4 m off, which the next two thresholds tell apart from false matches."""
GROSS_ROTATION_DEG = 5.0
"""An accepted estimate further off than this in rotation is a false match: odometry
drift never turns a right merge this far."""
GROSS_TRANSLATION_M = 1.0
"""Same, metres of translation: a false match puts a map a room or more away."""


@dataclass(frozen=True, slots=True)
class MergeStats:
    """An episode's merge rounds in a few numbers.

    Attributes
    ----------
    rounds : int
        Merge rounds run.
    estimates, accepted, confirmed : int
        Pair estimates made, accepted by the merger, and confirmed (given to the
        linking, which may still drop one as contradicting the others).
    wrong : int
        Accepted estimates beyond :data:`WRONG_ROTATION_DEG` or :data:`WRONG_TRANSLATION_M`.
    gross_wrong : int
        Accepted estimates beyond :data:`GROSS_ROTATION_DEG` or :data:`GROSS_TRANSLATION_M`.
    gross_wrong_confirmed : int
        Those of them also confirmed and kept by the linking, which linked
        maps: a confirmed estimate the linking drops as contradicting the
        others (:attr:`~tomosim.team.PairQuality.dropped`) links nothing.
    first_link_step : int or None
        The first round in which a confirmed estimate linked two maps.
    linked_robots : int
        Robots in the largest linked group at the last round (1 without links).
    all_linked_step : int or None
        The first round whose main group held every robot's map (None when
        none did, and for a robot alone): what a team waits for when one
        robot explores apart from the others.
    rotation_error_deg_max, translation_error_m_max : float
        Largest errors of accepted estimates (NaN when none was accepted).
    seconds : float
        Wall-clock time of all rounds.
    """

    rounds: int
    estimates: int
    accepted: int
    confirmed: int
    wrong: int
    gross_wrong: int
    gross_wrong_confirmed: int
    first_link_step: int | None
    linked_robots: int
    all_linked_step: int | None
    rotation_error_deg_max: float
    translation_error_m_max: float
    seconds: float

    def as_dict(self) -> dict[str, Any]:
        """Plain values."""
        return {name: getattr(self, name) for name in self.__slots__}


@dataclass(frozen=True, slots=True)
class EpisodeMetrics:
    """What an episode achieved.

    Attributes
    ----------
    settings : dict
        :meth:`EpisodeConfig.settings`.
    steps : int
        Steps taken.
    sim_seconds, wall_seconds : float
        Simulated and wall-clock duration.
    coverage : float
        Final team coverage of the free space.
    coverage_curve : tuple of float
        Team coverage after each step, from step 0 (the first scans).
    stop_reason : str
        Why the episode ended.
    merges : tuple of MergeRound
        Every merge round, in order.
    drift : tuple of (float, float)
        Per robot, the final error of its pose estimate: heading (degrees)
        and position (metres).
    dt : float
        Simulated seconds per step.
    record : str or None
        The recording written.
    robot_coverage_curves : tuple of tuple of float
        Per robot, the coverage of its own grid after each step, from step 0.
    path_lengths : tuple of float
        Per robot, metres its true position travelled.
    free_area : float
        Square metres of the world's counted free space.
    """

    settings: dict[str, Any]
    steps: int
    sim_seconds: float
    wall_seconds: float
    coverage: float
    coverage_curve: tuple[float, ...]
    stop_reason: str
    merges: tuple[MergeRound, ...]
    drift: tuple[tuple[float, float], ...]
    dt: float
    record: str | None = None
    robot_coverage_curves: tuple[tuple[float, ...], ...] = ()
    path_lengths: tuple[float, ...] = ()
    free_area: float = 0.0

    def steps_to(self, fraction: float) -> int | None:
        """First step at which the team coverage reached ``fraction`` (None: never)."""
        reached = np.flatnonzero(np.asarray(self.coverage_curve) >= fraction)
        return int(reached[0]) if len(reached) else None

    def seconds_to(self, fraction: float) -> float | None:
        """Simulated seconds until the team coverage reached ``fraction`` (None: never)."""
        steps = self.steps_to(fraction)
        return None if steps is None else steps * self.dt

    @property
    def robot_coverage(self) -> tuple[float, ...]:
        """Per robot, the final coverage of its own grid."""
        return tuple(curve[-1] if curve else 0.0 for curve in self.robot_coverage_curves)

    @property
    def path_length(self) -> float:
        """Metres travelled by the whole team."""
        return float(sum(self.path_lengths))

    @property
    def overlap_rate(self) -> float:
        """Final sum of the robots' coverages over the team's, less one."""
        return overlap_rate(self.robot_coverage, self.coverage)

    @property
    def efficiency(self) -> float:
        """Square metres of free space the team knows per metre travelled (NaN: none)."""
        travelled = self.path_length
        return self.coverage * self.free_area / travelled if travelled > 0 else math.nan

    def merge_stats(self) -> MergeStats:
        """The merge rounds in a few numbers."""
        pairs = [p for m in self.merges for p in m.pairs]
        accepted = [p for p in pairs if p.accepted]
        rotation = np.array([p.rotation_error_deg for p in accepted], dtype=float)
        translation = np.array([p.translation_error_m for p in accepted], dtype=float)
        wrong = (rotation > WRONG_ROTATION_DEG) | (translation > WRONG_TRANSLATION_M)
        gross = (rotation > GROSS_ROTATION_DEG) | (translation > GROSS_TRANSLATION_M)
        confirmed = np.array([p.confirmed for p in accepted], dtype=bool)
        kept = np.array([p.confirmed and not p.dropped for p in accepted], dtype=bool)
        linked = [m.step for m in self.merges if any(p.used for p in m.pairs)]
        team = int(self.settings.get("robots", len(self.robot_coverage_curves)))
        whole = [m.step for m in self.merges if team > 1 and len(m.merged_robots) == team]
        last = self.merges[-1] if self.merges else None
        return MergeStats(
            rounds=len(self.merges),
            estimates=len(pairs),
            accepted=len(accepted),
            confirmed=int(np.count_nonzero(confirmed)),
            wrong=int(np.count_nonzero(wrong)),
            gross_wrong=int(np.count_nonzero(gross)),
            gross_wrong_confirmed=int(np.count_nonzero(gross & kept)),
            first_link_step=linked[0] if linked else None,
            linked_robots=len(last.merged_robots) if last is not None else 1,
            all_linked_step=whole[0] if whole else None,
            rotation_error_deg_max=float(rotation.max()) if len(rotation) else math.nan,
            translation_error_m_max=float(translation.max()) if len(translation) else math.nan,
            seconds=float(sum(m.seconds for m in self.merges)),
        )

    def curves(self, stride: int = CURVE_STRIDE) -> dict[str, Any]:
        """The coverage curves every ``stride`` steps (and at the last step)."""
        if stride < 1:
            raise ValueError(f"stride must be at least 1 step, got {stride}")
        last = len(self.coverage_curve) - 1
        steps = list(range(0, last + 1, stride))
        if steps[-1] != last:
            steps.append(last)
        return {
            "steps": steps,
            "team": [round(self.coverage_curve[s], 5) for s in steps],
            "robots": [[round(curve[s], 5) for s in steps] for curve in self.robot_coverage_curves],
        }

    def accepted(self) -> list[tuple[int, PairQuality]]:
        """``(step, pair)`` for every estimate the merger accepted, in order."""
        return [(m.step, p) for m in self.merges for p in m.pairs if p.accepted]

    def as_dict(self) -> dict[str, Any]:
        """Plain values for JSON (non-finite numbers become None)."""
        target = float(self.settings["coverage_target"])
        return _finite(
            {
                "settings": self.settings,
                "steps": self.steps,
                "sim_seconds": self.sim_seconds,
                "wall_seconds": self.wall_seconds,
                "coverage": self.coverage,
                "steps_to_target": self.steps_to(target),
                "seconds_to_target": self.seconds_to(target),
                "stop_reason": self.stop_reason,
                "path_length_m": self.path_length,
                "overlap_rate": self.overlap_rate,
                "efficiency_m2_per_m": self.efficiency,
                "free_area_m2": self.free_area,
                "robots": [
                    {"coverage": c, "path_length_m": p}
                    for c, p in zip(self.robot_coverage, self.path_lengths, strict=True)
                ],
                "coverage_curve": self.curves(),
                "merge_stats": self.merge_stats().as_dict(),
                "drift": [{"heading_deg": h, "position_m": p} for h, p in self.drift],
                "merges": [
                    {
                        "step": m.step,
                        "agreement": m.agreement,
                        "merged_robots": list(m.merged_robots),
                        "seconds": m.seconds,
                        "drift": [{"heading_deg": h, "position_m": p} for h, p in m.drift],
                        "pairs": {p.name: p.as_dict() for p in m.pairs},
                    }
                    for m in self.merges
                ],
                "record": self.record,
            }
        )


def _finite(value: Any) -> Any:
    """``value`` with every non-finite float (recursively) replaced by None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def odometry_drift(session: TeamSession) -> tuple[tuple[float, float], ...]:
    """Per robot, heading (degrees) and position (metres) error of its pose estimate."""
    sim = session.simulation
    out = []
    for k in range(sim.count):
        truth = np.linalg.inv(pose_matrix(sim.start_poses[k])) @ pose_matrix(sim.true_poses[k])
        estimate = sim.odometry[k].pose
        turn = math.remainder(estimate[2] - math.atan2(truth[1, 0], truth[0, 0]), 2 * math.pi)
        out.append((abs(math.degrees(turn)), float(np.hypot(*(estimate[:2] - truth[:2, 2])))))
    return tuple(out)
