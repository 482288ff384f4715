"""The exploration study (what merging is worth), one idea per module.

``scripts/study_exploration.py`` is the entry point:

* :mod:`.worlds`: the worlds studied, their labels and step caps;
* :mod:`.runs`: the episodes as sweeps (:mod:`tomosim.sweep`), one results
  file per world, resumable;
* :mod:`.summary`: medians and spreads over seeds, speed-ups, the oracle's
  share, and the acceptance checks;
* :mod:`.report`: the Markdown tables; :mod:`.plots`: the PNG figures.
"""
