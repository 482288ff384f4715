"""The examples in the packages' docstrings run, and print what they say they print."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

import envs
import merging
import tomosim

OPTIONAL = {"envs.sb3": "stable_baselines3", "envs.rllib": "ray.rllib"}
"""Modules that need an optional extra, and the module whose absence skips them."""


def modules_with_examples() -> list[str]:
    """Every module of the three packages whose source holds a ``>>>`` example."""
    names = []
    for package in (merging, tomosim, envs):
        names.append(package.__name__)
        names += [
            info.name for info in pkgutil.walk_packages(package.__path__, f"{package.__name__}.")
        ]
    found = []
    for name in sorted(names):
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.origin and ">>>" in Path(spec.origin).read_text():
            found.append(name)
    return found


EXAMPLES = modules_with_examples()


def test_the_packages_have_examples() -> None:
    assert {"merging", "merging.catalog", "tomosim.worlds"} <= set(EXAMPLES)


@pytest.mark.parametrize("name", EXAMPLES)
def test_examples_run(name: str) -> None:
    if name in OPTIONAL:
        pytest.importorskip(OPTIONAL[name], reason=f"{name} needs an optional extra")
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = finder.find(module, name)
    assert sum(len(test.examples) for test in tests) > 0, f"{name} has no examples to run"
    for test in tests:
        runner.run(test)
    results = runner.summarize(verbose=False)
    assert results.failed == 0, f"{results.failed} of {results.attempted} examples of {name} failed"
