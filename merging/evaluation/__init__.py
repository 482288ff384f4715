"""Measuring merges against a known answer: quality indices, errors and test pairs.

:mod:`~merging.evaluation.metrics`
    The paper's matching index (eq. 31), the acceptance index, and the error
    of an estimated transform against the truth.
:mod:`~merging.evaluation.pairs`
    Pairs of windows cut from one map with a known transform between them:
    the protocol of section 4.1 of the paper.

Nothing here takes part in estimating a transform; the benchmarks and tests
use it to score what the methods return.
"""
