"""Reading the recorded fp32-vs-bf16 parity runs into chapter 98's tables."""

from __future__ import annotations

import json

import pytest

from motionlab.estimate import Estimate
from motionlab.studies import precision_parity as pp


def _record(precision: str, scale: float) -> dict:
    def cell(mean, half, n=5):
        return {"mean": mean, "ci95": half, "n": n}

    reconstruction = {
        "deterministic": ["RVQ-VAE decoder (deterministic)"],
        "rows": {
            "RVQ-VAE decoder (deterministic)": {"mpjpe_mm": cell(50 * scale, 0.0, 1), "fid": cell(0.1 * scale, 0.0, 1)},
            "RVQ tokens + DisCoRD (8 midpoint)": {"sjpe": cell(1.5, 0.1), "fid": cell(0.2, 0.05)},
        },
    }
    t2m = {
        "rows": {
            "Ground Truth": {"top1": cell(0.6, 0.01)},
            "Discrete diffusion + VQ-VAE decoder": {
                "fid": cell(30 * scale, 2.0),
                "top1": cell(0.4, 0.02),
                "top3": cell(0.7, 0.02),
            },
        }
    }
    return {
        "precision": precision,
        "profile": "laptop",
        "cpu": "Test CPU (amx_bf16)",
        "started": "2026-12-02 08:00",
        "training": {"rvq": {"cpu_seconds": 200.0 / (1 if precision == "fp32" else 1.5)}},
        "reconstruction": {"table": reconstruction},
        "t2m": {"table": t2m},
    }


def test_parity_tables_judge_each_number_by_the_one_rule(tmp_path):
    for precision, scale in (("fp32", 1.0), ("bf16", 1.2)):
        (tmp_path / f"{precision}.json").write_text(json.dumps(_record(precision, scale)))
    runs = pp.load_runs(tmp_path)
    assert pp.training_times(runs) == [("rvq", 200.0, pytest.approx(133.33, abs=0.01), pytest.approx(1.5))]
    rows = {r.what: r for r in pp.quality_rows(runs)}
    mpjpe = rows["RVQ tokenizer: reconstruction MPJPE (mm)"]
    assert mpjpe.verdict is None and mpjpe.relative_difference == pytest.approx(0.2)  # deterministic
    assert rows["DisCoRD flow decoder: sJPE"].verdict == "not distinguishable"  # the same number
    assert rows["diffusion model: text-to-motion FID"].verdict == "higher"  # 36 ± 2 against 30 ± 2
    table = pp.markdown_tables(runs)
    assert "| rvq | 200 | 133 | 1.50× |" in table and "no interval; bf16 +20.0%" in table
    assert "| 30.000 ± 2.000 | 36.000 ± 2.000 | bf16 higher (+20.0%) |" in table
    assert "| 1.500 ± 0.100 | 1.500 ± 0.100 | not distinguishable at 95% |" in table
    assert "within the 95% intervals" not in table  # the overlap rule is gone


@pytest.mark.parametrize(
    ("bf16", "verdict"),
    [
        (Estimate(36.0, 2.0, 5), "higher"),  # |6| > hypot(2, 2) = 2.83
        (Estimate(24.0, 2.0, 5), "lower"),
        (Estimate(31.0, 2.0, 5), "not distinguishable"),
        # intervals that overlap (2.5 < 2 + 2) while the difference is clear: the overlap rule said "same"
        (Estimate(33.5, 2.0, 5), "higher"),
    ],
)
def test_a_row_is_judged_by_the_interval_of_the_difference(bf16, verdict):
    row = pp.ParityRow("FID", Estimate(30.0, 2.0, 5), bf16)
    assert row.verdict == verdict


def test_a_side_without_repeats_has_no_verdict():
    row = pp.ParityRow("MPJPE", Estimate(30.0, 2.0, 5), Estimate(40.0))
    assert not row.has_interval and row.verdict is None and row.relative_difference == pytest.approx(1 / 3)


def test_a_missing_run_is_named(tmp_path):
    (tmp_path / "fp32.json").write_text(json.dumps(_record("fp32", 1.0)))
    with pytest.raises(FileNotFoundError, match="no bf16 parity run"):
        pp.load_runs(tmp_path)
