"""Reporting: how a measured number becomes a sentence on a page.

One rule judges every comparison in the library and the book, :meth:`~motionlab.metrics.Estimate.apart_from` (the
95% interval of the difference excludes 0), and :func:`compare` turns a comparison into a sentence with it::

    from motionlab import report
    report.compare(flow_sjpe, ff_sjpe, "DisCoRD", "feed-forward", quantity="sJPE")
    # sJPE: DisCoRD 1.38 ± 0.02 is lower than feed-forward 1.45 ± 0.03

The claims table (:mod:`motionlab.results`) judges its orderings with the same :class:`Comparison`, so a chapter's
sentence and the verdict box at the top of its page cannot disagree. Where the training-seed study measured a
difference on other training runs (:func:`load_spread`), the verdict is the mean over those runs and this build's:
``compare(..., training=spread.other_runs(a, b, this_build()))``.
"""

from motionlab.comparison import Comparison, RunDifferences, Sentence, compare, difference, this_build, trend

from .scale import plot_training_scale, scale_changes
from .spread import TrainingSpread, load_spread

__all__ = [
    "Comparison",
    "RunDifferences",
    "Sentence",
    "TrainingSpread",
    "compare",
    "difference",
    "load_spread",
    "plot_training_scale",
    "scale_changes",
    "this_build",
    "trend",
]
