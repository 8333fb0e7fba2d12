"""The reporting protocol: repeat an evaluation (20 times in the papers) and report mean +- 95% CI."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ._checks import as_float_array


def mean_ci(values: Sequence[float]) -> tuple[float, float]:
    """``(mean, 1.96 * std / sqrt(n))`` of repeated measurements (``std`` with ``ddof=0``, as the papers' code).

    The half-width is the usual normal-approximation 95% interval of the mean; with a single value it is 0.
    """
    v = as_float_array(values, "values").reshape(-1)
    if v.size == 0:
        raise ValueError("values is empty")
    return float(v.mean()), float(1.96 * v.std() / np.sqrt(v.size))


@dataclass(frozen=True)
class Estimate:
    """A mean and its 95% half-width; prints as ``0.123 ± 0.004``."""

    mean: float
    half_width: float
    n: int = 1
    digits: int = 3

    @classmethod
    def from_values(cls, values: Sequence[float], digits: int = 3) -> Estimate:
        mean, hw = mean_ci(values)
        return cls(mean, hw, len(values), digits)

    def __str__(self) -> str:
        return f"{self.mean:.{self.digits}f} ± {self.half_width:.{self.digits}f}"


def summarize_runs(runs: Iterable[Mapping[str, float]], digits: int = 3) -> dict[str, Estimate]:
    """Turn repeated evaluations ``[{"fid": .., "top1": ..}, ...]`` into one :class:`Estimate` per metric."""
    runs = list(runs)
    if not runs:
        raise ValueError("runs is empty")
    keys = list(runs[0])
    for i, r in enumerate(runs):
        if list(r) != keys:
            raise ValueError(f"run {i} has metrics {list(r)}, expected {keys}")
    return {k: Estimate.from_values([r[k] for r in runs], digits) for k in keys}
