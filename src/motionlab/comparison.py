"""Two estimates compared by the one rule, and the sentences that say it.

The rule: ``a`` and ``b`` differ when the 95% interval of ``a − b`` excludes 0
(:meth:`~motionlab.estimate.Estimate.apart_from`); where the training-seed study measured the same difference on
other training runs (:class:`RunDifferences`), the verdict reads their mean with this run's. Every table that offers
``.compare`` (:class:`~motionlab.viz.tables.Table`, :class:`~motionlab.evaluation.EvaluationTable`) and every claim of
:mod:`motionlab.report` judges with :func:`compare`, so a chapter's sentence and the claims table cannot disagree. It
sits on the ground floor, beside :mod:`motionlab.estimate`, because those tables live below the report layer.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from statistics import stdev
from typing import NamedTuple

from motionlab.estimate import Estimate, format_estimate

MIN_SEEDS = 3  # fewer seeds give no usable spread (t with one degree of freedom is 12.7)

LOWER, HIGHER, SAME = "lower", "higher", "not distinguishable"
HOLDS, FAILS, INCONCLUSIVE = "holds", "does not hold", "inconclusive"  # the claims table's verdicts


class Run(NamedTuple):
    """One training run of a study's models: the precision it was trained in and its seed. Seed 0 in bf16 on one CPU
    and seed 0 in fp32 on another are two runs (the book's model on each machine), and both join the spread."""

    precision: str
    seed: int

    def __str__(self) -> str:
        return f"seed {self.seed} ({self.precision})"


def this_build(precision: str | None = None) -> Run:
    """The run this build's models are: seed 0 (the book's) in ``precision`` (default: the precision this process
    trains in, :func:`motionlab.precision.network_precision`)."""
    if precision is None:
        from motionlab.precision import network_precision  # imports torch: only when asked

        precision = network_precision()
    return Run(precision, 0)


def student_t(n: int) -> float:
    """The two-sided 95% quantile of Student's t with ``n − 1`` degrees of freedom."""
    from scipy.special import stdtrit

    return float(stdtrit(n - 1, 0.975))


@dataclass(frozen=True)
class RunDifferences:
    """``a − b`` on the recorded training runs other than this build's own (``runs[i]`` gave ``values[i]``)."""

    runs: tuple[Run, ...]
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.runs) != len(self.values) or len(self.values) < MIN_SEEDS - 1:
            raise ValueError(f"need {MIN_SEEDS - 1} or more recorded runs, one value each, got {self.values}")

    def pooled(self, here: Estimate) -> Estimate:
        """The mean of ``a − b`` over these runs and this build's (``here``, with its measurement interval), with
        its 95% half-width ``hypot(t · sd / √n, h_here / √n)`` over the ``n`` runs."""
        d = (*self.values, here.mean)
        n = len(d)
        half = math.hypot(student_t(n) * stdev(d), here.half_width) / math.sqrt(n)
        return Estimate(sum(d) / n, half, n, here.unit)


class Sentence(str):
    """A generated sentence: a ``str`` that Jupyter renders as Markdown (``display(s)``, or a cell's last line)."""

    def _repr_markdown_(self) -> str:
        return str(self)


def _estimate(x: Estimate | float | Sequence[float], name: str) -> Estimate:
    if isinstance(x, Estimate):
        return x
    if isinstance(x, (int, float)) and not isinstance(x, bool):
        return Estimate(float(x))
    raise TypeError(f"{name} must be an Estimate or a number, got {type(x).__name__}")


@dataclass(frozen=True)
class Comparison:
    """``a`` against ``b``: which is lower, and whether that is beyond the noise (the 95% interval of ``a − b``).

    ``verdict`` is ``"lower"``, ``"higher"`` or ``"not distinguishable"``; :meth:`say` turns it into a sentence and
    appends the caller's reading of each outcome.

    ``training``, where measured, is ``a − b`` on the recorded training runs of the models behind the two numbers,
    other than the run these numbers come from (:meth:`motionlab.report.spread.TrainingSpread.other_runs`). Then the
    verdict is the mean difference over those runs and this one, with its interval
    (:meth:`RunDifferences.pooled`): what a model trained this way does, which every
    machine reads alike, not what one training run did. ``test_set``, where measured, is ``a − b`` paired over the
    test clips both were measured on (:func:`motionlab.estimate.paired_bootstrap`): how far drawing another test set
    moves the difference, which a deterministic measurement's own interval lacks (and every training run shares). Its
    half-width joins the interval in quadrature.
    """

    a: Estimate
    b: Estimate
    names: tuple[str, str] = ("a", "b")
    quantity: str = ""
    against_zero: bool = False  # a measured difference (a) against 0 (b): see difference()
    training: RunDifferences | None = None  # a − b on the other recorded training runs: the verdict pools them
    test_set: Estimate | None = None  # a − b paired over the test clips: the spread of drawing the test set

    @property
    def pooled(self) -> Estimate | None:
        """``a − b`` averaged over the training runs (the recorded ones and this), where ``training`` is given."""
        if self.training is None:
            return None
        here = Estimate(self.a.mean - self.b.mean, math.hypot(self.a.half_width, self.b.half_width), 1, self.a.unit)
        return self.training.pooled(here)

    @property
    def judged(self) -> Estimate:
        """The difference the verdict reads: this run's ``a − b`` (or the mean over training runs, where pooled), its
        95% half-width joined in quadrature with the test-clip interval."""
        pooled = self.pooled
        d = pooled if pooled is not None else self.a.minus(self.b)
        test_set = 0.0 if self.test_set is None else self.test_set.half_width
        return Estimate(d.mean, math.hypot(d.half_width, test_set), d.n, self.a.unit)

    @property
    def has_interval(self) -> bool:
        return self.judged.half_width > 0 or self.training is not None

    @property
    def apart(self) -> bool:
        """The one rule: the 95% interval of the difference excludes 0 (pooled over training runs where measured)."""
        return self.judged.apart_from(0.0)

    @property
    def direction(self) -> str:
        """How the difference orders ``a`` and ``b``, whatever the noise: ``"lower"``, ``"higher"`` or ``"equal"`` (the
        point estimates', or, pooled over training runs, the mean difference's)."""
        d = self.judged.mean
        return LOWER if d < 0 else HIGHER if d > 0 else "equal"

    @property
    def verdict(self) -> str:
        return self.direction if self.apart else SAME

    def judge(self, expected: str) -> str:
        """The claims table's verdict for the expectation ``"lower"`` or ``"higher"`` of ``a`` against ``b``:
        ``"holds"``, ``"does not hold"`` or ``"inconclusive"`` (an interval and the difference within it)."""
        if expected not in (LOWER, HIGHER):
            raise ValueError(f"expected must be {LOWER!r} or {HIGHER!r}, got {expected!r}")
        if self.has_interval and not self.apart:
            return INCONCLUSIVE
        return HOLDS if self.direction == expected else FAILS

    def __str__(self) -> str:
        (name_a, name_b), prefix = self.names, f"{self.quantity}: " if self.quantity else ""
        if self.against_zero:
            where = {LOWER: "below 0", HIGHER: "above 0", SAME: "not distinguishable from 0 at 95%"}[self.verdict]
            return f"{prefix}{name_a} = {self.a}, {where}"
        clips = ""  # the test-clip interval, where measured: another draw of the test set
        if self.test_set is not None:
            spread = format_estimate(self.test_set.half_width, unit=self.a.unit, significant=2)
            clips = f"another draw of test clips moves the difference by ± {spread}"
            clips += f": a paired bootstrap over {self.test_set.n} clips"
        pooled = self.pooled
        if pooled is not None:
            mean = self.judged
            runs = f"{pooled.n} training runs (this one and {pooled.n - 1} recorded)"
            word = "not distinguishable from 0 at 95%" if self.verdict == SAME else f"{name_a} is {self.verdict}"
            extra = f"; {clips}" if clips else ""
            return (
                f"{prefix}{name_a} {self.a}, {name_b} {self.b}; over {runs}, {name_a} − {name_b} = {mean}: "
                f"{word}{extra}"
            )
        clips = f" ({clips})" if clips else ""
        if self.verdict == SAME:
            return f"{prefix}{name_a} {self.a} and {name_b} {self.b} are not distinguishable at 95%{clips}"
        return f"{prefix}{name_a} {self.a} is {self.verdict} than {name_b} {self.b}{clips}"

    def say(self, lower: str = "", higher: str = "", same: str = "") -> Sentence:
        """The comparison as a sentence, followed by the caller's reading of the outcome that happened
        (``lower``, ``higher`` or ``same``, for "not distinguishable"); each reading may be empty."""
        reading = {LOWER: lower, HIGHER: higher, SAME: same}[self.verdict]
        return Sentence(f"{self}{': ' + reading if reading else ''}.")

    def _repr_markdown_(self) -> str:
        return f"{self}."


def compare(
    a: Estimate | float,
    b: Estimate | float,
    name_a: str = "a",
    name_b: str = "b",
    *,
    quantity: str = "",
    training: RunDifferences | None = None,
    test_set: Estimate | None = None,
) -> Comparison:
    """Compare two independent estimates (or plain numbers, which carry no interval) by the one rule; ``training``:
    ``a − b`` on the other recorded training runs (the verdict pools them with this one), ``test_set``: ``a − b``
    paired over the test clips, each where it was measured (see :class:`Comparison`)."""
    if training is not None and not isinstance(training, RunDifferences):
        raise TypeError(f"training must be RunDifferences (TrainingSpread.other_runs), got {type(training).__name__}")
    if test_set is not None and not isinstance(test_set, Estimate):
        raise TypeError(f"test_set must be an Estimate of a − b, got {type(test_set).__name__}")
    return Comparison(
        _estimate(a, "a"), _estimate(b, "b"), (name_a, name_b), quantity, training=training, test_set=test_set
    )


def difference(d: Estimate, name: str = "the difference", *, quantity: str = "") -> Comparison:
    """A measured (e.g. paired) difference against 0: ``verdict`` says whether it is below, above or indistinguishable
    from 0; the sentence reads ``TPS − independent = -0.034 ± 0.067, not distinguishable from 0 at 95%``."""
    return Comparison(_estimate(d, "d"), Estimate(0.0), (name, "0"), quantity, against_zero=True)


@dataclass(frozen=True)
class Trend:
    """A sequence of estimates, each neighbour compared by the one rule."""

    steps: tuple[Comparison, ...]

    @property
    def rising(self) -> bool:
        """Every point estimate above the one before (whatever the noise)."""
        return all(c.direction == LOWER for c in self.steps)

    @property
    def falling(self) -> bool:
        return all(c.direction == HIGHER for c in self.steps)

    @property
    def established(self) -> bool:
        """Monotone, and every step beyond the noise."""
        return (self.rising or self.falling) and all(c.apart for c in self.steps)

    def __str__(self) -> str:
        first = self.steps[0]
        values = [f"{first.names[0]} {first.a}"] + [f"{c.names[1]} {c.b}" for c in self.steps]
        prefix = f"{first.quantity}: " if first.quantity else ""
        shape = "rises" if self.rising else "falls" if self.falling else "is not monotone"
        if shape != "is not monotone":
            shape += " at every step" if self.established else ", but not every step is beyond the noise at 95%"
        return f"{prefix}{', '.join(values)}: it {shape}"

    def say(self, established: str = "", unclear: str = "") -> Sentence:
        """The trend as a sentence, then ``established`` or ``unclear`` as the caller reads it."""
        reading = established if self.established else unclear
        return Sentence(f"{self}{' — ' + reading if reading else ''}.")

    def _repr_markdown_(self) -> str:
        return f"{self}."


def trend(estimates: Sequence[Estimate | float], names: Sequence[str], *, quantity: str = "") -> Trend:
    """Neighbouring pairs of ``estimates`` (two or more) compared in order."""
    if len(estimates) < 2 or len(estimates) != len(names):
        raise ValueError(f"need two or more estimates with one name each, got {len(estimates)} and {len(names)}")
    steps = tuple(
        compare(a, b, na, nb, quantity=quantity)
        for a, b, na, nb in zip(estimates[:-1], estimates[1:], names[:-1], names[1:], strict=True)
    )
    return Trend(steps)
