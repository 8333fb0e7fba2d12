"""Reading the recorded fp32-vs-bf16 parity runs into chapter 98's tables."""

from __future__ import annotations

import json

import pytest

from motionlab.train import precision_parity as pp


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


def test_parity_tables_compare_each_number_within_its_interval(tmp_path):
    for precision, scale in (("fp32", 1.0), ("bf16", 1.2)):
        (tmp_path / f"{precision}.json").write_text(json.dumps(_record(precision, scale)))
    runs = pp.load_runs(tmp_path)
    assert pp.training_times(runs) == [("rvq", 200.0, pytest.approx(133.33, abs=0.01), pytest.approx(1.5))]
    rows = {c.what: c for c in pp.quality_rows(runs)}
    mpjpe = rows["RVQ tokenizer: reconstruction MPJPE (mm)"]
    assert mpjpe.within_intervals is None and mpjpe.relative_difference == pytest.approx(0.2)  # deterministic
    assert rows["DisCoRD flow decoder: sJPE"].within_intervals is True
    assert rows["diffusion model: text-to-motion FID"].within_intervals is False  # 30 ± 2 vs 36 ± 2
    table = pp.markdown_tables(runs)
    assert "| rvq | 200 | 133 | 1.50× |" in table and "no interval; bf16 +20.0%" in table and "no (+20.0%)" in table


def test_a_missing_run_is_named(tmp_path):
    (tmp_path / "fp32.json").write_text(json.dumps(_record("fp32", 1.0)))
    with pytest.raises(FileNotFoundError, match="no bf16 parity run"):
        pp.load_runs(tmp_path)
