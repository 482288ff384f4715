"""Refusal reasons: which failing factor a refusal names, in words."""

from __future__ import annotations

import pytest

from merging.evidence.verdict import CLOSE_FACTORS, refusal_reason

PASS, FAIL = 0.9, 0.1
"""Factor values that pass and fail (a factor passes at 0.5)."""


def close(**failing: float) -> tuple[float, ...]:
    """The close fit's factors, all passing but those given."""
    return tuple(failing.get(name, PASS) for name in CLOSE_FACTORS)


RIVAL = {"tolerant_runner_up_distance_cells": 31.0, "tolerant_runner_up_turn_deg": 1.2}


@pytest.mark.parametrize(
    ("factors", "robust", "words"),
    [
        # The close fit alone: its first failing factor names the cause.
        (close(fit=FAIL), {}, "too many of them land on the other map's open space"),
        (close(support=FAIL), {}, "too little overlap"),
        (close(constraint=FAIL), {}, "only one wall or corridor"),
        (close(space=FAIL), {}, "no open space"),
        # The robust way tried too: too few walls meeting comes before a rival...
        (close(fit=FAIL), {"agreeing": FAIL, "margin": FAIL}, "too few of them meet"),
        (close(fit=FAIL, support=FAIL), {"agreeing": FAIL}, "too little overlap"),
        (close(fit=FAIL), {"open_share": FAIL, "margin": FAIL}, "too little open space"),
        # ... which is named when the placement explains enough.
        (
            close(fit=FAIL),
            {"margin": FAIL},
            "ambiguous: another placement about as good "
            "lies 31 cells away, turned 1 degree from it",
        ),
        (close(fit=FAIL), {"strength": FAIL}, "only one wall or corridor"),
        (close(fit=FAIL), {"quality": FAIL}, "too many of them land"),
    ],
)
def test_a_refusal_names_its_cause(
    factors: tuple[float, ...], robust: dict[str, float], words: str
) -> None:
    passing = dict.fromkeys(robust and ("margin", "agreeing", "open_share", "strength"), PASS)
    assert words in refusal_reason(factors, {**passing, **robust}, RIVAL)


def test_turns_of_several_degrees_are_plural() -> None:
    evidence = {"runner_up_distance_cells": 555.0, "runner_up_turn_deg": 90.0}
    reason = refusal_reason(close(distinct=FAIL), {}, evidence)
    assert "555 cells away, turned 90 degrees from it" in reason
