"""The environment's episodes, pinned: every output of a seeded episode, hashed.

Work on the simulator's speed must not move what the environment means: the
same seed gives the same episode, here and in every version that keeps the
environment's name. The digest below was recorded on the version before the
simulator's step was rewritten for speed (commit 52aca21) and is reproduced bit
for bit by that work; a meant change of the simulator's behaviour changes it, and
the environment's version with it (``*_v1``). The episode's merges follow the
default merger, so a change of the merger's answers records it again, named in
``CHANGELOG.md``.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np

from envs import multi_robot_exploration_v0 as exploration

EPISODE_STEPS = 160
"""Steps hashed: three merge rounds at the default interval (50), the links they make and
the teammates' maps shown from then on."""
EPISODE_DIGEST = "0e9b9cb83643a819"
"""The first 16 hex digits of :func:`episode_digest`. Recorded at commit 52aca21
(``e46471d80cbbd226``) and again when the default merger's answers changed with the
significance-ranked translation search: the episode's merges, and so the teammates'
maps it shows, follow the merger, while the simulator's own steps are as before."""


def add_observations(digest: Any, observations: dict[str, dict[str, np.ndarray]]) -> None:
    """Hash every agent's observation arrays, bytes, dtypes and shapes."""
    for agent in sorted(observations):
        for key in sorted(observations[agent]):
            value = np.ascontiguousarray(observations[agent][key])
            digest.update(f"{agent}/{key}/{value.dtype}/{value.shape}".encode())
            digest.update(value.tobytes())


def add_values(digest: Any, values: Any) -> None:
    """Hash rewards, ends or infos as JSON, floats written exactly (``repr``)."""
    digest.update(json.dumps(values, sort_keys=True, default=repr).encode())


def episode_digest() -> str:
    """The digest of a default environment's episode from seed 0 under seeded actions."""
    env = exploration.parallel_env()
    observations, infos = env.reset(seed=0)
    digest = hashlib.sha256()
    add_observations(digest, observations)
    add_values(digest, infos)
    generator = np.random.default_rng(1)
    for _ in range(EPISODE_STEPS):
        actions = {a: generator.uniform(-1.0, 1.0, 2).astype(np.float32) for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        add_observations(digest, observations)
        add_values(digest, [{a: repr(r) for a, r in rewards.items()}, terminations, truncations])
        add_values(digest, infos)
    env.close()
    return digest.hexdigest()[:16]


def test_a_seeded_episode_is_the_one_recorded() -> None:
    assert episode_digest() == EPISODE_DIGEST
