"""``scripts/bench_real_maps.py``'s summary: per group, and over a suite's groups pooled."""

from __future__ import annotations

import csv
import io

from merging.params import DEFAULT_PARAMS
from merging.settings import with_settings
from tests.merging.builders import synthetic_building, turned
from tests.support import load_script


def test_a_suite_of_two_groups_ends_with_their_pooled_medians() -> None:
    bench = load_script("bench_real_maps")

    def row(group: str, method: str, seconds: float):
        return bench.Row(
            "low-overlap", group, "p", method, 1.0, 2.0, "yes", True, 0.9, seconds, seconds, 0.0, ""
        )

    # One method twice as fast in each group, yet slower over both together: the
    # other's times are spread across the groups.
    rows = [row("a", "default", t) for t in (0.010, 0.011, 0.012)]
    rows += [row("a", "other", t) for t in (0.020, 0.022, 0.024)]
    rows += [row("b", "default", t) for t in (0.008, 0.009, 0.010)]
    rows += [row("b", "other", t) for t in (0.001, 0.002, 0.003)]
    lines = bench.summary_table(rows, ["default", "other"])
    pooled = {line.split(" | ")[1]: line for line in lines if line.startswith("| all pairs |")}
    assert set(pooled) == {"default", "other"}
    # Medians over six pairs: default 0.0100, other 0.0115 (printed 0.011).
    assert "| 0.010 |" in pooled["default"] and "| 1.00 |" in pooled["default"]
    assert "| 0.011 |" in pooled["other"] and "| 1.15 |" in pooled["other"]
    single = bench.summary_table([r for r in rows if r.group == "a"], ["default", "other"])
    assert not any(line.startswith("| all pairs |") for line in single)


def test_window_pairs_are_also_summed_up_per_map() -> None:
    bench = load_script("bench_real_maps")

    def row(pair: str, method: str, seconds: float, right: str = "yes"):
        return bench.Row(
            "low-overlap", "w", pair, method, 1.0, 2.0, right, True, 0.9, seconds, seconds, 0.0, ""
        )

    # The other method is ten times slower on the large map and five times faster on
    # the small one; a pair without '#' (not a window) and one without a truth are left out.
    rows = [row(f"large#{k}", "default", 0.020) for k in range(2)]
    rows += [row(f"large#{k}", "other", 0.200) for k in range(2)]
    rows += [row("small#0", "default", 0.010), row("small#1", "default", 0.010, "no")]
    rows += [row(f"small#{k}", "other", 0.002) for k in range(2)]
    rows += [row("hall", "default", 9.0), row("large#9", "default", 9.0, "unknown")]
    lines = bench.by_map_table(rows, ["default", "other"])
    table = {tuple(line.split(" | ")[:2]): line for line in lines[5:]}
    assert set(table) == {("| large", "default"), ("| large", "other"), ("| small", "default"),
                          ("| small", "other")}  # fmt: skip
    assert table[("| large", "other")].endswith("| 0.2000 | 10.00 |")
    assert table[("| small", "other")].endswith("| 0.0020 | 0.20 |")
    # One of small's two default pairs is accepted but wrong.
    assert "| 2 | 50.0% | 1 | 0.0100 | 1.00 |" in table[("| small", "default")]
    assert bench.by_map_table([r for r in rows if r.pair.startswith("large")], ["default"]) == []


def test_the_window_suites_cut_the_shares_they_name(maps_folder, monkeypatch) -> None:
    bench = load_script("bench_real_maps")
    monkeypatch.setattr(bench, "LOW_OVERLAP_MAPS", ("intel",))
    for suite, overlap in (("low-overlap", bench.LOW_OVERLAP),
                           ("moderate-overlap", bench.MODERATE_OVERLAP)):  # fmt: skip
        cases = list(bench.window_cases(suite, overlap, 2, 41))
        assert [case.name for case in cases] == ["intel#0", "intel#1"]
        low, high = round(overlap[0] * 100), round(overlap[1] * 100)
        assert {case.group for case in cases} == {f"windows sharing {low}-{high} %"}
        assert {case.suite for case in cases} == {suite}


def test_from_truth_rows_judge_the_truth_and_skip_pairs_without_one() -> None:
    bench = load_script("bench_real_maps")
    building = synthetic_building(5)
    map2, truth = turned(building, 30.0, (4.0, -3.0))
    cases = [
        bench.Case("s", "known", "turned", building, map2, truth, 2.0),
        bench.Case("s", "unknown", "same", building, building, None, 0.0),
    ]
    handle = io.StringIO()
    writer = csv.DictWriter(handle, fieldnames=list(bench.Row.__dataclass_fields__))
    rows = bench.run(iter(cases), ["tomographic", *bench.TRUTH_ROWS], 0, writer, handle)
    assert [(r.pair, r.method) for r in rows] == [
        ("turned", "tomographic"),
        ("turned", bench.FROM_TRUTH),
        ("turned", bench.TRUTH_IN_SEARCH),
        ("same", "tomographic"),
    ]
    # Judged against the search's own pool too, the building's truth holds: no rival.
    assert rows[2].accepted and rows[2].right == "yes"
    judged = rows[1]
    # Refined from the truth itself, the building's walls hold it: accepted, in place.
    assert judged.accepted and judged.right == "yes" and judged.rms_cells < 0.5
    # The search finds the same placement: the two rows lie within a cell of each other.
    assert rows[0].accepted and judged.from_default_cells < 1.0


def test_the_default_merger_s_settings_reach_its_rows_and_the_report() -> None:
    bench = load_script("bench_real_maps")
    building = synthetic_building(5)
    map2, truth = turned(building, 30.0, (4.0, -3.0))
    cases = [bench.Case("s", "known", "turned", building, map2, truth, 2.0)]
    handle = io.StringIO()
    writer = csv.DictWriter(handle, fieldnames=list(bench.Row.__dataclass_fields__))
    # Asked for a confidence no placement reaches, the default and from_truth refuse.
    params = with_settings(DEFAULT_PARAMS, {"confidence.accept": "1.0"})
    rows = bench.run(iter(cases), ["tomographic", bench.FROM_TRUTH], 0, writer, handle, params)
    assert [r.accepted for r in rows] == [False, False]
    # The default's row says where its time went; the report sums it up.
    steps = dict(item.split("=") for item in rows[0].stages.split(";"))
    assert {"rotation", "translation", "refine"} <= set(steps) and "total" not in steps
    assert rows[1].stages == ""
    table = bench.stages_table(rows)
    assert "Where the default's time goes (1 pairs; milliseconds):" in table
    translation = next(line for line in table if line.startswith("| translation |"))
    assert translation == f"| translation | 1 | {float(steps['translation']):.1f} | " + (
        f"{float(steps['translation']):.1f} |"
    )
    assert bench.stages_table(rows[1:]) == []
    assert all(r.right == "yes" for r in rows)  # the same placements, only refused
    assert bench.settings_line(params) == [
        "Default merger's settings changed (`--merger`): `confidence.accept=1.0`.",
        "",
    ]
    assert bench.settings_line(None) == bench.settings_line(DEFAULT_PARAMS) == []
