"""Where a recording goes: an ``.rrd`` file, a live viewer, or both.

A run can be written to a file (kept for ``tomosim review`` and later viewing)
and shown live at the same time, the three ways rerun's own examples offer:

* ``spawn``: start a native viewer on this machine (it needs a display) and
  stream to it;
* ``connect``: stream to a viewer already running, here or elsewhere
  (``rerun`` started by hand; its gRPC address, by default
  ``rerun+http://127.0.0.1:9876/proxy``);
* ``serve-web``: host a gRPC server and rerun's web viewer from this process,
  for a browser on any machine that reaches it (the way to watch a run on a
  machine without a display).

:class:`Sinks` builds the ``rerun.RecordingStream`` with these sinks and turns
rerun's failures into :class:`RecordingError` with one-line messages.
"""

from __future__ import annotations

import errno
import os
import shutil
import socket
import sys
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlparse

import rerun as rr

from tomosim.recording.paths import APPLICATION_ID

LIVE_MODES = ("spawn", "connect", "serve-web")
"""The ways to watch a run live."""
DEFAULT_VIEWER_URL = "rerun+http://127.0.0.1:9876/proxy"
"""Where a viewer started with plain ``rerun`` listens."""
DEFAULT_GRPC_PORT = 9876
"""Port of the gRPC server ``spawn`` and ``serve-web`` start (rerun's default)."""
DEFAULT_WEB_PORT = 9090
"""Port of the web viewer ``serve-web`` hosts (rerun's default)."""
CONNECT_TIMEOUT_S = 2.0
"""Seconds to wait when checking that a viewer listens before a run starts."""
DISPLAY_VARIABLES = ("DISPLAY", "WAYLAND_DISPLAY")
"""Environment variables of which one is set when a Linux desktop is there to show a window."""


LOW_SPACE_BYTES = 1 << 20
"""Free bytes on a disk below which a failed write is put down to a full disk."""


class RecordingError(OSError):
    """A recording could not be written or shown; the message names the file or viewer."""


def unwritable(path: Path, reason: str) -> RecordingError:
    """The error for a recording ``path`` that cannot be written, with what to do."""
    folder = path.absolute().parent
    remedy = "record elsewhere with --record PATH"
    try:
        usage = shutil.disk_usage(folder) if folder.is_dir() else None
    except OSError:  # no usage figures here: keep the reason as given
        usage = None
    # /proc and the like report a size of 0: only a real disk can be full.
    full = usage is not None and usage.total > 0 and usage.free < LOW_SPACE_BYTES
    if full or "No space left" in reason:
        reason, remedy = f"the disk is full ({reason})", f"free some space or {remedy}"
    return RecordingError(f"cannot write the recording {path}: {reason}; {remedy}")


@dataclass(frozen=True, slots=True)
class LiveViewer:
    """How to show a run live (module docstring).

    Attributes
    ----------
    mode : {"spawn", "connect", "serve-web"}
        The way to watch.
    url : str
        ``connect``: the viewer's gRPC address.
    grpc_port, web_port : int
        ``spawn`` and ``serve-web``: the ports to listen on.
    """

    mode: str
    url: str = DEFAULT_VIEWER_URL
    grpc_port: int = DEFAULT_GRPC_PORT
    web_port: int = DEFAULT_WEB_PORT

    def __post_init__(self) -> None:
        if self.mode not in LIVE_MODES:
            raise ValueError(f"live viewing mode must be one of {LIVE_MODES}, got {self.mode!r}")
        for name in ("grpc_port", "web_port"):
            port = getattr(self, name)
            if not 1 <= port <= 65535:
                raise ValueError(f"{name} must be in 1..65535, got {port}")
        if self.mode == "serve-web" and self.grpc_port == self.web_port:
            raise ValueError(
                f"grpc_port and web_port must differ (the web viewer and the run's stream "
                f"each need a port), got {self.grpc_port} for both"
            )


def has_display() -> bool:
    """Whether a native viewer window can open here (always assumed off Linux)."""
    if not sys.platform.startswith("linux"):
        return True
    return any(os.environ.get(name) for name in DISPLAY_VARIABLES)


def check_viewer_reachable(url: str) -> None:
    """Raise :class:`RecordingError` unless something listens at ``url``'s host and port."""
    parsed = urlparse(url)
    if parsed.scheme not in ("rerun", "rerun+http", "rerun+https") or not parsed.hostname:
        raise RecordingError(
            f"viewer address {url!r} is not a rerun gRPC URL such as {DEFAULT_VIEWER_URL}"
        )
    port = parsed.port or (443 if parsed.scheme == "rerun+https" else DEFAULT_GRPC_PORT)
    try:
        with socket.create_connection((parsed.hostname, port), timeout=CONNECT_TIMEOUT_S):
            pass
    except OSError as exc:
        instead = "or use --spawn" if has_display() else "or use --serve-web (no display here)"
        raise RecordingError(
            f"no viewer listens at {url} ({exc.strerror or exc}); start one with 'rerun' {instead}"
        ) from exc


def open_file_sink(path: Path) -> rr.FileSink:
    """A file sink for ``path``, after checking that the file can be created."""
    try:
        with path.open("wb"):
            pass
    except OSError as exc:
        raise unwritable(path, str(exc.strerror or exc)) from exc
    return rr.FileSink(path)


def check_record(path: Path) -> None:
    """Raise :class:`RecordingError` if ``path`` surely cannot be written (touches nothing)."""
    folder = path.absolute().parent
    if path.is_dir():
        raise RecordingError(f"cannot write the recording {path}: it is a directory")
    if not folder.is_dir():
        raise RecordingError(
            f"cannot write the recording {path}: folder {folder} does not exist; "
            "record elsewhere with --record PATH"
        )


class Sinks:
    """A recording stream and where it will go, attached only when the run starts.

    Building one checks everything that can be checked without touching the
    file (a ``connect`` viewer listens, ``spawn`` has a display, the folder
    exists) and starts a ``spawn`` viewer; :meth:`attach`, called when the
    first data is logged, creates (or empties) the file and starts serving.
    A run that fails before it starts (a world that cannot be read) leaves an
    existing recording of the same name as it was.

    Parameters
    ----------
    record : Path or None
        The ``.rrd`` file to write.
    live : LiveViewer or None
        Where to show the run live.

    Raises
    ------
    ValueError
        If there is nowhere to send the recording.
    RecordingError
        If no viewer listens at a ``connect`` address, ``spawn`` has no
        display, or the file's folder does not exist.
    """

    __slots__ = ("_attached", "_live_sinks", "live", "record", "stream", "watch")

    def __init__(self, record: Path | None, live: LiveViewer | None) -> None:
        if record is None and live is None:
            raise ValueError("a recording needs a file, a live viewer, or both")
        if record is not None:
            check_record(record)
        self.record = record
        self.live = live
        self.stream = rr.RecordingStream(APPLICATION_ID, recording_id=uuid.uuid4())
        self.stream.set_log_time_enabled(False)
        self._live_sinks: list[Any] = []
        self._attached = False
        self.watch: str | None = None
        if live is not None:
            self.watch = _live_sink(self.stream, live, self._live_sinks)

    def attach(self) -> None:
        """Create the file and connect the viewers (once; later calls do nothing).

        Raises
        ------
        RecordingError
            If the file cannot be written or a port is taken.
        """
        if self._attached:
            return
        self._attached = True
        sinks = list(self._live_sinks)
        if self.record is not None:
            sinks.append(open_file_sink(self.record))
        try:
            self.stream.set_sinks(*sinks)
        except (RuntimeError, ValueError) as exc:  # rerun's first write failed
            reason = " ".join(str(exc).split())
            if self.record is not None and "grpc" not in reason.lower():
                raise unwritable(self.record, reason) from exc
            raise RecordingError(f"cannot show the run live: {reason}") from exc
        if self.live is not None and self.live.mode == "serve-web":
            _serve_web(self.live)


PORT_OPTIONS = {"grpc_port": "--grpc-port", "web_port": "--web-port"}
"""The command-line option that chooses each port of :class:`LiveViewer`."""


def check_port_free(live: LiveViewer, name: str) -> None:
    """Raise :class:`RecordingError` when something already listens on ``live``'s port
    ``name`` (``grpc_port`` or ``web_port``), such as a viewer left running.

    rerun would otherwise log the failure and carry on, serving nothing where
    the printed address points. The check runs before the run starts; a
    program that takes the port between it and rerun's first write is not
    caught.
    """
    port = getattr(live, name)
    option = PORT_OPTIONS[name]
    probes = [(socket.AF_INET, "0.0.0.0")]
    if socket.has_ipv6:  # a browser's "localhost" may be ::1
        probes.append((socket.AF_INET6, "::"))
    for family, address in probes:
        try:
            probe = socket.socket(family, socket.SOCK_STREAM)
        except OSError:  # no such family here
            continue
        with probe:
            if sys.platform == "win32":  # there SO_REUSEADDR would share a port in use
                exclusive = getattr(socket, "SO_EXCLUSIVEADDRUSE")  # noqa: B009 (Windows only)
                probe.setsockopt(socket.SOL_SOCKET, exclusive, 1)
            else:  # ignore connections of an earlier run still closing (TIME_WAIT)
                probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6:
                probe.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            try:
                probe.bind((address, port))
            except OSError as exc:
                if exc.errno == errno.EADDRNOTAVAIL and family == socket.AF_INET6:
                    continue  # IPv6 switched off
                if exc.errno == errno.EADDRINUSE:
                    raise RecordingError(
                        f"cannot listen on port {port}: it is in use, perhaps by a rerun "
                        f"viewer still running; stop that or choose another port with {option}"
                    ) from exc
                raise RecordingError(
                    f"cannot listen on port {port} ({exc.strerror or exc}); choose another "
                    f"port with {option}"
                ) from exc


def _live_sink(stream: rr.RecordingStream, live: LiveViewer, sinks: list[Any]) -> str:
    """Add the sink of ``live`` to ``sinks``; returns what to tell the user."""
    if live.mode == "connect":
        check_viewer_reachable(live.url)
        sinks.append(rr.GrpcSink(live.url))
        return f"streaming to the viewer at {live.url}"
    if live.mode == "spawn":
        if not has_display():
            raise RecordingError(
                "--spawn needs a display to open the viewer's window (DISPLAY is not set); "
                "use --serve-web and open the printed address in a browser elsewhere"
            )
        # No port check: a viewer left open on the port is reused, as rerun intends.
        try:
            stream.spawn(port=live.grpc_port, connect=False)
        except Exception as exc:  # rerun raises its own error types when the viewer fails
            raise RecordingError(f"cannot start the rerun viewer: {exc}") from exc
        url = f"rerun+http://127.0.0.1:{live.grpc_port}/proxy"
        sinks.append(rr.GrpcSink(url))
        return "streaming to a new viewer window"
    for name in ("grpc_port", "web_port"):
        check_port_free(live, name)
    sinks.append(rr.GrpcServerSink(port=live.grpc_port))
    grpc = f"rerun+http://localhost:{live.grpc_port}/proxy"
    return f"http://localhost:{live.web_port}/?url={quote(grpc, safe='')}"


def _serve_web(live: LiveViewer) -> None:
    """Host rerun's web viewer on ``live.web_port``, pointed at the gRPC server."""
    grpc = f"rerun+http://localhost:{live.grpc_port}/proxy"
    try:
        rr.serve_web_viewer(web_port=live.web_port, open_browser=False, connect_to=grpc)
    except Exception as exc:  # a taken port raises rerun's own error type
        raise RecordingError(f"cannot serve the web viewer on port {live.web_port}: {exc}") from exc
