"""Photograph a recording in the real rerun viewer, as a user sees it when it opens.

Records the default ``tomosim explore`` run (or takes ``--recording``), starts
rerun's native viewer headless (no window; it renders on the CPU through
Mesa's Vulkan driver), opens the file, waits until it has loaded, checks that
every view of the recording's own layout drew without a reported error, waits
for the viewer's start-up notices to fade and for two screenshots in a row to
agree, and saves the last. It prints the time the viewer's cursor stands at,
so a picture of the wrong step cannot pass unnoticed.

Needs the Vulkan driver on a machine without a GPU::

    apt-get install -y mesa-vulkan-drivers libvulkan1
    python scripts/screenshot_viewer.py [--recording RUN.rrd] [--out docs/figures/viewer.png]

``rerun --headless --renderer vulkan --window-size 1600x1000 --screenshot-to
shot.png RUN.rrd`` takes a screenshot too, but shoots as soon as the file
starts loading, before the robots and charts have arrived; this script waits.
"""

from __future__ import annotations

import argparse
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tomosim.commands import check_writable
from tomosim.commands.script_args import positive_int, run_script

WINDOW_SIZE = "1600x1000"
"""Size of the viewer's window, and of the PNG, in pixels."""
DEFAULT_PORT = 9871
"""gRPC port of the headless viewer; not rerun's default 9876, to leave a user's viewer alone."""
MAX_PORT = 65535
"""The highest TCP port number."""
START_TIMEOUT_S = 60.0
"""Longest wait for the viewer to start listening."""
LOAD_TIMEOUT_S = 120.0
"""Longest wait for the recording to load."""
NOTICE_FADE_S = 6.0
"""Seconds the viewer shows its start-up notices (renderer, software rasterizer) for."""
POLL_S = 0.2
"""Seconds between two questions to the viewer."""
SETTLE_S = 1.0
"""Seconds between two screenshots compared to see that the view has settled."""
SETTLE_TRIES = 20
"""Most screenshots taken waiting for the view to settle."""


def record_default_run(folder: Path) -> Path:
    """Run the default ``tomosim explore`` and return its recording."""
    path = folder / "explore.rrd"
    command = [sys.executable, "-m", "tomosim.cli", "explore", "--record", str(path)]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return path


def start_viewer(port: int) -> subprocess.Popen[bytes]:
    """rerun's viewer, headless on Vulkan, listening on ``port``."""
    from tomosim.recording.reader import rerun_executable

    program = rerun_executable()
    if program is None:
        raise RuntimeError("the rerun program is missing: python -m pip install rerun-sdk")
    if port_taken(port):
        raise RuntimeError(f"port {port} is taken (another viewer?); pass --port")
    command = [
        program, "--headless", "--renderer", "vulkan", "--window-size", WINDOW_SIZE,
        "--port", str(port), "--hide-welcome-screen",
    ]  # fmt: skip
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def port_taken(port: int) -> bool:
    """Whether something listens on ``port`` here."""
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def connect(port: int, viewer: subprocess.Popen[bytes]) -> object:
    """A client of the viewer once it answers."""
    from rerun.experimental import ViewerClient

    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        if viewer.poll() is not None:
            error = viewer.stderr.read().decode() if viewer.stderr else ""
            raise RuntimeError(
                "the viewer did not start; on a machine without a GPU install the Vulkan "
                f"driver: apt-get install -y mesa-vulkan-drivers libvulkan1\n{error[-2000:]}"
            )
        try:
            client = ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy")
            client.get_state()
            return client
        except Exception:  # not listening yet
            time.sleep(POLL_S)
    raise RuntimeError(f"the viewer did not answer within {START_TIMEOUT_S:.0f} s")


def settled_screenshot(client: object) -> bytes:
    """A screenshot once two taken :data:`SETTLE_S` apart are the same (the viewer
    fetches a file's chunks as views need them, so the first frames may lack some)."""
    previous = client.take_screenshot()  # type: ignore[attr-defined]
    for _ in range(SETTLE_TRIES):
        time.sleep(SETTLE_S)
        current = client.take_screenshot()  # type: ignore[attr-defined]
        if current == previous:
            return bytes(current)
        previous = current
    raise RuntimeError(f"the view kept changing for {SETTLE_TRIES * SETTLE_S:.0f} s")


def photograph(recording: Path, out: Path, *, port: int) -> None:
    """Open ``recording`` in a headless viewer and save what it shows to ``out``."""
    viewer = start_viewer(port)
    try:
        client = connect(port, viewer)
        client.open(str(recording.resolve()))  # type: ignore[attr-defined]
        deadline = time.monotonic() + LOAD_TIMEOUT_S
        state = client.get_state()  # type: ignore[attr-defined]
        while state.loading or not state.recordings:
            if time.monotonic() > deadline:
                raise RuntimeError(f"{recording} did not load within {LOAD_TIMEOUT_S:.0f} s")
            time.sleep(POLL_S)
            state = client.get_state()  # type: ignore[attr-defined]
        time.sleep(NOTICE_FADE_S)
        state = client.get_state()  # type: ignore[attr-defined]
        problems = [
            f"{view.name}: {report.severity}: {report.summary}"
            for view in state.views
            for report in view.reports
        ]
        if problems:
            raise RuntimeError("views reported problems: " + "; ".join(problems))
        (shown,) = [r for r in state.recordings if r.store_id == state.active_recording]
        ends = {t.name: t.end for t in shown.timelines}
        print(
            f"{len(state.views)} views drew without a reported problem; the time cursor is at "
            f"{shown.current_timeline} {shown.current_time} (the recording ends at "
            f"{ends.get(shown.current_timeline or '')})"
        )
        png = settled_screenshot(client)
        out.parent.mkdir(parents=True, exist_ok=True)
        partial = out.with_name(out.name + ".partial")
        partial.write_bytes(png)
        partial.replace(out)
        print(f"screenshot: {out}")
    finally:
        viewer.terminate()
        try:
            viewer.wait(timeout=30)
        except subprocess.TimeoutExpired:
            viewer.kill()
            viewer.wait()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--recording", type=Path, help="a .rrd file (default: record one)")
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("docs/figures/viewer.png"),
        help="the PNG to write (default: docs/figures/viewer.png, the README's picture)",
    )
    parser.add_argument(
        "--port", type=positive_int, default=DEFAULT_PORT, help="the viewer's gRPC port"
    )
    args = parser.parse_args(argv)
    if args.port > MAX_PORT:
        parser.error(f"--port must be at most {MAX_PORT}, got {args.port}")
    if args.recording is not None and not args.recording.is_file():  # not a wait for the viewer
        parser.error(f"--recording {args.recording}: no such file")
    check_writable(args.out, option="--out")  # before the run and the viewer, not after
    with tempfile.TemporaryDirectory(prefix="tomosim-shot-") as folder:
        recording = args.recording or record_default_run(Path(folder))
        try:
            photograph(recording, args.out, port=args.port)
        except RuntimeError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
