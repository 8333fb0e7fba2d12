"""Reading decoder-sweep results: estimates over sampling seeds, the best setting, budget curves."""

from __future__ import annotations

import json

import pytest

from motionlab.flow import discord_config
from motionlab.flow.sweep import best_setting, budget_curve, estimate, load_sweep, sweep_rows
from motionlab.flow.training import noise_floor
from motionlab.metrics import mean_ci


def _runs(*sjpe):
    return {"runs": [{"sjpe": s, "noise_sjpe": s / 2, "static_sjpe": s / 2, "fid": 1.0, "joint_jerk": 100.0}
                     for s in sjpe], "seed_rms": 0.1}  # fmt: skip


def _result(values_at_end):
    return {"checkpoints": [
        {"step": 10, "train_seconds": 5.0, "samplings": {"T1": _runs(3.0)}},
        {"step": 20, "train_seconds": 10.0, "samplings": values_at_end},
    ]}  # fmt: skip


@pytest.fixture
def sweep_folder(tmp_path):
    (tmp_path / "v.json").write_text(json.dumps(_result({"T1": _runs(2.0, 2.2, 2.1), "T0": _runs(1.5, 1.5)})))
    (tmp_path / "x.json").write_text(json.dumps(_result({"T1": _runs(1.2, 1.4, 1.3)})))
    return tmp_path


def test_sweep_estimates_rows_best_and_curves(sweep_folder):
    sweep = load_sweep(sweep_folder)
    assert list(sweep) == ["v", "x"]
    e = estimate(sweep["x"], "T1", "sjpe")
    assert (e.mean, e.half_width, e.n) == pytest.approx((*mean_ci([1.2, 1.4, 1.3]), 3))
    assert best_setting(sweep) == ("x", "T1")
    seconds, values = budget_curve(sweep["v"], "T1")
    assert seconds.tolist() == [5.0, 10.0] and values == pytest.approx([3.0, 2.1])
    assert budget_curve(sweep["v"], "T0")[0].tolist() == [10.0]  # a sampling scored only at the end
    rows = sweep_rows(sweep, samplings=["T1"])
    assert [(r["variant"], r["sampling"], r["steps"]) for r in rows] == [("v", "T1", 20), ("x", "T1", 20)]


def test_load_sweep_needs_results(tmp_path):
    with pytest.raises(FileNotFoundError, match="no sweep results"):
        load_sweep(tmp_path)


def test_noise_floor_binds_velocity_prediction_only():
    narrow = discord_config("laptop", width=128)
    assert noise_floor(narrow) == pytest.approx((263 - 128) / 263)
    assert noise_floor(discord_config("laptop", width=128, prediction="x")) == 0.0
