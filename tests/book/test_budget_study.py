"""The M2D2M budget study read back: claim numbers per budget, each claim judged at every budget by its own rule."""

from __future__ import annotations

import json

import pytest

from motionlab.estimate import Estimate
from motionlab.evaluation import EvaluationTable
from motionlab.evaluation.multi import PAPER_METHODS, method_rows
from motionlab.evaluation.studies import budget_evaluations, budget_model_config
from motionlab.multimotion import GROUND_TRUTH_CONCAT, GROUND_TRUTH_SINGLE
from motionlab.report.budget import budget_results, load_budget, scale_statement
from motionlab.report.render import claims_table
from motionlab.results import CLAIMS, FAILS, HOLDS, MISSING
from motionlab.train.cache import config_dict

LAPTOP = 800  # the laptop profile's training steps


def _claim(key_part: str):
    return next(c for c in CLAIMS if key_part in c.rule.describe())


def _record(arm: str, seed: int, steps: int, tps_jerk: float, fid_s4: float = 12.0) -> dict:
    name = f"t2m/{arm}-seed{seed}-steps{steps}"
    methods = {
        label: {"jerk": Estimate(1.3, 0.05, 3), "fid": Estimate(10.0, 1.0, 3)}
        for label in method_rows(PAPER_METHODS, 90)
    }
    methods["TPS (T_s = 90)"] = {"jerk": Estimate(tps_jerk, 0.05, 3), "fid": Estimate(10.0, 1.0, 3)}
    rows = {
        GROUND_TRUTH_SINGLE: {"jerk": Estimate(1.6, 0.03, 3)},
        GROUND_TRUTH_CONCAT: {"jerk": Estimate(1.8, 0.05, 3)},
    }
    multi = EvaluationTable("multi", "laptop", "d", "test", 3, 0, {}, {}, ("jerk", "fid"), rows | methods)
    t2m_rows = {f"{name}, s = {s:g}": {"fid": Estimate(fid_s4 if s == 4 else 5.0, 1.0, 3)} for s in (0, 1, 2, 4)}
    t2m = EvaluationTable("t2m", "laptop", "d", "test", 3, 0, {}, {}, ("fid",), t2m_rows)
    record = {"model": name, "arm": arm, "training_seed": seed, "steps": steps, "profile": "laptop", "commit": "abc"}
    return _with_configs(record | {"multi": multi.to_json_dict(), "t2m": t2m.to_json_dict()})


def _with_configs(record: dict) -> dict:
    """``record`` with the configs experiments/m2d2m_budget.py records: the model's, and the evaluations' in the
    tables (as the code builds them now: an up-to-date record)."""
    record["configs"] = {"model": budget_model_config(record, "laptop")}
    for task, config in budget_evaluations(record["model"], "laptop").items():
        record[task]["config"] = config_dict(config)
    return record


@pytest.fixture
def study_folder(tmp_path):
    # TPS over-smooths at the laptop budget (1.2 < 1.6) and sits between the real rows at 4x (1.68)
    for arm in ("dynamic", "uniform"):
        for steps, jerk in ((800, 1.2), (3200, 1.68)):
            (tmp_path / f"{arm}-seed0-steps{steps}.json").write_text(json.dumps(_record(arm, 0, steps, jerk)))
    (tmp_path / "dynamic-seed1-steps3200.json").write_text(json.dumps(_record("dynamic", 1, 3200, 1.64)))
    return tmp_path


def test_the_study_reads_its_budgets_and_seeds(study_folder):
    study = load_budget("laptop", study_folder)
    assert study.budgets == [800, 3200] and study.laptop_steps == LAPTOP
    assert study.seeds(3200) == [0]  # seed 1 was scored in one arm only
    assert load_budget("full", study_folder) is None


def test_budget_results_give_the_claim_keys(study_folder):
    recorded = budget_results(load_budget("laptop", study_folder), 800)
    assert recorded["tps/jerk_tps"].value == 1.2 and recorded["tps/jerk_tps_uniform"].value == 1.2
    assert recorded["tps/jerk_gt_single"].value == 1.6
    assert recorded["diffusion/fid_guided"].value == 12.0 and recorded["diffusion/fid_unguided"].value == 5.0
    assert recorded["transitions/fid_dynamic"].value == recorded["transitions/fid_uniform"].value == 12.0
    assert recorded["tps/fid_ts50"].ci == pytest.approx((9.0, 11.0))
    with pytest.raises(ValueError, match="no budget of 1600 steps"):
        budget_results(load_budget("laptop", study_folder), 1600)


def test_a_claim_is_judged_at_every_budget_by_its_own_rule(study_folder):
    study = load_budget("laptop", study_folder)
    between = scale_statement(_claim("tps/jerk_gt_single < tps/jerk_tps"), study)
    assert between.verdicts == {800: FAILS, 3200: HOLDS}
    assert "holds from 3,200 training steps (4× the laptop's)" in between.sentence()
    guidance = scale_statement(_claim("diffusion/fid_guided"), study)
    assert guidance.verdicts == {800: FAILS, 3200: FAILS}
    assert "the largest budget tried, 3,200 steps (4×): FID: 12.0 ± 1.0" in guidance.sentence()
    assert scale_statement(_claim("tps/jerk_gt_concat > tps/jerk_gt_single"), study) is None  # real motions only
    assert scale_statement(_claim("discord/sjpe_rf < discord/sjpe_ff"), study) is None  # not the study's keys


def test_the_claims_table_prints_the_scale_of_each_measured_row(study_folder, tmp_path, monkeypatch):
    from motionlab import results

    monkeypatch.setenv(results.RESULTS_ENV, str(tmp_path / "results"))
    table = claims_table("laptop", budget=load_budget("laptop", study_folder), spread=None, scale=None)
    scales = {row.rule: row.scale for row in table}
    assert scales["tps/jerk_gt_single < tps/jerk_tps < tps/jerk_gt_concat"].startswith("By training budget: 800 steps")
    assert scales["discord/sjpe_rf < discord/sjpe_ff"] == ""
    assert "At other scales:" in table.html() and "Measured scale" in table.to_markdown()
    assert all(row.scale == "" for row in claims_table("laptop", budget=None, spread=None, scale=None, gpu=None))
    with pytest.raises(TypeError, match="budget must be a BudgetStudy"):
        claims_table("laptop", budget=5)


def test_budget_curves_and_their_figure(study_folder):
    import matplotlib

    matplotlib.use("Agg")
    from motionlab.report import plot_training_scale
    from motionlab.report.budget import budget_curves

    study = load_budget("laptop", study_folder)
    curves = budget_curves(study, ["tps/jerk_tps", "diffusion/fid_guided"])
    assert [n for n, _ in curves["tps/jerk_tps"]] == [800, 3200]  # the figure dodges them, the data does not
    assert [e.mean for _, e in curves["tps/jerk_tps"]] == [1.2, 1.68]
    with pytest.raises(KeyError, match="measures no 'discord/sjpe_rf'"):
        budget_curves(study, ["discord/sjpe_rf"])
    (ax,) = plot_training_scale({"transition Jerk": ["tps/jerk_tps", "tps/jerk_gt_single"]}, budget=study)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["TPS", "real single motions"]
    assert len(ax.lines) >= 3  # two curves and the laptop's budget
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1×", "4×"]  # 800 and 3,200 steps
    with pytest.raises(ValueError, match="need as many axes"):
        plot_training_scale({"a": ["tps/jerk_tps"], "b": ["tps/jerk_tps"]}, budget=study, axes=[ax])
    with pytest.raises(ValueError, match="need a budget study or a scale study"):
        plot_training_scale({"a": ["tps/jerk_tps"]})


def test_budgets_in_another_precision_are_labelled_with_it(study_folder):
    import matplotlib

    matplotlib.use("Agg")
    from motionlab.report import plot_training_scale

    study = load_budget("laptop", study_folder)
    assert study.precision(800) == "fp32" and not study.mixed_precision  # records without the field are fp32
    assert "(4×)" in scale_statement(_claim("diffusion/fid_guided"), study).sentence()
    for arm in ("dynamic", "uniform"):  # the 3,200-step models trained in bf16 (another CPU, say)
        path = study_folder / f"{arm}-seed0-steps3200.json"
        path.write_text(json.dumps(json.loads(path.read_text()) | {"precision": "bf16"}))
    study = load_budget("laptop", study_folder)
    assert study.precision(3200) == "bf16" and study.mixed_precision  # seed 1 (fp32) is in one arm: not judged
    sentence = scale_statement(_claim("diffusion/fid_guided"), study).sentence()
    assert "800 steps (1×, fp32): does not hold; 3,200 steps (4×, bf16)" in sentence
    (ax,) = plot_training_scale({"FID": ["diffusion/fid_guided"]}, budget=study)
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1×\nfp32", "4×\nbf16"]


def test_the_eta_axis_takes_eta_0_and_the_paper_s_from_the_budget_study(study_folder, tmp_path):
    from motionlab.report.budget import load_eta_axis

    etas = tmp_path / "eta"
    etas.mkdir()
    for eta, jerk in ((2.0, 1.1), (8.0, 1.0)):
        record = _record("dynamic", 0, LAPTOP, jerk, fid_s4=20.0 + eta) | {"eta": eta, "model": f"t2m/eta{eta:g}"}
        record["t2m"]["rows"] = {
            k.replace("t2m/dynamic-seed0-steps800", f"t2m/eta{eta:g}"): v for k, v in record["t2m"]["rows"].items()
        }
        (etas / f"eta{eta:g}.json").write_text(json.dumps(_with_configs(record)))
    axis = load_eta_axis("laptop", etas, load_budget("laptop", study_folder))
    assert axis.etas == [0.0, 0.5, 2.0, 8.0]
    columns = axis.columns()
    assert {eta: e.mean for eta, e in columns["FID ↓ (s = 4)"].items()} == {0.0: 12.0, 0.5: 12.0, 2.0: 22.0, 8.0: 28.0}
    assert columns["TPS transition Jerk"][8.0].mean == 1.0 and columns["TPS transition Jerk"][0.5].mean == 1.2
    assert load_eta_axis("full", etas) is None


def test_a_budget_measured_with_other_configs_is_set_aside(study_folder):
    """A budget trained with another model config (a wider network, another schedule) or scored with another
    evaluation is another model: it joins no curve and no scale line, and the study says which file and why."""
    path = study_folder / "uniform-seed0-steps3200.json"
    record = json.loads(path.read_text())
    record["configs"]["model"]["transformer"]["d_model"] *= 2
    record["multi"]["config"]["instances"] = 8
    path.write_text(json.dumps(record))
    legacy = study_folder / "dynamic-seed1-steps3200.json"
    legacy.write_text(json.dumps({k: v for k, v in json.loads(legacy.read_text()).items() if k != "configs"}))
    study = load_budget("laptop", study_folder)
    assert sorted(study.records) == [("dynamic", 0, 800), ("dynamic", 0, 3200), ("uniform", 0, 800)]
    assert study.budgets == [800]  # 3,200 steps lost its uniform arm
    changed, missing = sorted(study.set_aside, key=lambda line: not line.startswith("uniform"))
    assert "model.transformer.d_model" in changed and "multi.instances" in changed
    assert missing.startswith("dynamic-seed1-steps3200.json") and "without its configs" in missing
    for path in study_folder.glob("*.json"):  # now every file measured other models: as if none were recorded
        path.write_text(json.dumps({k: v for k, v in json.loads(path.read_text()).items() if k != "configs"}))
    with pytest.warns(UserWarning, match="every record in"):
        assert load_budget("laptop", study_folder) is None


def test_the_recorded_budgets_measured_the_books_models_and_evaluations():
    """Every budget and η file under book/data/ was trained and scored as the code would now; a change to the laptop
    text-to-motion model or to chapter 07's or 09's evaluation sizes fails here until the study is recorded again."""
    from motionlab.report.budget import load_eta_axis

    study, axis = load_budget("laptop"), load_eta_axis("laptop")
    assert study is not None and axis is not None
    assert not study.set_aside and not axis.set_aside, "\n".join(study.set_aside + axis.set_aside)
    assert len(study.records) >= 18 and {800, 3200, 8000} <= set(study.budgets)


def _scale_study(values: dict[str, tuple[float, float]], multiples=(10.0, 30.0)):
    """A scale study with the same ``values`` (key -> (mean, half-width)) at each multiple, trained on an H200."""
    from motionlab.report.scale import ScaleStudy

    records = {
        ("m2d2m", m): {
            "group": "m2d2m",
            "multiple": m,
            "device": "NVIDIA H200",
            "precision": "bf16",
            "values": {k: {"mean": mean * (1 + 0.01 * i), "half_width": half} for k, (mean, half) in values.items()},
        }
        for i, m in enumerate(multiples)
    }
    return ScaleStudy("laptop", records)


def test_one_figure_draws_the_budget_line_the_scale_points_and_this_build(study_folder):
    import matplotlib

    matplotlib.use("Agg")
    from motionlab.report import plot_training_scale

    budget = load_budget("laptop", study_folder)
    scale = _scale_study({"tps/jerk_tps": (1.5, 0.05), "tps/jerk_gt_single": (1.6, 0.03)})
    panel = {"transition Jerk": ["tps/jerk_tps", "tps/jerk_gt_single"]}
    (ax,) = plot_training_scale(panel, budget=budget, scale=scale)
    diamonds = [line for line in ax.lines if line.get_marker() == "D" and len(line.get_xdata())]
    assert len(diamonds) == 1  # TPS's; the real motions' Jerk does not depend on training
    assert list(diamonds[0].get_ydata()) == [1.5, 1.5 * 1.01]
    assert diamonds[0].get_xdata()[0] == pytest.approx(10 * 0.98 * 1.06)  # 10x samples, dodged beside the budget
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1×", "4×", "10×", "30×"]
    assert [t.get_text() for t in ax.get_legend().get_texts()][-1] == "scale study (NVIDIA H200, bf16)"
    assert ax.get_xlabel() == "training samples (× the laptop's, dashed)"

    this_build = budget_results(budget, LAPTOP)
    (ax,) = plot_training_scale({"transition Jerk": ["tps/jerk_tps"]}, scale=scale, this_build=this_build)
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1×", "10×", "30×"]
    here = [line for line in ax.lines if line.get_marker() == "o"]
    assert list(here[0].get_xdata()) == [1.0] and list(here[0].get_ydata()) == [1.2]
    assert [t.get_text() for t in ax.get_legend().get_texts()][-2:] == ["scale study (NVIDIA H200, bf16)", "this build"]
    with pytest.raises(KeyError, match="recorded no 'discord/sjpe_rf'"):
        plot_training_scale({"sJPE": ["discord/sjpe_rf"]}, scale=scale)


def test_a_verdict_path_says_each_run_of_equal_verdicts_once():
    from motionlab.report.scale import verdict_path

    assert verdict_path("holds", []) == "holds here"
    assert verdict_path("inconclusive", [(10, "holds"), (30, "does not hold")]) == (
        "inconclusive here, holds at 10×, does not hold at 30×"
    )
    assert verdict_path("does not hold", [(10, "does not hold"), (30, "holds"), (100, "holds")]) == (
        "does not hold here and at 10×, holds at 30× and 100×"
    )
    assert verdict_path("holds", [(10, "holds"), (30, "holds"), (100, "inconclusive")]) == (
        "holds here and at 10× and 30×, inconclusive at 100×"
    )
    assert verdict_path("holds", [(10, "inconclusive"), (30, "inconclusive"), (100, "inconclusive")]) == (
        "holds here, inconclusive at 10×, 30× and 100×"
    )


def test_a_chapter_says_in_one_sentence_where_its_verdicts_change_with_scale():
    from types import SimpleNamespace

    from motionlab.report import scale_changes

    guidance = _claim("diffusion/fid_guided")  # guidance lowers FID: fid_guided < fid_unguided
    rows = [SimpleNamespace(verdict=FAILS if c is guidance else HOLDS) for c in CLAIMS]
    none = scale_changes(rows, None, "diffusion")
    assert "no point for this chapter's claims yet" in none and none.count(".") == 1
    lower = _scale_study({"diffusion/fid_guided": (4.0, 0.5), "diffusion/fid_unguided": (6.0, 0.5)})
    sentence = scale_changes(rows, lower, "diffusion")
    assert sentence.startswith("At 10×, 30× the laptop's training samples (NVIDIA H200, bf16), its one verdict changes")
    assert "does not hold here, holds at 10× and 30×." in sentence
    higher = _scale_study({"diffusion/fid_guided": (8.0, 0.5), "diffusion/fid_unguided": (6.0, 0.5)})
    assert "no verdict of this chapter changes (1 claim judged)" in scale_changes(rows, higher, "diffusion")
    assert "no point" in scale_changes(rows, higher, "tps")  # the study measured none of chapter 09's keys
    both = _scale_study(
        {k: (4.0, 0.5) for k in ("discord/fid_rf", "discord/sjpe_ff")}
        | {k: (6.0, 0.5) for k in ("discord/fid_ff", "discord/sjpe_rf")}
    )
    assert "1 of 2 verdicts changes: “Decoding the same tokens" in scale_changes(rows, both, "discord")
    unmeasured = [SimpleNamespace(verdict=MISSING) for _ in CLAIMS]
    assert "this build has not measured them" in scale_changes(unmeasured, higher, "diffusion")
    with pytest.raises(ValueError, match="no claim reads chapter 'nothing'"):
        scale_changes(rows, higher, "nothing")
