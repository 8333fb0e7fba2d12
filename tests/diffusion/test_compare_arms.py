"""``compare_arms``: chapter 08's dynamic-vs-uniform comparison with the training variance measured in the chapter (its
own seed replicates) or read from the training-seed study (seed 0 alone in the chapter)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import stdtrit

from motionlab.comparison import Run
from motionlab.estimate import Estimate, mean_ci
from motionlab.evaluation.t2m import compare_arms, seed_replica
from motionlab.report.spread import TrainingSpread


class _Table:
    """What compare_arms reads of an EvaluationTable: per-row estimates and per-repeat samples."""

    def __init__(self, samples: dict[str, dict[str, list[float]]]):
        self.samples = samples

    def estimate(self, row: str, metric: str) -> Estimate:
        return mean_ci(self.samples[row][metric])

    def paired(self, a: str, b: str, metric: str) -> Estimate:
        return mean_ci(np.subtract(self.samples[a][metric], self.samples[b][metric]))


def _table(seeds, fid: dict[tuple[str, int], list[float]]) -> _Table:
    return _Table(
        {
            seed_replica(arm, s): {"fid": fid[(arm, s)], "top3": [0.5 + 0.01 * s] * 3}
            for arm in ("uniform", "dynamic")
            for s in seeds
        }
    )


def test_with_replicates_in_the_table_the_training_variance_is_t_over_the_seeds():
    fid = {
        ("dynamic", 0): [10.0, 11.0, 12.0],
        ("uniform", 0): [12.0, 12.5, 13.0],
        ("dynamic", 1): [13.0, 13.0, 13.0],
        ("uniform", 1): [11.0, 11.5, 12.0],
        ("dynamic", 2): [9.0, 9.5, 10.0],
        ("uniform", 2): [10.0, 10.0, 10.0],
    }
    arms = compare_arms(_table((0, 1, 2), fid), (0, 1, 2))
    assert arms.fid["dynamic"].mean == pytest.approx(np.mean([11.0, 13.0, 9.5]))
    assert arms.fid["dynamic"].n == 3  # one value per training seed
    per_seed = [11.0 - 12.5, 13.0 - 11.5, 9.5 - 10.0]
    assert arms.training == mean_ci(per_seed)
    assert arms.same_seed == mean_ci([-2.0, -1.5, -1.0])
    assert (arms.gap_label, arms.gap_source) == ("seed 1 − seed 0", "paired per repeat")
    assert arms.seed_gaps["uniform"] == mean_ci([-1.0, -1.0, -1.0])
    assert "trained and scored here" in arms.source


def test_with_seed_0_alone_the_study_supplies_the_other_runs(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PRECISION", "fp32")  # this build repeats the study's fp32 seed 0, on any CPU
    fid = {("dynamic", 0): [10.0, 11.0, 12.0], ("uniform", 0): [12.0, 12.5, 13.0]}
    study = {
        "transitions/fid_dynamic": {Run("fp32", 0): 11.0, Run("fp32", 1): 13.0, Run("fp32", 2): 9.5},
        "transitions/fid_uniform": {Run("fp32", 0): 12.5, Run("fp32", 1): 11.5, Run("fp32", 2): 10.0},
    }
    spread = TrainingSpread("laptop", "embedded-test", study)
    arms = compare_arms(_table((0,), fid), (0,), spread)
    assert arms.fid["uniform"] == mean_ci([12.0, 12.5, 13.0])  # the model's repeats, not a mean over seeds
    same = mean_ci([-2.0, -1.5, -1.0])
    # seed 0 here takes the study's seed 0's place: its paired difference and the study's seeds 1 and 2
    d = np.array([same.mean, 13.0 - 11.5, 9.5 - 10.0])
    assert arms.same_seed == same
    assert arms.training.mean == pytest.approx(d.mean()) and arms.training.n == 3
    half = math.hypot(stdtrit(2, 0.975) * d.std(ddof=1), same.half_width) / math.sqrt(3)
    assert arms.training.half_width == pytest.approx(half)  # the mean's interval, seed 0's own over √n
    assert (arms.gap_label, arms.gap_source) == ("seed 1 − seed 0", "the training-seed study's numbers")
    assert arms.seed_gaps == {"uniform": Estimate(11.5 - 12.5), "dynamic": Estimate(13.0 - 11.0)}
    assert "mean over 3 training runs" in arms.source and "seed 2 (fp32)" in arms.source
    assert "seed 0 (fp32)" not in arms.source


def test_without_replicates_or_study_there_is_no_training_variance(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PRECISION", "fp32")
    fid = {("dynamic", 0): [10.0, 11.0, 12.0], ("uniform", 0): [12.0, 12.5, 13.0]}
    too_few = TrainingSpread(
        "laptop",
        "x",
        {"transitions/fid_dynamic": {Run("fp32", 0): 1.0}, "transitions/fid_uniform": {Run("fp32", 0): 2.0}},
    )
    for spread in (None, too_few):
        arms = compare_arms(_table((0,), fid), (0,), spread)
        assert arms.training is None and arms.seed_gaps == {} and arms.gap_label == arms.gap_source == ""
        assert arms.same_seed == mean_ci([-2.0, -1.5, -1.0])


@pytest.mark.parametrize("seeds", [(), (1, 2), (0, 0)])
def test_seeds_must_start_with_0_and_be_distinct(seeds):
    with pytest.raises(ValueError, match="start with 0"):
        compare_arms(_table((0,), {("dynamic", 0): [1.0], ("uniform", 0): [1.0]}), seeds)


def test_a_seed_gap_across_two_precisions_names_both_runs(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PRECISION", "fp32")
    fid = {("dynamic", 0): [10.0, 11.0, 12.0], ("uniform", 0): [12.0, 12.5, 13.0]}
    runs = (Run("bf16", 0), Run("fp32", 0), Run("fp32", 1))
    study = {
        "transitions/fid_dynamic": dict(zip(runs, (11.0, 13.0, 9.5), strict=True)),
        "transitions/fid_uniform": dict(zip(runs, (12.5, 11.5, 10.0), strict=True)),
    }
    arms = compare_arms(_table((0,), fid), (0,), TrainingSpread("laptop", "embedded-test", study))
    assert arms.gap_label == "seed 0 (fp32) − seed 0 (bf16)"
    assert arms.seed_gaps["dynamic"] == Estimate(13.0 - 11.0)
