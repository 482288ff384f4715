"""Recording a team's exploration with rerun, reading it back, and what the viewer opens on."""

from __future__ import annotations

import itertools
import json
import shutil
import socket
import subprocess
import sys
import urllib.request
import uuid
import warnings
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from tomosim.episode import EpisodeConfig, load_world, run_episode
from tomosim.episode.exploration_tracker import ExplorationTracker
from tomosim.exploration import FrontierPolicy
from tomosim.recording import (
    LiveViewer,
    Recorder,
    RecordingError,
    read_recording,
    recorded_views,
)
from tomosim.recording.paths import (
    ACCEPTED_PAIRS,
    AGREEMENT,
    APPLICATION_ID,
    CONFIG,
    COVERAGE,
    MERGED,
    MERGED_FRAME,
    OVERLAP_RATE,
    PATH_LENGTH_TOTAL,
    PATH_LENGTHS,
    TRUTH,
    map_path,
    path_length_path,
    robot_colour,
    robot_coverage_path,
)
from tomosim.recording.recorder import AGREEMENT_COLOUR, crop_to_known
from tomosim.recording.sinks import Sinks
from tomosim.team import RoundQuality, TeamConfig, TeamSession
from tomosim.worlds import generate_floorplan

SMALL_FLOOR = (12.0, 9.0)
"""Width and height, metres, of the floor the recording tests explore."""
STEPS = 45
MERGE_INTERVAL = 15
MAP_INTERVAL = 10
TEAM_SEED = 2
"""A team whose first round is refused and whose next two are accepted."""
SPATIAL_KINDS = ("2D", "3D")
"""rerun's class identifiers of spatial views."""
SCALAR_COLUMN = "Scalars:scalars"
"""The column a scalar series is logged in."""


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


def held_entities(path: Path) -> dict[str, set[str]]:
    """Every entity of the recording in ``path`` (without the leading ``/``) and its columns."""
    held: dict[str, set[str]] = {}
    for chunk in RrdReader(path).stream():
        held.setdefault(chunk.entity_path.lstrip("/"), set()).update(
            chunk.to_record_batch().schema.names
        )
    return held


def matched(rule: str, origin: str, held: dict[str, set[str]]) -> set[str]:
    """The held entities one ``+ path`` or ``+ path/**`` rule selects."""
    path = rule.removeprefix("+ ").replace("$origin", origin).strip("/").strip()
    if path.endswith("/**") or path == "**":
        stem = path.removesuffix("**").rstrip("/")
        return {e for e in held if not stem or e == stem or e.startswith(stem + "/")}
    return {path} & set(held)


@pytest.fixture(scope="module")
def recorded(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Path, TeamSession, list[float], list[RoundQuality]]:
    """A short exploration of two robots recorded to a file, with what the run saw."""
    world = generate_floorplan(2, width=SMALL_FLOOR[0], height=SMALL_FLOOR[1])
    session = TeamSession(
        world, robots=2, config=TeamConfig(merge_interval=MERGE_INTERVAL), rng=TEAM_SEED
    )
    policies = [FrontierPolicy() for _ in range(2)]
    path = tmp_path_factory.mktemp("rec") / "run.rrd"
    coverage = [session.coverage.fraction]
    merges = []
    tracker = ExplorationTracker(session)
    with Recorder.to_file(path, map_interval=MAP_INTERVAL) as recorder:
        recorder.log_start(session, {"world": world.name, "robots": 2})
        recorder.log_figures(session, tracker.last)
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
            recorder.log_figures(session, tracker.update(session))
        recorder.log_end(session, "step limit reached")
        recorder.log_end(session, "step limit reached")  # nothing changed: no second map copy
    return path, session, coverage, merges


def test_recording_passes_rerun_verify(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    verify(recorded[0])


def test_recording_holds_one_blueprint(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    reader = RrdReader(recorded[0])
    assert len(reader.recordings()) == 1
    assert len(reader.blueprints()) == 1


def test_every_view_is_2d_or_a_chart_and_shows_recorded_entities(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    """Read the layout back from the file: each view's filter selects what the run logged."""
    path, _, _, merges = recorded
    assert any(p.accepted for m in merges for p in m.pairs), "the run needs an accepted merge"
    assert not all(p.accepted for m in merges for p in m.pairs), "and a refused one"
    views = recorded_views(path)
    held = held_entities(path)
    kinds = [view.kind for view in views]
    assert "3D" not in kinds
    assert kinds.count("2D") == 1 + 1 + 2  # the world, the merged map, two robots' maps
    assert kinds.count("TimeSeries") == 6
    for view in views:
        assert view.origin == "/", view
        selected: set[str] = set()
        for rule in view.contents:
            assert rule.startswith(("+ ", "- ")), rule
            # rerun's filters know one wildcard: a trailing /** (no * inside a path)
            assert "*" not in rule.removesuffix("/**"), rule
            if rule.startswith("+ "):
                found = matched(rule, view.origin, held)
                assert found, f"{view.name}: {rule} selects nothing the recording holds"
                selected |= found
        if view.kind == "TimeSeries":
            assert any(SCALAR_COLUMN in held[e] for e in selected), view
        else:
            assert view.kind == "2D"
            assert any(
                held[e] & {"SegmentationImage:buffer", "Points2D:positions"} for e in selected
            ), view


def test_views_follow_what_the_run_logs(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    views = {view.name: view for view in recorded_views(recorded[0])}
    rotation = views["Rotation error [deg]"]
    assert rotation.contents == ("+ merge/rotation_error_deg/**",)
    held = held_entities(recorded[0])
    assert matched(rotation.contents[0], "/", held) == {"merge/rotation_error_deg/r0-r1"}
    team = views["Coverage, overlap rate (fractions)"]
    fractions = {COVERAGE, OVERLAP_RATE, robot_coverage_path(0), robot_coverage_path(1)}
    lengths = {path_length_path(0), path_length_path(1), PATH_LENGTH_TOTAL}
    assert matched(team.contents[0], "/", held) == fractions | lengths
    assert team.contents[1] == f"- {PATH_LENGTHS}/**"  # metres would dwarf the fractions
    assert matched(views["Path length [m]"].contents[0], "/", held) == lengths
    # a series logged later under team/ would show without touching the layout
    assert "team/frontier_count" in matched(
        team.contents[0], "/", held | {"team/frontier_count": set()}
    )


def series_styles(path: Path) -> dict[str, tuple[str, tuple[int, int, int]]]:
    """Each styled series' name and RGB colour, by entity."""
    styles = {}
    for chunk in RrdReader(path).stream():
        batch = chunk.to_record_batch()
        if "SeriesLines:names" in batch.schema.names:
            (name,) = batch.column("SeriesLines:names").to_pylist()[0]
            (packed,) = batch.column("SeriesLines:colors").to_pylist()[0]
            rgb = ((packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255)
            styles[chunk.entity_path.lstrip("/")] = (name, rgb)
    return styles


def test_team_series_are_named_and_drawn_in_their_robots_colours(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    # Unstyled, the viewer chose colours itself: r1's path length and the team's total
    # came out alike, so r1 looked to have gone three times as far as the others.
    styles = series_styles(recorded[0])
    for k in range(2):
        assert styles[path_length_path(k)] == (f"r{k}", robot_colour(k))
        assert styles[robot_coverage_path(k)] == (f"r{k} own map", robot_colour(k))
    lengths = [
        styles[path] for path in (path_length_path(0), path_length_path(1), PATH_LENGTH_TOTAL)
    ]
    fractions = [
        styles[path] for path in (COVERAGE, OVERLAP_RATE, *map(robot_coverage_path, (0, 1)))
    ]
    for chart in (lengths, fractions):
        assert len({colour for _, colour in chart}) == len(chart)  # one colour per line
    assert styles[PATH_LENGTH_TOTAL][0] == "team total"
    assert styles[AGREEMENT][1] == AGREEMENT_COLOUR and min(AGREEMENT_COLOUR) > 200  # on dark


def test_a_run_without_merging_has_no_merge_views(tmp_path: Path) -> None:
    path = tmp_path / "alone.rrd"
    config = EpisodeConfig(
        world=2,
        world_size=SMALL_FLOOR,
        robots=2,
        steps=5,
        record=path,
        team=TeamConfig(merge=False),
    )
    run_episode(config)
    views = recorded_views(path)
    held = held_entities(path)
    assert [v.kind for v in views].count("TimeSeries") == 2
    assert [v.kind for v in views].count("2D") == 1 + 2
    assert "World: truth, robots" in [v.name for v in views]  # no merged map to name
    for view in views:
        for rule in view.contents:
            if rule.startswith("+ "):
                assert matched(rule, view.origin, held), (view.name, rule)


def test_series_read_back_equal_what_was_logged(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    path, _, coverage, merges = recorded
    run = read_recording(path)
    assert run.settings == {"world": "floorplan seed=2", "robots": 2}
    assert run.status == f"finished at step {STEPS}: step limit reached"
    assert run.finished and run.notes == ()
    np.testing.assert_array_equal(run.series[COVERAGE].steps, np.arange(STEPS + 1))
    np.testing.assert_array_equal(run.series[COVERAGE].values, coverage)
    # Every 10 steps while the two maps are not linked (when a round can link them).
    assert [m.step for m in merges] == [10, 20, 30, 45]
    assert run.pairs == ["r0-r1"]
    for merge in merges:
        (pair,) = merge.pairs
        assert run.pair("r0-r1", "confidence").at(merge.step) == pair.confidence
        assert run.pair("r0-r1", "accepted").at(merge.step) == float(pair.accepted)
        assert run.pair("r0-r1", "confirmed").at(merge.step) == float(pair.confirmed)
        assert run.pair("r0-r1", "used").at(merge.step) == float(pair.used)
        assert run.pair("r0-r1", "dropped").at(merge.step) == float(pair.dropped)
        # nan (for estimates not accepted) reads back as nan
        np.testing.assert_equal(
            run.pair("r0-r1", "matching_index").at(merge.step), pair.matching_index
        )
        assert run.pair("r0-r1", "shared_free_m2").at(merge.step) == pair.shared_free_m2
        rotation = run.pair("r0-r1", "rotation_error_deg").at(merge.step)
        # Errors are logged for accepted estimates only.
        assert rotation == (pair.rotation_error_deg if pair.accepted else None)
        assert run.series[AGREEMENT].at(merge.step) == merge.agreement
        assert run.series[ACCEPTED_PAIRS].at(merge.step) == len(merge.accepted)
    assert len(run.log) == len(merges)
    # The run links the two maps, so the series of the linking's choice holds a 1, and the
    # merge log says so.
    assert any(pair.used for merge in merges for pair in merge.pairs)
    for (step, line), merge in zip(run.log, merges, strict=True):
        (pair,) = merge.pairs
        assert step == merge.step and ("r0-r1 confirmed, used (" in line) == pair.used


def test_grids_read_back_equal_what_was_logged(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
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
    np.testing.assert_allclose(run.poses[MERGED_FRAME], start, atol=1e-6)


def test_maps_are_logged_when_changed_not_every_step(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]],
) -> None:
    steps = []
    for chunk in RrdReader(recorded[0]).stream().filter(content=f"+ /{map_path(0)}"):
        batch = chunk.to_record_batch()
        if "SegmentationImage:buffer" in batch.schema.names:
            steps += batch.column("step").to_pylist()
    # Step 0, then at most every MAP_INTERVAL steps, then the last step once.
    assert steps[0] == 0 and steps[-1] == STEPS
    assert len(steps) == len(set(steps))
    assert all(b - a >= MAP_INTERVAL or b == STEPS for a, b in itertools.pairwise(steps))
    assert len(steps) <= STEPS // MAP_INTERVAL + 2


def test_a_failed_episode_keeps_what_it_recorded(tmp_path: Path) -> None:
    path = tmp_path / "failed.rrd"
    config = EpisodeConfig(
        world=4, world_size=SMALL_FLOOR, robots=2, record=path, team=TeamConfig(merge_interval=5)
    )

    def fail_at_step_12(step: int, coverage: float) -> None:
        if step == 12:
            raise RuntimeError("stopped on purpose")

    with pytest.raises(RuntimeError, match="on purpose"):
        run_episode(config, progress=fail_at_step_12)
    verify(path)
    run = read_recording(path)
    assert run.series[COVERAGE].steps[-1] == 12
    assert run.pair("r0-r1", "confidence").steps.tolist() == [5, 10]
    assert run.status == "stopped at step 12 before its end" and not run.finished


def test_a_torn_file_is_read_up_to_its_last_whole_message(
    recorded: tuple[Path, TeamSession, list[float], list[RoundQuality]], tmp_path: Path
) -> None:
    """A process killed while writing leaves half a message at the end: read the rest."""
    whole = recorded[0].read_bytes()
    torn = tmp_path / "torn.rrd"
    torn.write_bytes(whole[: int(len(whole) * 0.7)])
    with warnings.catch_warnings(), pytest.raises(RuntimeError):
        warnings.simplefilter("ignore")  # its warning that the file has no footer
        RrdReader(torn).recordings()  # rerun's reader refuses the whole file
    run = read_recording(torn)
    assert run.notes and "cut short" in run.notes[0] and "torn.rrd" in run.notes[0]
    assert not run.finished
    assert 0 < run.last_step <= STEPS
    assert run.settings == {"world": "floorplan seed=2", "robots": 2}
    np.testing.assert_array_equal(
        run.series[COVERAGE].steps, np.arange(len(run.series[COVERAGE].steps))
    )


def write_foreign(path: Path, application: str, config: str) -> None:
    """A recording of ``application`` holding a ``run/config`` text and a scalar."""
    stream = rr.RecordingStream(application, recording_id=uuid.uuid4())
    stream.save(path)
    stream.log(CONFIG, rr.TextDocument(config), static=True)
    stream.set_time("step", sequence=0)
    stream.log(COVERAGE, rr.Scalars(0.5))
    stream.flush()
    stream.disconnect()


def test_recordings_of_other_applications_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "other.rrd"
    write_foreign(path, "somebody_else", json.dumps({"robots": 2}))
    with pytest.raises(ValueError, match="application 'somebody_else', not of 'tomosim'"):
        read_recording(path)


def test_settings_that_are_not_json_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / "odd.rrd"
    write_foreign(path, APPLICATION_ID, "robots: two")
    with pytest.raises(ValueError, match=r"odd\.rrd: its run/config is not JSON"):
        read_recording(path)


def test_reading_a_missing_or_foreign_file_fails_clearly(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no such recording"):
        read_recording(tmp_path / "absent.rrd")
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"not a recording at all")
    with pytest.raises(ValueError, match="not a rerun recording"):
        read_recording(junk)


def test_an_unwritable_recording_is_one_clear_error(tmp_path: Path) -> None:
    dangling = tmp_path / "run.rrd"
    dangling.symlink_to(tmp_path / "missing" / "run.rrd")
    session = TeamSession(
        generate_floorplan(2, width=SMALL_FLOOR[0], height=SMALL_FLOOR[1]), robots=1, rng=0
    )
    recorder = Recorder.to_file(dangling)
    with pytest.raises(RecordingError, match=r"cannot write the recording .*run\.rrd"):
        recorder.log_start(session, {})
    recorder.close()
    with pytest.raises(RecordingError, match=r"folder .* does not exist"):
        Recorder.to_file(tmp_path / "missing" / "run.rrd")


def free_port() -> int:
    """A TCP port nobody listens on right now."""
    return free_ports(1)[0]


def free_ports(count: int) -> list[int]:
    """``count`` different TCP ports nobody listens on right now: the probes stay bound
    until all are drawn, or the system may hand the same port out twice."""
    probes = [socket.socket() for _ in range(count)]
    try:
        for probe in probes:
            probe.bind(("127.0.0.1", 0))
        return [int(probe.getsockname()[1]) for probe in probes]
    finally:
        for probe in probes:
            probe.close()


def test_serve_web_hosts_a_viewer_for_a_browser(tmp_path: Path) -> None:
    grpc_port, web_port = free_ports(2)
    live = LiveViewer("serve-web", grpc_port=grpc_port, web_port=web_port)
    sinks = Sinks(tmp_path / "live.rrd", live)
    assert not (tmp_path / "live.rrd").exists()  # nothing is touched before the run starts
    try:
        sinks.attach()
        assert sinks.watch == (
            f"http://localhost:{live.web_port}/?url=rerun%2Bhttp%3A%2F%2Flocalhost%3A"
            f"{live.grpc_port}%2Fproxy"
        )
        with urllib.request.urlopen(f"http://127.0.0.1:{live.web_port}/", timeout=30) as page:
            assert page.status == 200
        assert (tmp_path / "live.rrd").is_file()
    finally:
        sinks.stream.flush()
        sinks.stream.disconnect()


@pytest.mark.parametrize(
    ("taken", "option"), [("grpc_port", "--grpc-port"), ("web_port", "--web-port")]
)
def test_serving_on_a_port_in_use_is_refused_before_the_run(
    tmp_path: Path, taken: str, option: str
) -> None:
    with socket.socket() as holder:
        holder.bind(("0.0.0.0", 0))
        holder.listen()
        grpc_port, web_port = free_ports(2)
        ports = {"grpc_port": grpc_port, "web_port": web_port}
        ports[taken] = int(holder.getsockname()[1])
        live = LiveViewer("serve-web", **ports)
        with pytest.raises(RecordingError, match=f"port {ports[taken]}: it is in use.*{option}"):
            Recorder.open(record=tmp_path / "r.rrd", live=live)
    assert not (tmp_path / "r.rrd").exists()


def test_serving_where_an_ipv6_listener_holds_the_port_is_refused(tmp_path: Path) -> None:
    # A browser's "localhost" may be ::1: a program there would answer the address.
    try:
        holder = socket.socket(socket.AF_INET6)
        holder.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
        holder.bind(("::1", 0))
    except OSError:
        pytest.skip("no IPv6 loopback here")
    with holder:
        holder.listen()
        taken = int(holder.getsockname()[1])
        live = LiveViewer("serve-web", grpc_port=free_port(), web_port=taken)
        with pytest.raises(RecordingError, match=f"port {taken}: it is in use"):
            Recorder.open(record=tmp_path / "r.rrd", live=live)


def test_connecting_to_no_viewer_is_refused_before_the_run(tmp_path: Path) -> None:
    url = f"rerun+http://127.0.0.1:{free_port()}/proxy"
    with pytest.raises(RecordingError, match="no viewer listens at"):
        Recorder.open(record=tmp_path / "r.rrd", live=LiveViewer("connect", url=url))


def test_spawning_without_a_display_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if not sys.platform.startswith("linux"):
        pytest.skip("the display check is for Linux desktops")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RecordingError, match="--spawn needs a display"):
        Recorder.open(record=tmp_path / "r.rrd", live=LiveViewer("spawn"))


@pytest.mark.parametrize(
    ("settings", "match"),
    [
        ({"robots": True}, "robots must be a whole number"),
        ({"world_size": (0.0, 0.0)}, "world_size must be"),
        ({"world": None}, "world must be a seed or a map file path"),
        ({"coverage_target": "0.5"}, "coverage_target must be a number"),
        ({"team": {"merge": False}}, "team must be a TeamConfig"),
        ({"seed": -1}, "seed must be a whole number >= 0"),
    ],
)
def test_episode_settings_are_checked_when_made(settings, match) -> None:
    # Each was taken and failed only inside run_episode, or with a raw TypeError.
    with pytest.raises((TypeError, ValueError), match=match):
        EpisodeConfig(**settings)


def test_a_negative_seed_given_as_text_is_named_as_a_seed() -> None:
    with pytest.raises(ValueError, match="world seed must be a non-negative integer"):
        load_world("-1")
