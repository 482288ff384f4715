"""The paper's comparison (Tables 2 and 3, Figures 3-5, 7, 8), one idea per module.

``scripts/reproduce_paper.py`` is the entry point; it runs these in order:

* :mod:`.contenders`: the methods compared (the tables' columns);
* :mod:`.cases`: the pairs of maps of each row, with their truth, and
  :mod:`.references`: the reference transforms of the Exp. rows;
* :mod:`.runner`: every method on every pair, rows appended to ``rows.csv``;
* :mod:`.summary`, :mod:`.tables`, :mod:`.discussion`, :mod:`.report`: the
  Markdown report, beside the paper's own figures (:mod:`.paper_values`);
* :mod:`.figures`, :mod:`.sinogram_figures`: the PNG figures, through
  :mod:`.plotting` (matplotlib is optional).

The pairs are built and the methods are called through :mod:`merging`
(:mod:`merging.evaluation.pairs`, :mod:`merging.evaluation.metrics`, :mod:`merging.warp`,
:mod:`merging.paper`); nothing here re-implements them.
"""
