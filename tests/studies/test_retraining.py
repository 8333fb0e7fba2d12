"""The retraining study's figure data: each run's difference per comparison, and which comparisons a run flips."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest

from motionlab.comparison import Run
from motionlab.report.claims import Claim, Less
from motionlab.report.spread import TrainingSpread
from motionlab.studies import retraining

CLAIMS = [
    Claim("DisCoRD", "Table 1", "flow is smoother", "0.385 < 0.512", Less("discord/sjpe_rf", "discord/sjpe_ff")),
    Claim("DisCoRD", "Table 1", "flow is closer", "-", Less("discord/mpjpe_rf", "discord/mpjpe_ff")),
]


def spread(values: dict[str, dict[Run, float]]) -> TrainingSpread:
    return TrainingSpread("laptop", "embedded-test", values)


def test_each_run_differs_by_its_own_values_grouped_by_precision():
    runs = [Run("bf16", 0), Run("bf16", 1), Run("fp32", 0)]
    s = spread({"discord/sjpe_rf": dict(zip(runs, (1.0, 1.2, 1.1))), "discord/sjpe_ff": dict.fromkeys(runs, 1.5)})
    [(label, by_precision)] = retraining.run_differences(s, CLAIMS).items()  # MPJPE was not measured: left out
    assert "sJPE" in label
    assert by_precision == {"bf16": pytest.approx([-0.5, -0.3]), "fp32": pytest.approx([-0.4])}
    assert retraining.flipping(s, CLAIMS) == []


def test_a_run_on_the_other_side_of_zero_is_a_flip():
    runs = [Run("bf16", 0), Run("bf16", 1), Run("bf16", 2)]
    s = spread(
        {
            "discord/sjpe_rf": dict(zip(runs, (1.0, 1.0, 1.6))),  # the third run reads the other way
            "discord/sjpe_ff": dict.fromkeys(runs, 1.5),
            "discord/mpjpe_rf": dict.fromkeys(runs, 30.0),
            "discord/mpjpe_ff": dict.fromkeys(runs, 40.0),
        }
    )
    flips = retraining.flipping(s, CLAIMS)
    assert len(flips) == 1 and "sJPE" in flips[0]
    ax = retraining.plot_run_differences(s, CLAIMS)
    assert len(ax.get_yticks()) == 2


def test_a_study_that_measured_nothing_says_so():
    with pytest.raises(ValueError, match="measured none"):
        retraining.plot_run_differences(spread({}), CLAIMS)
