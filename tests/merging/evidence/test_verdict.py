"""Refusal reasons: which failing factor a refusal names, in words; when a weak turn or a
cheap slide is held by the refinement."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from merging.evidence.verdict import (
    CLOSE_FACTORS,
    refusal_reason,
    reverse_reason,
    same_walls,
    slide_is_held,
    turn_is_held,
)
from merging.evidence.verify import (
    Verification,
    confidence_factors,
    pinned_factors,
    prepare_map,
)
from merging.params import DEFAULT_PARAMS

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


@pytest.mark.parametrize(
    ("same_walls", "restarted", "words"),
    [
        # The rival lays the aligned walls elsewhere and no slide was tried: the rival.
        (0.1, {}, "ambiguous: another placement about as good lies 100 cells away"),
        # The rival lays them on themselves again (one wall turned end for end): the slide.
        (0.9, {}, "only one wall or corridor to align on: the maps could slide"),
        # A slide tried and not come back from is named whatever the rival.
        (0.1, {"slide_return_cells": 2.46}, "started slid a little along it"),
    ],
)
def test_a_rival_elsewhere_is_named_before_an_untried_slide(
    same_walls: float, restarted: dict[str, float], words: str
) -> None:
    evidence = {
        "runner_up_distance_cells": 100.0,
        "runner_up_turn_deg": 89.0,
        "runner_up_same_walls": same_walls,
        **restarted,
    }
    assert words in refusal_reason(close(constraint=0.45, distinct=0.2), {}, evidence)


def test_same_walls_tells_a_wall_laid_on_itself_from_a_rival_elsewhere() -> None:
    cells = np.full((80, 120), -1, dtype=np.int8)
    cells[20:60, :] = 0
    cells[40, 10:110] = 100  # one straight wall...
    cells[20:40, 100] = 100  # ... and a short cross wall at one end
    first = prepare_map(cells)
    second = prepare_map(cells)
    best = np.eye(3)
    # Turned end for end about the wall's middle (x = 59.5, y = 40): the long wall lies
    # on itself again, the cross wall lands at the other end, away from any wall.
    flipped = np.array([[-1.0, 0.0, 119.0], [0.0, -1.0, 80.0], [0.0, 0.0, 1.0]])
    elsewhere = np.array([[0.0, -1.0, 70.0], [1.0, 0.0, -40.0], [0.0, 0.0, 1.0]])
    on_itself = same_walls(first, second, best, flipped, radius=1)
    assert 0.7 < on_itself < 1.0
    assert same_walls(first, second, best, elsewhere, radius=1) < 0.3
    assert same_walls(first, second, best, best, radius=1) == 1.0


def test_turns_of_several_degrees_are_plural() -> None:
    evidence = {"runner_up_distance_cells": 555.0, "runner_up_turn_deg": 90.0}
    reason = refusal_reason(close(distinct=FAIL), {}, evidence)
    assert "555 cells away, turned 90 degrees from it" in reason


def test_a_turn_the_refinement_does_not_come_back_from_is_named() -> None:
    words = refusal_reason(close(constraint=FAIL), {}, {"turn_return_cells": 3.04})
    assert words.startswith("the overlap is too short to hold map 2's turn")
    assert "3.0 cells away" in words


def test_a_slide_the_refinement_does_not_come_back_from_is_named_before_the_turn() -> None:
    # The slide is asked about only once the turn is held: when both were asked, the
    # slide is why.
    evidence = {"turn_return_cells": 0.1, "slide_return_cells": 2.46}
    words = refusal_reason(close(constraint=FAIL), {}, evidence)
    assert words.startswith("only one wall or corridor to align on: started slid a little")
    assert "2.5 cells away" in words


# The close fit's factors with the constraint last but one: (fit, support, distinct,
# constraint, space). A slide costing 120 cells gives 0.95; a turn of 3, 0.18.
PINNED = (120.0, 3.0)
HELD_BACK = (0.96, 1.0, 1.0, 0.18, 1.0)


def _never() -> float:
    raise AssertionError("the turn was asked about though it cannot change the verdict")


def test_the_turn_is_asked_about_only_when_it_alone_holds_the_verdict_back() -> None:
    params = DEFAULT_PARAMS.confidence
    unconstrained = 0.96
    # Already passing, or the slide the weaker hold, or too weak without the turn anyway.
    exact = {"fit_quality": 1.0}
    assert not turn_is_held((0.9, 1, 1, 0.9, 1), unconstrained, PINNED, _never, params, {}, **exact)
    assert not turn_is_held(HELD_BACK, unconstrained, (5.0, 30.0), _never, params, {}, **exact)
    assert not turn_is_held(HELD_BACK, 0.5, PINNED, _never, params, {}, **exact)
    # ... or the walls meet too loosely for a sharp optimum to vouch for the truth.
    loose = {"fit_quality": 0.9}
    assert not turn_is_held(HELD_BACK, unconstrained, PINNED, _never, params, {}, **loose)


@pytest.mark.parametrize(("returned", "held"), [(0.2, True), (1.5, False), (float("inf"), False)])
def test_the_turn_is_held_when_the_refinement_comes_back(returned: float, held: bool) -> None:
    measures: dict[str, float] = {}
    params = DEFAULT_PARAMS.confidence
    asked = turn_is_held(HELD_BACK, 0.96, PINNED, lambda: returned, params, measures, fit_quality=1)
    assert asked is held
    assert measures == {"turn_return_cells": returned}


def test_a_weak_turn_is_asked_about_with_a_weak_slide_when_the_slide_will_be_asked_too() -> None:
    params = DEFAULT_PARAMS.confidence
    # Sliding costs 5 cells (0.12), turning 3 (0.18): neither alone would pass.
    both = (5.0, 3.0)
    exact = {"fit_quality": 1.0}
    assert not turn_is_held(HELD_BACK, 0.96, both, _never, params, {}, **exact)
    measures: dict[str, float] = {}
    held = turn_is_held(
        HELD_BACK, 0.96, both, lambda: 0.2, params, measures, slide_asked=True, **exact
    )
    assert held
    assert measures == {"turn_return_cells": 0.2}
    # ... but not when nothing else holds the verdict back.
    assert not turn_is_held(HELD_BACK, 0.5, both, _never, params, {}, slide_asked=True, **exact)


def _never_slid(within: float) -> float:
    raise AssertionError("the slide was asked about though it cannot change the verdict")


# A slide costing 5 cells gives 0.12; a turn of 30, 0.86.
CHEAP_SLIDE = (5.0, 30.0)


def test_the_slide_is_asked_about_only_when_it_alone_holds_the_verdict_back() -> None:
    params = DEFAULT_PARAMS.confidence
    exact = {"fit_quality": 1.0}
    ask = partial(slide_is_held, params=params, measures={}, slide_returns=_never_slid)
    # Already passing; the turn the weaker hold (and not held); too weak anyway.
    assert not ask((0.9, 1, 1, 0.9, 1), 0.96, CHEAP_SLIDE, **exact)
    assert not ask(HELD_BACK, 0.96, PINNED, **exact)
    assert not ask(HELD_BACK, 0.5, CHEAP_SLIDE, **exact)
    assert not ask(HELD_BACK, 0.96, (5.0, 3.0), **exact)
    # ... or the walls meet too loosely.
    assert not ask(HELD_BACK, 0.96, CHEAP_SLIDE, fit_quality=0.9)


@pytest.mark.parametrize(("returned", "held"), [(0.2, True), (0.9, False), (float("inf"), False)])
def test_the_slide_is_held_when_the_refinement_comes_back(returned: float, held: bool) -> None:
    params = DEFAULT_PARAMS.confidence
    asked_within: list[float] = []

    def returns(within: float) -> float:
        asked_within.append(within)
        return returned

    measures: dict[str, float] = {}
    # A weak turn held by the refinement leaves the cheap slide to be asked.
    both = (5.0, 3.0)
    asked = slide_is_held(HELD_BACK, 0.96, both, returns, params, measures, fit_quality=1.0,
                          turn_held=True)  # fmt: skip
    assert asked is held
    assert measures == {"slide_return_cells": returned}
    assert asked_within == [params.slide_return_cells]


EXACT_OVERLAP = Verification(agreement=1.0, conflict=0.0, overlap=2000.0, agreeing=2000.0,
                             shared_space=5000.0)  # fmt: skip
"""A large overlap whose walls all meet: only the constraint factor is in question."""


@pytest.mark.parametrize("pinned", [PINNED, CHEAP_SLIDE])
def test_what_is_held_leaves_the_other_to_pin_the_placement(pinned) -> None:
    # The curvature (strength 0.5) is weaker than either; held both ways, it is pinned.
    params = DEFAULT_PARAMS.confidence
    slid, turned = pinned_factors(pinned, params)
    rate = partial(confidence_factors, EXACT_OVERLAP, strength=0.5, params=params, pinned=pinned)
    assert rate()[3] == pytest.approx(min(slid, turned))
    assert rate(turn_held=True)[3] == pytest.approx(slid)
    assert rate(slide_held=True)[3] == pytest.approx(turned)
    assert rate(slide_held=True, turn_held=True)[3] == 1.0


def test_a_reverse_refinement_far_away_or_a_near_miss_says_which() -> None:
    params = DEFAULT_PARAMS.confidence
    far = reverse_reason(2.6, 0.4, params)
    assert far.startswith("the overlap does not hold map 2 to the accuracy asked")
    assert "2.6 cells away" in far
    near = reverse_reason(0.8, 0.596, params)
    assert near.startswith("only just short of sure (confidence 0.596, 0.6 asked)")
