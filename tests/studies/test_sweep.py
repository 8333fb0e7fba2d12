"""Reading decoder-sweep results: estimates over sampling seeds, the best setting, budget curves, and the tables and
sentences chapter 05 shows them with."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from motionlab.flow import discord_config
from motionlab.flow.training import noise_floor
from motionlab.metrics import mean_ci
from motionlab.models import xpred_config
from motionlab.studies.sweep import (
    FEED_FORWARD,
    GROUND_TRUTH,
    best_setting,
    budget_curve,
    crossing,
    crossing_sentence,
    estimate,
    load_sweep,
    longest_run,
    matches_setting,
    sampling_of,
    settings_table,
    sweep_findings,
    sweep_rows,
    sweep_table,
)


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


def _study(sweep_folder):
    sweep = load_sweep(sweep_folder)
    for name, result in sweep.items():  # what the sweep script writes beside the checkpoints
        result.update(
            variant=name,
            overrides={"prediction": name},
            clips=5,
            dataset="data-1",
            config={"train_steps": 20, "batch_size": 32},
            feed_forward={"sjpe": 1.25, "noise_sjpe": 0.6, "static_sjpe": 0.65, "fid": 0.5, "joint_jerk": 90.0},
            ground_truth={"sjpe": 0.0, "noise_sjpe": 0.0, "static_sjpe": 0.0, "fid": float("nan"), "joint_jerk": 80.0},
        )
    return sweep


def test_sweep_table_rows_references_and_notes(sweep_folder):
    table = sweep_table(_study(sweep_folder))
    assert table.labels == ["v, T1", "v, T0", "x, T1", FEED_FORWARD, GROUND_TRUTH]
    assert table.columns == ("steps", "sJPE", "Noise sJPE", "Static sJPE", "FID", "joint jerk (m/s³)", "seed spread")
    assert table.cell("x, T1", "sJPE") == estimate(_study(sweep_folder)["x"], "T1", "sjpe")
    assert table.cell("x, T1", "steps") == 20 and table.cell("x, T1", "joint jerk (m/s³)") == 100.0
    assert table.cell(GROUND_TRUTH, "FID") is None and table.cell(FEED_FORWARD, "seed spread") == 0.0
    markdown = table.to_markdown()
    assert "| x, T1 | 20 | 1.30 ± 0.25 |" in markdown and "over 3 sampling seeds" in markdown
    assert f"saw {481_896 * 768 / (20 * 32):,.0f}× more windows" in markdown
    small = sweep_table(_study(sweep_folder), samplings=["T0"], columns=("minutes", "sjpe"), references=False)
    assert (
        small.labels == ["v, T0"] and small.columns == ("minutes", "sJPE") and small.cell("v, T0", "minutes") == 10 / 60
    )
    with pytest.raises(ValueError, match="unknown sweep columns"):
        sweep_table(_study(sweep_folder), columns=("sJPE",))
    with pytest.raises(ValueError, match="none of the variants"):
        sweep_table(_study(sweep_folder), variants=["w"])
    with pytest.raises(ValueError, match="no \\(variant, sampling\\)"):
        sweep_table(_study(sweep_folder), samplings=["T9"])


def test_sweep_findings_compare_rows_by_the_one_rule(sweep_folder):
    table = sweep_table(_study(sweep_folder))
    pairs = [("x, T1", "v, T1", "x instead of v"), ("v, T0", "v, T1", "temperature 0"), ("w, T1", "v, T1", "absent")]
    said = sweep_findings(table, pairs, columns=("sJPE", "FID"))
    lines = str(said).splitlines()
    assert len(lines) == 2  # the pair the sweep did not run is left out
    assert lines[0].startswith("- x instead of v: sJPE: x, T1 1.30 ± 0.25 is lower than v, T1 2.10 ± 0.25")
    assert "FID: x, T1 1.00 and v, T1 1.00 are not distinguishable at 95%" in lines[0]
    assert lines[1].startswith("- temperature 0: sJPE: v, T0 1.50 is lower than") and said._repr_markdown_() == said


def test_the_setting_a_config_samples_and_trains_with(sweep_folder):
    study = _study(sweep_folder)
    x = discord_config("laptop", prediction="x", temperature=0.0)
    assert sampling_of(x) == "T0" and sampling_of(discord_config("smoke")) == "T1"
    assert sampling_of(discord_config("laptop", prediction="x", temperature=0.5, final_prediction=True)) == "T0.5-final"
    assert sampling_of(discord_config("smoke", spacing="data_dense")) == "T1-dense"
    assert matches_setting(x, study["x"], "T0") and not matches_setting(x, study["v"], "T0")
    assert not matches_setting(x, study["x"], "T1")
    laptop = xpred_config("laptop", None)  # the committed sweep's winner, as study s1 asserts: the lever
    winner = load_sweep(Path(__file__).resolve().parents[2] / "book" / "data" / "discord_sweep" / "embedded-v2")
    variant, sampling = best_setting(winner, max_budget=min(r["budget_s"] for r in winner.values()))
    assert matches_setting(laptop, winner[variant], sampling)


def test_crossing_sentence_says_measured_extrapolated_or_none(sweep_folder):
    result = _study(sweep_folder)["v"]  # sJPE 3.0 after 5 s, 2.1 after 10 s
    measured = crossing_sentence(result, "T1", 2.5)
    assert "falls below the feed-forward decoder's (2.500)" in measured and "(measured, between two" in measured
    guessed = crossing_sentence(result, "T1", 1.0, "sjpe")
    assert "stays above" in guessed and "an extrapolation, not a measurement" in guessed
    result["checkpoints"][-1]["samplings"]["T1"] = _runs(3.5)  # rising: no crossing in sight
    assert crossing_sentence(result, "T1", 1.0).endswith("no crossing in sight.")
    assert "`v` at T1" in crossing_sentence(result, "T1", 1.0)


def test_settings_table_sets_a_run_beside_the_paper():
    table = settings_table(discord_config("smoke"))
    assert table.columns == ("this run", "DisCoRD (Table A)")
    assert table.cell("parameters", "DisCoRD (Table A)") == "66.9 M"
    assert table.cell("steps (warm-up)", "DisCoRD (Table A)") == "481,896 (48,190)"
    assert table.cell("decode default", "DisCoRD (Table A)") == "15 midpoint steps (30 evaluations)"
    assert table.cell("decode default", "this run") == "4 euler steps (4 evaluations)"


def test_longest_run_picks_the_largest_budget_of_a_prediction_target():
    study = {
        "v-short": {"config": {"prediction": "v"}, "budget_s": 600.0},
        "x-long": {"config": {"prediction": "x"}, "budget_s": 2400.0},
        "v-long": {"config": {"prediction": "v"}, "budget_s": 2400.0},
        "x-short": {"config": {"prediction": "x"}, "budget_s": 600.0},
    }
    assert longest_run(study) == "x-long"  # a tie goes to the first in the study's order
    assert longest_run(study, prediction="v") == "v-long"
    assert longest_run(study, prediction="x") == "x-long"
    with pytest.raises(ValueError, match="predicts 'eps'"):
        longest_run(study, prediction="eps")


def test_estimate_names_the_samplings_a_run_scored(sweep_folder):
    study = load_sweep(sweep_folder)
    assert estimate(study["v"], "T0", "sjpe").mean == pytest.approx(1.5)
    with pytest.raises(KeyError, match="did not score sampling 'T0.5'; it scored T1, T0"):
        estimate(study["v"], "T0.5", "sjpe")


def _sweep_script():
    """experiments/discord_sweep.py as a module (its sampling choice and argument checks, without training)."""
    script = Path(__file__).resolve().parents[2] / "experiments" / "discord_sweep.py"
    spec = importlib.util.spec_from_file_location("discord_sweep_experiment", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_sweep_scores_the_samplings_it_is_given():
    sweep = _sweep_script()
    every_v = sweep.samplings_for("v")
    assert "T1" in every_v and not any(s.get("final_prediction") for s in every_v.values())
    assert len(sweep.samplings_for("x")) == len(sweep.SAMPLINGS)  # only an x-predicting decoder has the final x̂1
    assert list(sweep.samplings_for("v", ["T0", "T1", "T1-final"])) == ["T0", "T1"]
    assert list(sweep.samplings_for("x", ["T1-final"])) == ["T1-final"]


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["v", "--samplings", "T2"], "unknown sampling"),
        (["v", "--samplings", "T1-final"], "none of --samplings"),
    ],
)
def test_the_sweep_refuses_samplings_it_cannot_score(arguments, message, capsys):
    with pytest.raises(SystemExit) as stop:
        _sweep_script().main(arguments)
    assert stop.value.code == 2 and message in capsys.readouterr().err
