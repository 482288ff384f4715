"""The nearest frontier: the cheapest cell to reach, less its cluster's size bonus."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tomosim.exploration.targets import Candidate, Choice, Teammate, own_scores


@dataclass(frozen=True, slots=True)
class NearestChooser:
    """The cheapest cell to reach, less its cluster's size bonus; teammates ignored."""

    name: str = "nearest"
    coordinated: bool = False

    def choose(
        self, candidates: Sequence[Candidate], teammates: Sequence[Teammate], *, size_bonus: float
    ) -> Choice | None:
        best: tuple[float, Choice] | None = None
        for k, candidate in enumerate(candidates):
            scores = own_scores(candidate, size_bonus)
            index = int(np.argmin(scores))
            if best is None or scores[index] < best[0]:
                best = (float(scores[index]), (k, index))
        return None if best is None else best[1]
