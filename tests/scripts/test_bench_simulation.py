"""``scripts/bench_simulation.py``: the plan table times each stage on a map a robot drew."""

from __future__ import annotations

from tests.support import load_script


def test_the_plan_table_times_every_stage_on_a_drawn_map() -> None:
    bench = load_script("bench_simulation")
    shape, medians = bench.bench_plan(after=60, repeats=2)
    assert shape[0] > 0 and shape[1] > 0
    assert set(medians) == {
        "coarsen (numpy)",
        "block_states (compiled)",
        "distance_transform_edt (scipy)",
        "distances_to_walls (compiled)",
        "frontier_clusters (scipy)",
        "frontier_groups (compiled)",
        "planning_grid",
        "Wavefront",
    }
    assert all(milliseconds > 0 for milliseconds in medians.values())
