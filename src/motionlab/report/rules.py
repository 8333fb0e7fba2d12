"""Rules: how one claim (or a chapter finding) is judged from recorded results, by the one comparison rule."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from motionlab.comparison import Run, RunDifferences, compare, this_build
from motionlab.estimate import format_estimate

from .quantities import quantity
from .spread import TrainingSpread
from .store import CHAPTERS, FAILS, HOLDS, INCONCLUSIVE, Result


def _relation(a: Result | None, b: Result | None) -> str:
    if a is None or b is None:
        return "vs"
    return "<" if a.value < b.value else ">" if a.value > b.value else "="


def describe_values(
    keys: Sequence[str], recorded: Mapping[str, Result], compare: bool = True, name: bool = True
) -> str:
    """Our numbers for ``keys`` as a phrase: ``sJPE: 3.62 ± 0.011 (flow decoder) > 2.57 (feed-forward decoder)``.

    Keys of one quantity share its name, each value followed by its condition. With ``compare``, neighbouring values
    are joined by how they compare (``<``, ``>``, ``=``); else by commas. ``name=False`` leaves out a shared quantity
    (the caller has named it). A key not recorded reads "not yet measured". Two different values never read alike:
    where three digits would print them equal, both get more.
    """
    names = [quantity(k)[0] for k in keys]
    shared = len(set(names)) == 1
    values = [recorded[k].describe() if k in recorded else "not yet measured" for k in keys]
    for i in range(1, len(keys)):
        a, b = recorded.get(keys[i - 1]), recorded.get(keys[i])
        if a is not None and b is not None and a.value != b.value and values[i - 1] == values[i]:
            for digits in range(4, 8):
                values[i - 1], values[i] = (format_estimate(r.value, r.ci, r.unit, significant=digits) for r in (a, b))
                if values[i - 1] != values[i]:
                    break
    text = ""
    for i, key in enumerate(keys):
        quantity_name, condition = quantity(key)
        if shared:
            part = f"{values[i]} ({condition})" if condition else values[i]
        else:
            part = f"{quantity_name} ({condition}) {values[i]}" if condition else f"{quantity_name} {values[i]}"
        if i:
            text += f" {_relation(recorded.get(keys[i - 1]), recorded.get(key))} " if compare else ", "
        text += part
    return f"{names[0]}: {text}" if shared and name else text


# ----------------------------------------------------------------------------------------------
# Rules: how one claim is judged from recorded results


def _studied(a: Result, b: Result, spread: TrainingSpread | None) -> bool:
    """Whether the training-seed study measured ``a`` and ``b`` as this build did: at least one on the study's data
    (its note names it), the other too, or a number no training run moves (ground truth, the same on every run)."""
    if spread is None or not (spread.applies_to(a.note) or spread.applies_to(b.note)):
        return False
    return all(spread.applies_to(r.note) or spread.run_independent(r.name, r.value) for r in (a, b))


def _build(a: Result) -> Run | None:
    """The recorded run this build repeats: seed 0 in the precision its results were recorded in (None: unknown)."""
    return this_build(a.precision) if a.precision else None


def training_difference(a: Result, b: Result, spread: TrainingSpread | None) -> RunDifferences | None:
    """``a − b`` on the recorded training runs other than the one this build repeats, where the training-seed study
    measured both as this build did; else None: the verdict rests on this build's measurement alone."""
    return spread.other_runs(a.name, b.name, _build(a)) if _studied(a, b, spread) else None


def _compare(
    a: Result, b: Result, expected: str, spread: TrainingSpread | None = None, test_set: Result | None = None
) -> str:
    """Verdict of the expectation that ``a`` is ``"lower"`` (or ``"higher"``) than ``b``, by the one rule
    (:meth:`motionlab.report.Comparison.judge`): "inconclusive" when a side carries an interval and the 95% interval
    of the difference, half-width ``sqrt(h_a² + h_b²)`` for independent estimates (``+ h_c²``, ``a − b`` paired over
    the test clips, where ``test_set`` records it), contains 0. Where ``spread`` measured the two keys, the difference
    is the mean over the training runs, the recorded ones and this build's (:mod:`motionlab.report.spread`).

    Not "when their intervals overlap": two 95% intervals can overlap while the difference is clear (for equal
    widths the overlap test works at about the 99.5% level, not 95%). Where both were measured on the same samples,
    a paired difference recorded beside them (a mechanism row) is sharper still.
    """
    clips = test_set.estimate if test_set is not None else None
    return compare(a.estimate, b.estimate, training=training_difference(a, b, spread), test_set=clips).judge(expected)


def _combine(verdicts: Sequence[str]) -> str:
    if FAILS in verdicts:
        return FAILS
    if INCONCLUSIVE in verdicts:
        return INCONCLUSIVE
    return HOLDS


@dataclass(frozen=True)
class Less:
    """``a < b``. ``clips``: the key of ``a − b`` paired over the test clips (an interval from a bootstrap), where a
    chapter records one; it joins the verdict's interval when recorded (the papers' numbers have none)."""

    a: str
    b: str
    clips: str | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.a, self.b)

    @property
    def pairs(self) -> tuple[tuple[str, str], ...]:
        """The ``(a, b)`` comparisons the rule judges (their training-seed spread widens the verdict's interval)."""
        return ((self.a, self.b),)

    def judge(self, r: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
        return _compare(r[self.a], r[self.b], "lower", spread, self.test_set(r))

    def test_set(self, r: Mapping[str, Result]) -> Result | None:
        """The recorded ``a − b`` paired over the test clips (None where the rule names none or none was recorded)."""
        return r.get(self.clips) if self.clips else None

    def describe(self) -> str:
        return f"{self.a} < {self.b}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        """Our numbers for the rule's keys, for a reader (``describe`` is the rule itself)."""
        return describe_values(self.keys, r)


@dataclass(frozen=True)
class Greater(Less):
    """``a > b``."""

    def judge(self, r: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
        return _compare(r[self.a], r[self.b], "higher", spread, self.test_set(r))

    def describe(self) -> str:
        return f"{self.a} > {self.b}"


@dataclass(frozen=True)
class Between:
    """``low < x < high``."""

    x: str
    low: str
    high: str

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.x, self.low, self.high)

    @property
    def pairs(self) -> tuple[tuple[str, str], ...]:
        return ((self.low, self.x), (self.x, self.high))

    def judge(self, r: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
        x, lo, hi = r[self.x], r[self.low], r[self.high]
        return _combine([_compare(lo, x, "lower", spread), _compare(x, hi, "lower", spread)])

    def describe(self) -> str:
        return f"{self.low} < {self.x} < {self.high}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        return describe_values((self.low, self.x, self.high), r)


@dataclass(frozen=True)
class Increasing:
    """``keys[0] < keys[1] < ...`` (each neighbouring pair judged)."""

    ordered: tuple[str, ...]

    @property
    def keys(self) -> tuple[str, ...]:
        return self.ordered

    @property
    def pairs(self) -> tuple[tuple[str, str], ...]:
        return tuple(zip(self.ordered[:-1], self.ordered[1:], strict=True))

    def judge(self, r: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
        return _combine([_compare(r[a], r[b], "lower", spread) for a, b in self.pairs])

    def describe(self) -> str:
        return " < ".join(self.ordered)

    def sentence(self, r: Mapping[str, Result]) -> str:
        return describe_values(self.ordered, r)


@dataclass(frozen=True)
class Within:
    """``|a - b| <= rel_tol * |b|``: ``a`` is comparable to the reference ``b``."""

    a: str
    b: str
    rel_tol: float

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.a, self.b)

    pairs = ()  # a relative tolerance on point values: no interval to widen

    def pooled(self, r: Mapping[str, Result], spread: TrainingSpread | None) -> tuple[float, float, int] | None:
        """``(a, b, n)``: each averaged over the ``n`` training runs (the recorded ones and this build, in the place
        of the run it repeats), where the training-seed study measured both; else None."""
        a, b = r[self.a], r[self.b]
        if not _studied(a, b, spread):
            return None
        means = [spread.mean_with(x.name, x.value, _build(a)) for x in (a, b)]
        if None in means:
            return None
        (mean_a, n), (mean_b, _) = means
        return mean_a, mean_b, n

    def judge(self, r: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
        pooled = self.pooled(r, spread)
        a, b = (r[self.a].value, r[self.b].value) if pooled is None else pooled[:2]
        return HOLDS if abs(a - b) <= self.rel_tol * abs(b) else FAILS

    def describe(self) -> str:
        return f"{self.a} within ±{self.rel_tol:.0%} of {self.b}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        text = describe_values(self.keys, r, compare=False)
        if self.a in r and self.b in r and r[self.b].value:
            text += f": {self.apart(r[self.a].value, r[self.b].value)} (the claim allows {self.rel_tol:.0%})"
        return text

    @staticmethod
    def apart(a: float, b: float) -> str:
        """How far apart ``a`` is from the reference ``b``: ``"9% apart"``, or ``"104 times apart"``."""
        gap = abs(a - b) / abs(b)
        return f"{gap:.0%} apart" if gap <= 1 or not a else f"{max(abs(a / b), abs(b / a)):.3g} times apart"


@dataclass(frozen=True)
class AtMost:
    """``x <= limit``: a measured error stays below a tolerance (the limit is a setting, never a result)."""

    x: str
    limit: float

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.x,)

    pairs = ()

    def judge(self, r: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
        return HOLDS if r[self.x].value <= self.limit else FAILS

    def describe(self) -> str:
        return f"{self.x} <= {self.limit:g}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        unit = r[self.x].unit if self.x in r else None
        return f"{describe_values(self.keys, r)} (at most {format_estimate(self.limit, unit=unit)})"


Rule = Less | Greater | Between | Increasing | Within | AtMost


@dataclass(frozen=True)
class Evidence:
    """A measured quantity that explains a verdict (the *mechanism*, not the verdict): a label and the keys shown.

    It never changes the verdict; the table prints ``label: value (condition), ...`` from the recorded numbers (each
    key's quantity and condition come from :data:`QUANTITIES`).
    """

    label: str
    keys: tuple[str, ...]

    def format(self, recorded: Mapping[str, Result]) -> str:
        return f"{self.label}: {describe_values(self.keys, recorded, compare=False, name=False)}"


@dataclass(frozen=True)
class Claim:
    """A claim of a paper, the paper's numbers, and the rule that judges it on our numbers."""

    paper: str
    source: str
    statement: str
    paper_value: str
    rule: Rule
    mechanism: tuple[Evidence, ...] = ()  # what our measurements say about *why* the claim holds or fails

    @property
    def keys(self) -> tuple[str, ...]:
        return self.rule.keys

    @property
    def mechanism_keys(self) -> tuple[str, ...]:
        return tuple(k for e in self.mechanism for k in e.keys)

    @property
    def chapter(self) -> str:
        prefix = self.keys[0].split("/", 1)[0]
        return CHAPTERS.get(prefix, prefix)
