"""Record the default merger's answers on every benchmark pair, or compare them with a record.

For a change meant to make the merger faster without changing what it
answers: run this before the change (``--out before.jsonl``) and after it
(``--compare before.jsonl``). A line per pair holds its suite and name, the
transform (as exact hexadecimal floats), whether it was accepted, the
confidence and the reason; a comparison counts the pairs answered identically
to the bit and lists the others with how far their transforms moved and
whether their verdicts changed (exit status 1 when any differ).

The pairs are those of the benchmarks: ``paper``, the section 4.1 protocol of
``bench_merge.py`` (50 pairs per map, seed 2020), and ``low-overlap``,
``whole`` and ``sessions`` of ``bench_real_maps.py`` (seed 2026). All four
take about 30 s (one process, on the 2-core machine of the README's figures).

Usage::

    python scripts/merger_answers.py --out before.jsonl
    python scripts/merger_answers.py --compare before.jsonl
    python scripts/merger_answers.py --suites paper low-overlap --out quick.jsonl
    python scripts/merger_answers.py --compare before.jsonl --merger confidence.accept=0.5

``--merger NAME=VALUE`` (repeatable) answers with a setting of the default
method changed by its dotted name (:mod:`merging.settings`): compared with a
record of the defaults, it lists every verdict the setting moves.
"""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

import merging
from merging.evaluation.pairs import cut_window_pairs
from tomosim.commands.merger_options import add_merger_argument, changed, merger_params
from tomosim.commands.script_args import run_script
from tomosim.data import maps_dir, maps_missing

SUITES = ("paper", "low-overlap", "whole", "sessions")
PAPER_PAIRS_PER_MAP = 50
"""Pairs per map of the paper's protocol, as the README's table runs it."""
PAPER_SEED = 2020
"""``bench_merge.py``'s default ``--seed``."""
REAL_SEED = 2026
"""``bench_real_maps.py``'s default ``--seed``."""


def _sibling(name: str) -> ModuleType:
    """A benchmark script beside this one, imported for its pairs."""
    path = Path(__file__).with_name(f"{name}.py")
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def cases(suites: list[str], limit: int | None = None) -> Iterator[tuple[str, str, Any, Any, int]]:
    """``(suite, pair, map1, map2, seed)`` for the pairs of ``suites`` (the first ``limit``
    of each), in a fixed order."""
    for suite in suites:
        yield from itertools.islice(_suite_cases(suite), limit)


def _suite_cases(suite: str) -> Iterator[tuple[str, str, Any, Any, int]]:
    """The pairs of one suite, as its benchmark script cuts them."""
    if suite == "paper":
        paper, folder = _sibling("bench_merge"), maps_dir()
        assert folder is not None
        for name in paper.DEFAULT_MAPS:
            grid = merging.load_map(folder / f"{name}.yaml")
            pairs = cut_window_pairs(grid.data, count=PAPER_PAIRS_PER_MAP, rng=PAPER_SEED)
            for index, pair in enumerate(pairs):
                yield suite, f"{name}#{index}", pair.map1, pair.map2, PAPER_SEED
        return
    real = _sibling("bench_real_maps")
    if suite == "low-overlap":
        generated = real.low_overlap_cases(75, REAL_SEED)
    elif suite == "whole":
        generated = real.whole_cases(10, REAL_SEED)
    else:
        generated = real.session_cases(1)
    for case in generated:
        yield suite, case.name, case.map1, case.map2, REAL_SEED


def answer(suite: str, pair: str, result: merging.MergeResult) -> dict[str, Any]:
    """One line of the record."""
    return {
        "suite": suite,
        "pair": pair,
        "matrix": [float(v).hex() for v in np.asarray(result.matrix, dtype=float).ravel()],
        "accepted": bool(result.accepted),
        "confidence": float(result.confidence).hex(),
        "reason": result.reason,
    }


def difference(before: dict[str, Any], now: dict[str, Any]) -> str:
    """How an answer moved: the largest change of a matrix entry, the confidence's and
    the verdict's."""
    old = np.array([float.fromhex(v) for v in before["matrix"]])
    new = np.array([float.fromhex(v) for v in now["matrix"]])
    parts = [f"matrix entries moved by up to {np.max(np.abs(new - old)):.3g}"]
    if before["confidence"] != now["confidence"]:
        was, now_is = float.fromhex(before["confidence"]), float.fromhex(now["confidence"])
        parts.append(f"confidence {was:.6g} -> {now_is:.6g}")
    if before["accepted"] != now["accepted"]:
        parts.append(f"accepted {before['accepted']} -> {now['accepted']}")
    if before["reason"] != now["reason"]:
        parts.append("reason changed")
    return ", ".join(parts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--suites", nargs="+", choices=SUITES, default=list(SUITES))
    parser.add_argument("--limit", type=int, help="only the first LIMIT pairs of each suite")
    target = parser.add_mutually_exclusive_group(required=True)
    target.add_argument("--out", type=Path, help="write the answers here (JSON lines)")
    target.add_argument("--compare", type=Path, help="compare with answers written before")
    add_merger_argument(parser)
    args = parser.parse_args(argv)
    params = merger_params(args.merger)
    options: dict[str, Any] = {} if params is None else {"params": params}
    if args.limit is not None and args.limit < 1:
        parser.error(f"--limit must be at least 1, got {args.limit}")
    if maps_dir() is None:
        parser.error(maps_missing())
    reference: dict[tuple[str, str], dict[str, Any]] = {}
    if args.compare is not None:
        if not args.compare.is_file():
            parser.error(f"--compare {args.compare}: no such file; write one with --out first")
        for number, line in enumerate(args.compare.read_text().splitlines(), start=1):
            try:
                entry = json.loads(line)
                reference[(entry["suite"], entry["pair"])] = entry
            except (json.JSONDecodeError, KeyError, TypeError):
                parser.error(f"--compare {args.compare}, line {number}: not a record this "
                             "script wrote with --out")  # fmt: skip
    handle = open(args.out, "w") if args.out is not None else None  # noqa: SIM115
    same = differ = missing = 0
    turned = {True: 0, False: 0}  # verdicts that moved, by the new one
    clock = time.perf_counter()
    try:
        for suite, pair, map1, map2, seed in cases(args.suites, args.limit):
            result = merging.estimate_transform(map1, map2, rng=seed, **options)
            now = answer(suite, pair, result)
            if handle is not None:
                handle.write(json.dumps(now) + "\n")
                handle.flush()
                continue
            before = reference.get((suite, pair))
            if before is None:
                missing += 1
            elif before == now:
                same += 1
            else:
                differ += 1
                if before["accepted"] != now["accepted"]:
                    turned[now["accepted"]] += 1
                print(f"{suite} {pair}: {difference(before, now)}")
    finally:
        if handle is not None:
            handle.close()
    seconds = time.perf_counter() - clock
    settings = changed(params)
    if settings:
        listed = ", ".join(f"{name}={value}" for name, value in settings.items())
        print(f"default merger's settings changed (--merger): {listed}")
    if args.out is not None:
        print(f"wrote the answers to {args.out} ({seconds:.0f} s)")
        return 0
    print(f"{same} identical, {differ} different ({turned[True]} now accepted, {turned[False]} "
          f"now refused), {missing} not in the record ({seconds:.0f} s)")  # fmt: skip
    return 1 if differ else 0


if __name__ == "__main__":
    run_script(main, __file__)
