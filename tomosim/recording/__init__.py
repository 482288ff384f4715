"""Recording tomosim runs with rerun, and reading the recordings back.

The only part of tomosim that imports rerun (besides the commands that use
it): :class:`Recorder` logs a :class:`~tomosim.team.TeamSession` to an explicit
``rerun.RecordingStream`` (an ``.rrd`` file, a live viewer, or both:
:class:`LiveViewer`) with :func:`default_blueprint` as the viewer's layout;
:func:`read_recording` reads an ``.rrd`` file back with rerun's own reader, and
:func:`recorded_views` the layout stored in it. Entity paths and timelines are
in :mod:`tomosim.recording.paths`.
"""

from tomosim.recording.blueprint import default_blueprint
from tomosim.recording.reader import (
    RecordedRun,
    RecordedView,
    Series,
    read_recording,
    recorded_views,
)
from tomosim.recording.recorder import Recorder
from tomosim.recording.sinks import LIVE_MODES, LiveViewer, RecordingError

__all__ = [
    "LIVE_MODES",
    "LiveViewer",
    "RecordedRun",
    "RecordedView",
    "Recorder",
    "RecordingError",
    "Series",
    "default_blueprint",
    "read_recording",
    "recorded_views",
]
