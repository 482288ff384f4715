"""Recording a team's exploration with rerun and reading it back."""

from __future__ import annotations

import itertools
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

from tomosim.episode import EpisodeConfig, run_episode
from tomosim.exploration import FrontierPolicy
from tomosim.recording import Recorder, read_recording
from tomosim.recording.paths import COVERAGE, MERGED, TRUTH, map_path
from tomosim.recording.recorder import crop_to_known
from tomosim.team import TeamConfig, TeamMerge, TeamSession
from tomosim.worlds import generate_floorplan

SMALL_FLOOR = (12.0, 9.0)
"""Width and height, metres, of the floor the recording tests explore."""
STEPS = 45
MERGE_INTERVAL = 15
MAP_INTERVAL = 10


def rerun_binary() -> str | None:
    """The ``rerun`` command installed beside this Python, or on the PATH."""
    beside = Path(sys.executable).with_name("rerun")
    return str(beside) if beside.is_file() else shutil.which("rerun")


def verify(path: Path) -> None:
    """``rerun rrd verify`` must accept ``path``; skips without the rerun command."""
    binary = rerun_binary()
    if binary is None:
        pytest.skip("the rerun command (from the rerun-sdk package) is not installed")
    done = subprocess.run(
        [binary, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def recorded(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Path, TeamSession, list[float], list[TeamMerge]]:
    """A short exploration of two robots recorded to a file, with what the run saw."""
    world = generate_floorplan(2, width=SMALL_FLOOR[0], height=SMALL_FLOOR[1])
    session = TeamSession(world, robots=2, config=TeamConfig(merge_interval=MERGE_INTERVAL), rng=7)
    policies = [FrontierPolicy() for _ in range(2)]
    path = tmp_path_factory.mktemp("rec") / "run.rrd"
    coverage = [session.coverage.fraction]
    merges = []
    with Recorder.to_file(
        path, robots=2, bounds=world.bounds, map_interval=MAP_INTERVAL
    ) as recorder:
        recorder.log_start(session, {"world": world.name, "robots": 2})
        for _ in range(STEPS):
            sim = session.simulation
            commands = [
                p.act(sim.odometry[k].pose, session.best_map(k), scan=sim.scans[k])
                for k, p in enumerate(policies)
            ]
            merge = session.step(np.array(commands))
            coverage.append(session.coverage.fraction)
            if merge is not None:
                merges.append(merge)
            recorder.log_step(session, merge)
        recorder.log_end(session)
        recorder.log_end(session)  # nothing changed: no second copy of the maps
    return path, session, coverage, merges


def test_recording_passes_rerun_verify(
    recorded: tuple[Path, TeamSession, list[float], list[TeamMerge]],
) -> None:
    verify(recorded[0])


def test_recording_holds_a_default_blueprint(
    recorded: tuple[Path, TeamSession, list[float], list[TeamMerge]],
) -> None:
    reader = RrdReader(recorded[0])
    assert len(reader.recordings()) == 1
    assert len(reader.blueprints()) == 1


def test_series_read_back_equal_what_was_logged(
    recorded: tuple[Path, TeamSession, list[float], list[TeamMerge]],
) -> None:
    path, _, coverage, merges = recorded
    run = read_recording(path)
    assert run.settings == {"world": "floorplan seed=2", "robots": 2}
    np.testing.assert_array_equal(run.series[COVERAGE].steps, np.arange(STEPS + 1))
    np.testing.assert_array_equal(run.series[COVERAGE].values, coverage)
    assert [m.step for m in merges] == [15, 30, 45]
    assert run.pairs == ["r0-r1"]
    for merge in merges:
        (pair,) = merge.pairs
        assert run.pair("r0-r1", "confidence").at(merge.step) == pair.confidence
        assert run.pair("r0-r1", "accepted").at(merge.step) == float(pair.accepted)
        assert run.pair("r0-r1", "confirmed").at(merge.step) == float(pair.confirmed)
        assert run.pair("r0-r1", "matching_index").at(merge.step) == pair.matching_index
        rotation = run.pair("r0-r1", "rotation_error_deg").at(merge.step)
        # Errors are logged for accepted estimates only.
        assert rotation == (pair.rotation_error_deg if pair.accepted else None)
        assert run.series["merge/agreement"].at(merge.step) == merge.agreement
    assert len(run.log) == len(merges)


def test_grids_read_back_equal_what_was_logged(
    recorded: tuple[Path, TeamSession, list[float], list[TeamMerge]],
) -> None:
    path, session, _, merges = recorded
    run = read_recording(path)
    step, truth = run.grids[TRUTH]
    assert step is None  # static
    np.testing.assert_array_equal(truth.data, session.world.truth.data)
    assert truth.origin == session.world.truth.origin
    assert truth.resolution == session.world.truth.resolution
    step, merged = run.grids[MERGED]
    assert step == merges[-1].step
    expected = crop_to_known(merges[-1].merge.merged)
    np.testing.assert_array_equal(merged.data, expected.data)
    np.testing.assert_allclose(merged.origin, expected.origin, atol=1e-6)
    start = session.simulation.start_poses[merges[-1].merge.reference]
    np.testing.assert_allclose(run.poses[MERGED], start, atol=1e-6)


def test_maps_are_logged_when_changed_not_every_step(
    recorded: tuple[Path, TeamSession, list[float], list[TeamMerge]],
) -> None:
    steps = []
    for chunk in RrdReader(recorded[0]).stream().filter(content=f"+ /{map_path(0)}"):
        batch = chunk.to_record_batch()
        if "GridMap:data" in batch.schema.names:
            steps += batch.column("step").to_pylist()
    # Step 0, then at most every MAP_INTERVAL steps, then the last step once.
    assert steps[0] == 0 and steps[-1] == STEPS
    assert len(steps) == len(set(steps))
    assert all(b - a >= MAP_INTERVAL or b == STEPS for a, b in itertools.pairwise(steps))
    assert len(steps) <= STEPS // MAP_INTERVAL + 2


def test_a_failed_episode_keeps_what_it_recorded(tmp_path: Path) -> None:
    path = tmp_path / "failed.rrd"
    config = EpisodeConfig(world=4, world_size=SMALL_FLOOR, robots=2, merge_interval=5, record=path)

    def fail_at_step_12(step: int, coverage: float) -> None:
        if step == 12:
            raise RuntimeError("stopped on purpose")

    with pytest.raises(RuntimeError, match="on purpose"):
        run_episode(config, progress=fail_at_step_12)
    verify(path)
    run = read_recording(path)
    assert run.series[COVERAGE].steps[-1] == 12
    assert run.pair("r0-r1", "confidence").steps.tolist() == [5, 10]


def test_reading_a_missing_or_foreign_file_fails_clearly(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no such recording"):
        read_recording(tmp_path / "absent.rrd")
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"not a recording at all")
    with pytest.raises(ValueError, match="cannot read"):
        read_recording(junk)
