"""Running an episode: what an observer of its merge rounds sees."""

from __future__ import annotations

from tomosim.episode import EpisodeConfig
from tomosim.episode.runner import run_episode
from tomosim.team import TeamConfig, TeamSession
from tomosim.team.quality import RoundQuality


def test_the_merge_observer_sees_every_round_with_the_grids_it_merged() -> None:
    seen: list[tuple[int, int]] = []

    def observe(session: TeamSession, merge: RoundQuality) -> None:
        grids = session.grids()
        seen.append((session.steps, merge.step))
        assert len(grids) == len(merge.merge.linking.roots) == 2

    config = EpisodeConfig(
        world="0", robots=2, steps=30, seed=1, team=TeamConfig(merge_worker=False)
    )
    metrics = run_episode(config, on_merge=observe)
    assert seen and [step for _, step in seen] == [m.step for m in metrics.merges]
    assert all(now == step for now, step in seen)  # called in the round's own step
