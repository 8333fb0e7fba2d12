"""One measured number with its uncertainty, and the reporting protocol: repeat an evaluation (20 times in the
papers) and report mean ± 95% interval.

:class:`Estimate` is the one carrier of such a number in the library: metrics, evaluation tables, recorded results and
the claims table all hold one, compare two with :meth:`Estimate.apart_from` (the one rule) and print one with
:func:`format_estimate` (the one formatter).

Two interval formulas, chosen by ``method``:

- ``"t"`` (the default): Student's t, ``t_{0.975, n−1} · s / √n`` with the sample std ``s`` (``ddof=1``).
  Right at any n; at the book's n = 3–5 runs it is 1.6–2.7× wider than the papers' formula.
- ``"normal"``: ``1.96 · std / √n`` with ``ddof=0``, as the papers' code prints it. Fine at their n = 20
  (4% narrower than t there), too narrow for small n. Kept to compare with the papers' tables.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

CI_METHODS = ("t", "normal")


@dataclass(frozen=True)
class Estimate:
    """A mean, its 95% half-width, the number of values behind it and a unit; prints as ``0.123 ± 0.004``.

    It unpacks like the ``(mean, half_width)`` pair older code passed around: ``mean, half = estimate``.
    A half-width of 0 means no interval (one run, or a deterministic computation): it prints the value alone.
    """

    mean: float
    half_width: float = 0.0
    n: int = 1
    unit: str | None = None

    @classmethod
    def from_values(cls, values: Sequence[float], method: str = "t", unit: str | None = None) -> Estimate:
        """Mean and 95% half-width of repeated measurements (``method``: see the module docstring)."""
        return mean_ci(values, method, unit)

    @property
    def low(self) -> float:
        return self.mean - self.half_width

    @property
    def high(self) -> float:
        return self.mean + self.half_width

    def __iter__(self) -> Iterator[float]:
        return iter((self.mean, self.half_width))

    def __getitem__(self, index: int) -> float:
        return (self.mean, self.half_width)[index]

    def __len__(self) -> int:
        return 2

    def minus(self, other: Estimate) -> Estimate:
        """``self − other`` for independent estimates: the half-widths add in quadrature."""
        return Estimate(
            self.mean - other.mean, math.hypot(self.half_width, other.half_width), min(self.n, other.n), self.unit
        )

    def apart_from(self, other: Estimate | float) -> bool:
        """Whether the 95% interval of ``self − other`` excludes 0: ``|a − b| > sqrt(h_a² + h_b²)``.

        The one rule every verdict in the library and the book uses (the claims table, the chapters' sentences).
        Not "the two intervals do not overlap": for equal widths that test works at about the 99.5% level.
        """
        other = other if isinstance(other, Estimate) else Estimate(float(other))
        return abs(self.mean - other.mean) > math.hypot(self.half_width, other.half_width)

    def excludes(self, value: float) -> bool:
        """Whether ``value`` lies outside ``mean ± half_width`` (never without an interval)."""
        return self.half_width > 0 and self.n > 1 and self.apart_from(value)

    def __format__(self, spec: str) -> str:
        """``f"{e}"`` reads like :func:`format_estimate`; ``f"{e:.3f}"`` gives fixed decimals (tables)."""
        if not spec:
            return format_estimate(self.mean, self.half_width, self.unit)
        text = format(self.mean, spec)
        if self.n > 1:  # repeated: the spread was measured, even when it is 0 (or NaN)
            text += f" ± {format(self.half_width, spec)}"
        return f"{text} {self.unit}" if self.unit else text

    def __str__(self) -> str:
        return format(self, "")


def mean_ci(values: Sequence[float], method: str = "t", unit: str | None = None) -> Estimate:
    """The :class:`Estimate` (mean, 95% half-width, n) of repeated measurements; see the module docstring for
    ``method``. With a single value the half-width is 0 (there is no spread to measure)."""
    from scipy.special import stdtrit  # Student's t quantile; scipy.stats would cost ~1 s of import

    if method not in CI_METHODS:
        raise ValueError(f"method must be one of {CI_METHODS}, got {method!r}")
    if hasattr(values, "detach"):  # a torch tensor, without importing torch here
        values = values.detach().cpu().double().numpy()
    try:
        v = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as err:
        raise ValueError(f"values must be a numeric array, got {type(values).__name__}") from err
    if not np.isfinite(v).all():
        raise ValueError("values contains NaN or inf values")
    if v.size == 0:
        raise ValueError("values is empty")
    if v.size == 1:
        return Estimate(float(v[0]), 0.0, 1, unit)
    if method == "normal":
        return Estimate(float(v.mean()), float(1.96 * v.std() / np.sqrt(v.size)), int(v.size), unit)
    half = float(stdtrit(v.size - 1, 0.975) * v.std(ddof=1) / np.sqrt(v.size))
    return Estimate(float(v.mean()), half, int(v.size), unit)


BOOTSTRAP_RESAMPLES = 2000


def paired_bootstrap(
    a: Sequence[float],
    b: Sequence[float],
    weights: Sequence[float] | None = None,
    *,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = 0,
    unit: str | None = None,
) -> Estimate:
    """``mean(a) − mean(b)`` over units measured both ways (test clips), with the 95% interval of a paired bootstrap.

    ``a[i]`` and ``b[i]`` are one unit's values under two conditions. Each resample draws the units with replacement
    and keeps the pairs together, so what the two conditions share (an easy or a hard clip) cancels. ``weights`` (one
    per unit, e.g. its frames) turn the means into weighted means, for metrics pooled over frames rather than clips.
    The half-width is half the 2.5–97.5 percentile range of the resampled differences; ``n`` is the number of units.
    """
    if not isinstance(resamples, int) or isinstance(resamples, bool) or resamples < 100:
        raise ValueError(f"resamples must be an int >= 100, got {resamples!r}")
    x, y = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (a, b))
    if x.shape != y.shape:
        raise ValueError(f"a has {x.size} values and b {y.size}: a paired bootstrap needs one pair per unit")
    w = np.ones_like(x) if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.shape != x.shape or (w < 0).any() or not w.sum() > 0:
        raise ValueError(f"weights must be {x.size} non-negative numbers, not all 0")
    if not (np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(w).all()):
        raise ValueError("a, b and weights must be finite")
    if x.size < 2:
        raise ValueError(f"a paired bootstrap needs at least 2 units, got {x.size}")
    d = x - y
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, d.size, size=(resamples, d.size))  # (R, N) unit indices
    drawn = (w[picks] * d[picks]).sum(axis=1) / np.maximum(w[picks].sum(axis=1), np.finfo(float).tiny)  # (R,)
    low, high = np.percentile(drawn, [2.5, 97.5])
    return Estimate(float((w * d).sum() / w.sum()), float(high - low) / 2.0, int(d.size), unit)


def summarize_runs(runs: Iterable[Mapping[str, float]], method: str = "t") -> dict[str, Estimate]:
    """Turn repeated evaluations ``[{"fid": .., "top1": ..}, ...]`` into one :class:`Estimate` per metric."""
    runs = list(runs)
    if not runs:
        raise ValueError("runs is empty")
    keys = list(runs[0])
    for i, r in enumerate(runs):
        if list(r) != keys:
            raise ValueError(f"run {i} has metrics {list(r)}, expected {keys}")
    return {k: mean_ci([r[k] for r in runs], method) for k in keys}


# ----------------------------------------------------------------------------------------------- formatting


def format_number(x: float, decimals: int | None = None, significant: int = 3) -> str:
    """``x`` to ``significant`` digits (or ``decimals`` places), without exponents in the usual range."""
    if not math.isfinite(x):
        return str(x)
    if decimals is None:
        size = abs(x)
        if size == 0:
            return "0"
        if size >= 10**significant:
            return f"{x:,.0f}"
        if size < 1e-3:
            return f"{x:.{significant - 1}g}"
        decimals = max(0, significant - 1 - math.floor(math.log10(size)))
    return f"{x:.{decimals}f}"


def format_estimate(
    value: float, ci: float | tuple[float, float] | None = None, unit: str | None = None, significant: int = 3
) -> str:
    """``3.62 ± 0.011``, ``25 (95% CI 3 to 53)`` or ``0.216``: a value with its 95% interval and unit, for reading.

    ``ci`` is a half-width or a ``(low, high)`` pair. The interval is shown where it has width, to two significant
    digits, with the value rounded to match; without one the value has ``significant`` digits.
    """
    if ci is None:
        low, high = value, value
    elif isinstance(ci, Sequence):
        low, high = ci
    else:
        low, high = value - ci, value + ci
    half = max(value - low, high - value)
    scale = max(abs(value), abs(low), abs(high), 1e-12)
    if not math.isfinite(half) or half <= 1e-9 * scale:  # no interval, or one of zero width: nothing to show
        text = format_number(value, significant=significant)
    else:
        decimals = min(8, max(0, 1 - math.floor(math.log10(half))))  # two significant digits of the half-width
        if abs((value - low) - (high - value)) <= 1e-6 * scale:
            text = f"{format_number(value, decimals)} ± {format_number(half, decimals)}"
        else:
            low_text, high_text = format_number(low, decimals), format_number(high, decimals)
            text = f"{format_number(value, decimals)} (95% CI {low_text} to {high_text})"
    return f"{text} {unit}" if unit else text
