"""The environment's episodes, pinned: every output of a seeded episode, hashed.

Work on the simulator's speed must not move what the environment means: the
same seed gives the same episode, here and in every version that keeps the
environment's name. The digest below was recorded on the version before the
simulator's step was rewritten for speed (commit 52aca21) and is reproduced bit
for bit by that work; a meant change of the simulator's behaviour changes it, and
the environment's version with it (``*_v1``). The episode's merges follow the
default merger, so a change of the merger's answers records it again, named in
``CHANGELOG.md``.

The same seed gives the same episode bit for bit only on the same arithmetic: NumPy
picks its kernels by the CPU's instruction set (its AVX-512 sine, cosine and sums
round differently from its AVX2 ones) and OpenBLAS its matrix products, and the last
bits of a pose decide where a ray hits. The digest was recorded on AVX2 machines, so
the episode is run in a child process held to those kernels
(:data:`KERNEL_ENVIRONMENT`) and is the same on any x86-64 machine with AVX2 (for
the NumPy and SciPy releases it was recorded with: another release may round
differently too).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from typing import Any

import numpy as np
import pytest

from envs import multi_robot_exploration_v0 as exploration

EPISODE_STEPS = 160
"""Steps hashed: three merge rounds at the default interval (50), the links they make and
the teammates' maps shown from then on."""
EPISODE_DIGEST = "8cfd222eae3090d7"
"""The first 16 hex digits of :func:`episode_digest`. Recorded at commit 52aca21
(``e46471d80cbbd226``) and again each time the default merger's answers changed: with
the significance-ranked translation search (``0e9b9cb83643a819``) and with its
significance counting map 1's walls in map 2's clear space (``0db020f4f72e829b``). The
episode's merges, and so the teammates' maps it shows, follow the merger, while the
simulator's own steps are as before. Recorded once more when the scored pairs in the
infos gained ``shared_free_m2``: without that key the episode hashes to
``0db020f4f72e829b`` still."""


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


def kernel_environment() -> dict[str, str] | None:
    """The environment holding NumPy and OpenBLAS to the AVX2 kernels the digest was
    recorded with, or ``None`` on a CPU without AVX2 and FMA (not x86-64 v3).

    Every NumPy dispatch target above AVX2 is disabled (``NPY_DISABLE_CPU_FEATURES``:
    ``X86_V4`` and the ``AVX512*`` ones, by whichever names this NumPy gives them) and
    OpenBLAS is told its CPU is a Haswell (``OPENBLAS_CORETYPE``).
    """
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # NumPy 1.x
        from numpy.core import _multiarray_umath as umath  # type: ignore[no-redef]

    features = umath.__cpu_features__
    if not (features.get("AVX2") and features.get("FMA3")):
        return None
    above_avx2 = [
        name for name in umath.__cpu_dispatch__ if name == "X86_V4" or name.startswith("AVX512")
    ]
    return {"NPY_DISABLE_CPU_FEATURES": " ".join(above_avx2), "OPENBLAS_CORETYPE": "Haswell"}


KERNEL_ENVIRONMENT = kernel_environment()
"""See :func:`kernel_environment`."""


def test_a_seeded_episode_is_the_one_recorded() -> None:
    if KERNEL_ENVIRONMENT is None:
        pytest.skip(
            "the digest was recorded with NumPy's AVX2 kernels, which this CPU lacks; "
            "run on an x86-64 machine with AVX2 and FMA"
        )
    child = subprocess.run(
        [sys.executable, __file__],
        env={**os.environ, **KERNEL_ENVIRONMENT},
        capture_output=True,
        text=True,
        check=False,
    )
    assert child.returncode == 0, child.stderr
    assert child.stdout.strip() == EPISODE_DIGEST


if __name__ == "__main__":
    print(episode_digest())
