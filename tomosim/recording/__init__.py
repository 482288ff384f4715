"""Recording tomosim runs with rerun, and reading the recordings back.

The only part of tomosim that imports rerun (besides the commands that use
it): :class:`Recorder` logs a :class:`~tomosim.team.TeamSession` to an explicit
``rerun.RecordingStream`` with :func:`default_blueprint` as the viewer's
layout; :func:`read_recording` reads an ``.rrd`` file back with rerun's own
reader. Entity paths and timelines are in :mod:`tomosim.recording.paths`.
"""

from tomosim.recording.blueprint import default_blueprint
from tomosim.recording.reader import RecordedRun, Series, read_recording
from tomosim.recording.recorder import Recorder, grid_map

__all__ = [
    "RecordedRun",
    "Recorder",
    "Series",
    "default_blueprint",
    "grid_map",
    "read_recording",
]
