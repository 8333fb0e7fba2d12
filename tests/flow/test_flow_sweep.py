"""Reading decoder-sweep results: estimates over sampling seeds, the best setting, budget curves."""

from __future__ import annotations

import json

import pytest

from motionlab.flow import discord_config
from motionlab.flow.sweep import best_setting, budget_curve, crossing, estimate, load_sweep, sweep_rows
from motionlab.flow.training import noise_floor
from motionlab.metrics import mean_ci


def _runs(*sjpe):
    return {
        "runs": [{"sjpe": s, "noise_sjpe": s / 2, "static_sjpe": s / 2, "fid": 1.0, "joint_jerk": 100.0} for s in sjpe],
        "seed_rms": 0.1,
    }


def _result(values_at_end, budget=10.0):
    return {
        "budget_s": budget,
        "checkpoints": [
            {"step": 10, "train_seconds": 5.0, "samplings": {"T1": _runs(3.0)}},
            {"step": 20, "train_seconds": 10.0, "samplings": values_at_end},
        ],
    }


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
    narrow = discord_config("laptop", width=128, prediction="v")
    assert noise_floor(narrow) == pytest.approx((263 - 128) / 263)
    assert noise_floor(discord_config("laptop", width=128, prediction="x")) == 0.0


def test_best_setting_respects_the_budget(sweep_folder):
    (sweep_folder / "x-long.json").write_text(json.dumps(_result({"T1": _runs(0.5, 0.6, 0.7)}, budget=40.0)))
    sweep = load_sweep(sweep_folder)
    assert best_setting(sweep) == ("x-long", "T1")
    assert best_setting(sweep, max_budget=10.0) == ("x", "T1")
    with pytest.raises(ValueError, match="budget"):
        best_setting(sweep, max_budget=1.0)


def test_crossing_is_measured_between_checkpoints_or_extrapolated():
    import numpy as np

    seconds, values = np.array([100.0, 200.0, 400.0]), np.array([2.0, 1.8, 1.4])
    when, measured = crossing(seconds, values, 1.6)
    assert measured and when == pytest.approx(np.exp(np.log(200) + 0.5 * np.log(2)))  # halfway in log-time
    assert crossing(seconds, values, 2.5) == (100.0, True)
    when, measured = crossing(seconds, np.array([2.0, 1.9, 1.8]), 1.5)  # 0.1 per doubling
    assert not measured and when == pytest.approx(400.0 * 2**3)
    assert crossing(seconds, np.array([2.0, 2.1, 2.2]), 1.5) == (None, False)
    with pytest.raises(ValueError, match="two checkpoints"):
        crossing(seconds[:1], values[:1], 1.0)
