"""The reporting protocol: repeat an evaluation (20 times in the papers) and report mean ± 95% interval.

Two interval formulas, chosen by ``method``:

- ``"t"`` (the default): Student's t, ``t_{0.975, n−1} · s / √n`` with the sample std ``s`` (``ddof=1``).
  Right at any n; at the book's n = 3–5 runs it is 1.6–2.7× wider than the papers' formula.
- ``"normal"``: ``1.96 · std / √n`` with ``ddof=0``, as the papers' code prints it. Fine at their n = 20
  (4% narrower than t there), too narrow for small n. Kept to compare with the papers' tables.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import stdtrit  # Student's t quantile; scipy.stats would cost ~1 s of import

from ._checks import as_float_array

CI_METHODS = ("t", "normal")


def mean_ci(values: Sequence[float], method: str = "t") -> tuple[float, float]:
    """``(mean, 95% half-width)`` of repeated measurements; see the module docstring for ``method``.

    With a single value the half-width is 0 (there is no spread to measure).
    """
    if method not in CI_METHODS:
        raise ValueError(f"method must be one of {CI_METHODS}, got {method!r}")
    v = as_float_array(values, "values").reshape(-1)
    if v.size == 0:
        raise ValueError("values is empty")
    if v.size == 1:
        return float(v[0]), 0.0
    if method == "normal":
        return float(v.mean()), float(1.96 * v.std() / np.sqrt(v.size))
    return float(v.mean()), float(stdtrit(v.size - 1, 0.975) * v.std(ddof=1) / np.sqrt(v.size))


@dataclass(frozen=True)
class Estimate:
    """A mean and its 95% half-width; prints as ``0.123 ± 0.004``."""

    mean: float
    half_width: float
    n: int = 1
    digits: int = 3

    @classmethod
    def from_values(cls, values: Sequence[float], digits: int = 3, method: str = "t") -> Estimate:
        mean, hw = mean_ci(values, method)
        return cls(mean, hw, len(values), digits)

    def excludes(self, value: float) -> bool:
        """Whether ``value`` lies outside ``mean ± half_width`` (never for a single run: no interval)."""
        return self.n > 1 and abs(value - self.mean) > self.half_width

    def __str__(self) -> str:
        return f"{self.mean:.{self.digits}f} ± {self.half_width:.{self.digits}f}"


def summarize_runs(runs: Iterable[Mapping[str, float]], digits: int = 3, method: str = "t") -> dict[str, Estimate]:
    """Turn repeated evaluations ``[{"fid": .., "top1": ..}, ...]`` into one :class:`Estimate` per metric."""
    runs = list(runs)
    if not runs:
        raise ValueError("runs is empty")
    keys = list(runs[0])
    for i, r in enumerate(runs):
        if list(r) != keys:
            raise ValueError(f"run {i} has metrics {list(r)}, expected {keys}")
    return {k: Estimate.from_values([r[k] for r in runs], digits, method) for k in keys}
