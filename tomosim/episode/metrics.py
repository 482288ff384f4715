"""What an episode achieved: coverage over time, merge rounds, odometry drift."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

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

    def steps_to(self, fraction: float) -> int | None:
        """First step at which the team coverage reached ``fraction`` (None: never)."""
        reached = np.flatnonzero(np.asarray(self.coverage_curve) >= fraction)
        return int(reached[0]) if len(reached) else None

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
                "stop_reason": self.stop_reason,
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
