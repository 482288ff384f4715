"""The checks every setting goes through: kinds, ranges, names, switches, generators."""

from __future__ import annotations

import re

import numpy as np
import pytest

from merging.validators import (
    SettingTypeError,
    as_generator,
    boolean,
    near_names,
    one_of,
    real_number,
    whole_number,
)


def test_a_whole_number_comes_back_as_an_int() -> None:
    assert whole_number(3, "robots", minimum=1) == 3
    value = whole_number(np.int64(7), "seed", minimum=0)
    assert value == 7 and type(value) is int
    assert whole_number(-5, "offset") == -5  # no minimum, no bound


@pytest.mark.parametrize("value", [True, np.bool_(True), 3.0, "3", None])
def test_a_whole_number_of_another_kind_is_a_type_and_a_value_error(value: object) -> None:
    # A bool is not a count, 3.0 not a number of steps: named, not read as 1 or 3.
    with pytest.raises(SettingTypeError, match="robots must be a whole number >= 1, got") as err:
        whole_number(value, "robots", minimum=1)
    assert isinstance(err.value, TypeError) and isinstance(err.value, ValueError)


def test_a_whole_number_below_its_minimum_names_the_bound_and_unit() -> None:
    with pytest.raises(
        ValueError, match=r"^merge_interval must be a whole number of steps >= 1, got 0$"
    ):
        whole_number(0, "merge_interval", minimum=1, unit="steps")
    with pytest.raises(ValueError) as err:
        whole_number(-1, "seed", minimum=0)
    assert not isinstance(err.value, TypeError)  # the right kind, out of range


@pytest.mark.parametrize(
    ("bounds", "words", "inside", "outside"),
    [
        (
            {"low": 0.0, "high": 1.0, "low_open": True},
            "a number in (0, 1]",
            [1.0, 1e-9],
            [0.0, 1.1],
        ),
        (
            {"low": 0.0, "high": 1.0, "high_open": True},
            "a number in [0, 1)",
            [0.0, 0.5],
            [1.0, -0.1],
        ),
        (
            {"low": 0.0, "low_open": True, "unit": "metres"},
            "a positive number of metres",
            [2.5],
            [0.0],
        ),
        ({"low": 0.0}, "a non-negative number", [0.0, 3.0], [-1e-12]),
        ({"low": 1.0}, "a number >= 1", [1.0], [0.99]),
        ({"high": 1.0}, "a number <= 1", [-5.0, 1.0], [1.5]),
        ({}, "a finite number", [-1e300, 0.0], [float("nan"), float("inf")]),
    ],
)
def test_a_real_number_is_checked_against_its_range(
    bounds: dict, words: str, inside: list[float], outside: list[float]
) -> None:
    for value in inside:
        assert real_number(value, "x", **bounds) == value
    for value in outside:
        with pytest.raises(ValueError, match=rf"^x must be {re.escape(words)}, got"):
            real_number(value, "x", **bounds)


def test_a_real_number_takes_numpy_scalars_and_refuses_other_kinds() -> None:
    value = real_number(np.float32(0.25), "coverage_target", low=0.0, high=1.0)
    assert value == 0.25 and type(value) is float
    assert real_number(np.int64(2), "range") == 2.0
    for bad in (True, "0.5", 1j, None):
        with pytest.raises(SettingTypeError, match="coverage_target must be a number in"):
            real_number(bad, "coverage_target", low=0.0, high=1.0)


def test_one_of_names_the_choices_in_their_order() -> None:
    assert one_of("utility", ("nearest", "utility"), what="exploration policy") == "utility"
    for bad in ("greedy", 1, None):
        with pytest.raises(
            ValueError, match=r"unknown exploration policy .*; choose one of: nearest, utility$"
        ):
            one_of(bad, ("nearest", "utility"), what="exploration policy")


def test_boolean_takes_python_and_numpy_bools_only() -> None:
    assert boolean(np.bool_(False), "merge") is False
    assert boolean(True, "merge") is True
    for bad in (1, 0, "no", None):
        with pytest.raises(SettingTypeError, match="merge must be True or False, got"):
            boolean(bad, "merge")


def test_as_generator_passes_a_generator_through_and_seeds_the_rest() -> None:
    generator = np.random.default_rng(1)
    assert as_generator(generator) is generator
    first, again = as_generator(5), as_generator(np.random.SeedSequence(5))
    assert first.integers(1 << 30) == again.integers(1 << 30)
    assert isinstance(as_generator(None), np.random.Generator)


@pytest.mark.parametrize(("rng", "error"), [(True, TypeError), (-1, ValueError), ("x", TypeError)])
def test_as_generator_names_what_it_takes(rng: object, error: type) -> None:
    with pytest.raises(error, match="seed must be None, a non-negative int"):
        as_generator(rng, name="seed")


@pytest.mark.parametrize(
    ("name", "meant"),
    [
        ("accept", ["confidence.accept"]),  # the last part alone
        ("confidence.acept", ["confidence.accept"]),  # a typo
        ("mar", ["robust.margin", "robust.margin_cells"]),  # the start of the last part
        ("margin", ["robust.margin"]),  # a whole last part wins over longer ones
        ("MARGIN", ["robust.margin"]),  # whatever the case
        ("margin.", ["robust.margin"]),  # a trailing separator
        ("ma", []),  # too short a start to suggest from
        ("zzz", []),
    ],
)
def test_near_names_are_those_a_misspelt_name_may_mean(name: str, meant: list[str]) -> None:
    candidates = ["confidence.accept", "robust.margin", "robust.margin_cells", "peaks"]
    assert near_names(name, candidates) == meant


def test_near_names_are_the_nearest_four_split_by_the_separator() -> None:
    sessions = [f"halmstad/{floor}_{k:02d}" for floor in ("E5", "F5") for k in range(1, 15)]
    assert near_names("E5_03", sessions, separator="/") == ["halmstad/E5_03"]
    # A close spelling is not crowded out by names that merely start the same.
    assert near_names("E5_1", sessions, separator="/") == [
        "halmstad/E5_01",
        "halmstad/E5_10",
        "halmstad/E5_11",
        "halmstad/E5_12",
    ]
    assert near_names("e5_01", sessions, separator="/") == ["halmstad/E5_01"]
    assert near_names("E5_03", ["a/E5_03", "b/E5_03"], separator="/") == ["a/E5_03", "b/E5_03"]
    assert near_names("E5_03", sessions) == []  # no dots: the whole name is compared
