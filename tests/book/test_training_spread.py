"""The training-seed spread: recorded per seed, read back, and added to the verdicts' intervals by the one rule."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest
from scipy.special import stdtrit

from motionlab import report, results
from motionlab.estimate import Estimate
from motionlab.report.render import chapter_findings, claims_table
from motionlab.report.spread import Run, TrainingSpread, load_spread, read_spread
from motionlab.results import FAILS, HOLDS, INCONCLUSIVE, Less, Result

DATA = "embedded-v3-n3000-s0-abc"
NOTE = f"DisCoRD; evaluate reconstruction: profile laptop, bf16, data {DATA}, split test"


def _write(folder, seed, values, profile="laptop", data=DATA, study="discord", precision="fp32"):
    record = {
        "study": study,
        "training_seed": seed,
        "profile": profile,
        "data": data,
        "cpu": "CPU",
        "precision": precision,
    }
    record |= {"commit": "abc1234", "values": values}
    path = folder / f"{study}-{profile}-{precision}-seed{seed}.json"
    path.write_text(json.dumps(record))
    return path


@pytest.fixture
def spread_folder(tmp_path):
    # sJPE flow − feed-forward per seed: -0.07, -0.01, -0.10 (the book's seed 0 is the first)
    for seed, (rf, ff) in enumerate(((1.38, 1.45), (1.40, 1.41), (1.35, 1.45))):
        _write(tmp_path, seed, {"sjpe_rf": rf, "sjpe_ff": ff, "fid_rf": 0.04 + seed * 1e-4, "fid_ff": 0.02})
    _write(tmp_path, 0, {"sjpe_rf": 9.0, "sjpe_ff": 9.0}, profile="smoke")  # another profile: not read
    return tmp_path


def test_the_spread_of_a_difference_is_t_times_the_sd_of_one_run(spread_folder):
    spread = load_spread("laptop", spread_folder)
    assert spread.data == DATA and spread.runs("discord/sjpe_rf", "discord/sjpe_ff") == [
        Run("fp32", s) for s in (0, 1, 2)
    ]
    d = spread.difference("discord/sjpe_rf", "discord/sjpe_ff")
    values = [-0.07, -0.01, -0.10]
    mean = sum(values) / 3
    sd = (sum((v - mean) ** 2 for v in values) / 2) ** 0.5
    assert d.mean == pytest.approx(mean) and d.n == 3
    assert d.half_width == pytest.approx(stdtrit(2, 0.975) * sd)  # one run's deviation, not the mean's (no / √k)
    assert len(spread.measured) == 3 and "commit abc1234" in spread.measured[0]
    assert spread.difference("discord/sjpe_rf", "discord/unknown") is None
    assert load_spread("full", spread_folder) is None


def test_fewer_than_three_seeds_give_no_spread(tmp_path):
    for seed in (0, 1):
        _write(tmp_path, seed, {"a": seed, "b": 0.0})
    assert load_spread("laptop", tmp_path).difference("discord/a", "discord/b") is None


def test_files_must_agree_on_the_data_and_not_repeat_a_seed(tmp_path):
    first = _write(tmp_path, 0, {"a": 1.0})
    other = _write(tmp_path, 1, {"a": 1.0}, data="embedded-v2-other")
    with pytest.raises(ValueError, match="measured on embedded-v2-other"):
        read_spread([first, other], "laptop")
    again = tmp_path / "copy.json"
    again.write_text(first.read_text())
    with pytest.raises(ValueError, match="recorded twice"):
        read_spread([first, again], "laptop")


def test_runs_in_two_precisions_pool_into_one_spread(tmp_path):
    # seed 0 in bf16 (one machine's book model) and seed 0 in fp32 (another's) are two runs, not a repeat
    for precision, shift in (("bf16", 0.0), ("fp32", 0.3)):
        for seed, d in enumerate((0.1, 0.2, 0.3)):
            _write(tmp_path, seed, {"a": d + shift, "b": 0.0}, precision=precision)
    spread = load_spread("laptop", tmp_path)
    assert spread.runs("discord/a", "discord/b") == [Run(p, s) for p in ("bf16", "fp32") for s in (0, 1, 2)]
    d = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    pooled = spread.difference("discord/a", "discord/b")
    sd = (sum((x - 0.35) ** 2 for x in d) / 5) ** 0.5
    assert pooled.n == 6 and pooled.mean == pytest.approx(0.35)
    assert pooled.half_width == pytest.approx(stdtrit(5, 0.975) * sd)  # the precisions' shift counts as spread
    assert str(Run("bf16", 2)) == "seed 2 (bf16)" and "discord seed 0 (bf16): CPU, bf16" in spread.measured[0]


def test_a_comparison_with_a_training_spread_widens_its_interval():
    a, b = Estimate(1.38), Estimate(1.45)
    assert report.compare(a, b).judge("lower") == HOLDS  # two points: no interval at all
    wide = report.compare(a, b, "DisCoRD", "feed-forward", quantity="sJPE", training=Estimate(-0.07, 0.12, 3))
    assert not wide.apart and wide.judge("lower") == INCONCLUSIVE
    assert "retraining moves the difference by ± 0.12 over 3 training runs" in str(wide)
    narrow = report.compare(a, b, training=Estimate(-0.07, 0.05, 3))
    assert narrow.apart and narrow.judge("lower") == HOLDS
    # the measurement's interval and the training spread add in quadrature: hypot(0.05, 0.05) = 0.0707 > 0.07
    both = report.compare(Estimate(1.38, 0.05, 5), b, training=Estimate(-0.07, 0.05, 3))
    assert not both.apart
    with pytest.raises(TypeError, match="training must be an Estimate"):
        report.compare(a, b, training=0.1)


def test_rules_use_the_spread_only_for_results_on_its_data(spread_folder):
    spread = load_spread("laptop", spread_folder)
    on_data = {
        "discord/sjpe_rf": Result("discord", "sjpe_rf", 1.38, note=NOTE),
        "discord/sjpe_ff": Result("discord", "sjpe_ff", 1.45, note=NOTE),
        "discord/fid_rf": Result("discord", "fid_rf", 0.0405, note=NOTE),
        "discord/fid_ff": Result("discord", "fid_ff", 0.0201, note=NOTE),
    }
    assert Less("discord/sjpe_rf", "discord/sjpe_ff").judge(on_data) == HOLDS  # no spread: two points
    assert Less("discord/sjpe_rf", "discord/sjpe_ff").judge(on_data, spread) == INCONCLUSIVE
    assert Less("discord/fid_rf", "discord/fid_ff").judge(on_data, spread) == FAILS  # retraining barely moves it
    elsewhere = {k: Result(r.chapter, r.key, r.value, note="data HumanML3D-abc") for k, r in on_data.items()}
    assert Less("discord/sjpe_rf", "discord/sjpe_ff").judge(elsewhere, spread) == HOLDS


def test_the_claims_table_and_the_findings_box_judge_with_the_recorded_spread(spread_folder, tmp_path, monkeypatch):
    monkeypatch.setenv(results.RESULTS_ENV, str(tmp_path / "results"))
    results.record("discord", "sjpe_rf", 1.38, note=NOTE, profile="laptop")
    results.record("discord", "sjpe_ff", 1.45, note=NOTE, profile="laptop")
    spread = load_spread("laptop", spread_folder)
    rule = "discord/sjpe_rf < discord/sjpe_ff"
    with_spread = {row.rule: row for row in claims_table("laptop", spread=spread)}[rule]
    without = {row.rule: row for row in claims_table("laptop", spread=None)}[rule]
    assert (with_spread.verdict, without.verdict) == (INCONCLUSIVE, HOLDS)
    assert "retraining moves the difference by ± 0.20 over 3 training runs" in with_spread.ours  # 4.30 × 0.046
    assert "retraining" not in without.ours
    box = {row.statement: row for row in chapter_findings("discord", "laptop", spread=spread).rows}
    assert [r.verdict for r in box.values() if "lowers sJPE" in r.statement] == [INCONCLUSIVE]
    with pytest.raises(TypeError, match="spread must be a TrainingSpread"):
        claims_table("laptop", spread=3)


def test_an_empty_spread_changes_nothing():
    spread = TrainingSpread("laptop", DATA)
    rec = {"c/a": Result("c", "a", 1.0, note=NOTE), "c/b": Result("c", "b", 2.0, note=NOTE)}
    assert Less("c/a", "c/b").judge(rec, spread) == HOLDS


def test_the_spread_table_lists_each_measured_comparison(spread_folder):
    from motionlab.report.render import spread_table

    table = spread_table(load_spread("laptop", spread_folder))
    [label] = [row for row in table.rows if "lowers sJPE" in row]
    assert table.rows[label] == {
        "training runs": 3,
        "a − b on each run": "fp32: -0.07, -0.01, -0.10",
        "± one run (t · sd)": "0.20",
    }
    assert "flow decoder − feed-forward decoder" in label
    assert f"measured on {DATA}" in table.notes[0] and "commit abc1234" in table.notes[0]
    with pytest.raises(ValueError, match="measured none"):
        spread_table(TrainingSpread("laptop", DATA))


def test_the_test_clips_interval_joins_the_verdict_where_recorded(spread_folder):
    a, b = Estimate(1.38), Estimate(1.45)
    clips = report.compare(a, b, "DisCoRD", "feed-forward", quantity="sJPE", test_set=Estimate(-0.07, 0.08, 160))
    assert clips.judge("lower") == INCONCLUSIVE
    assert "(another draw of test clips moves the difference by ± 0.080: a paired bootstrap over 160 clips)" in str(
        clips
    )
    # the three parts add in quadrature: hypot(0.05, 0.05) = 0.0707 > 0.07
    both = report.compare(a, b, training=Estimate(-0.07, 0.05, 3), test_set=Estimate(-0.07, 0.05, 160))
    assert not both.apart and report.compare(a, b, test_set=Estimate(-0.07, 0.05, 160)).apart
    assert "over 3 training runs, another draw of test clips by ± 0.050: a paired" in str(both)
    with pytest.raises(TypeError, match="test_set must be an Estimate"):
        report.compare(a, b, test_set=0.1)

    recorded = {
        "discord/sjpe_rf": Result("discord", "sjpe_rf", 1.38, note=NOTE),
        "discord/sjpe_ff": Result("discord", "sjpe_ff", 1.45, note=NOTE),
    }
    rule = Less("discord/sjpe_rf", "discord/sjpe_ff", clips="discord/sjpe_rf_minus_ff")
    assert rule.judge(recorded) == HOLDS and rule.keys == ("discord/sjpe_rf", "discord/sjpe_ff")  # not recorded: points
    wide = recorded | {"discord/sjpe_rf_minus_ff": Result("discord", "sjpe_rf_minus_ff", -0.07, ci=(-0.16, 0.02))}
    assert rule.judge(wide) == INCONCLUSIVE
    narrow = recorded | {"discord/sjpe_rf_minus_ff": Result("discord", "sjpe_rf_minus_ff", -0.07, ci=(-0.09, -0.05))}
    assert rule.judge(narrow) == HOLDS and rule.judge(narrow, load_spread("laptop", spread_folder)) == INCONCLUSIVE


def test_the_claims_table_says_how_far_the_test_clips_move_a_difference(tmp_path, monkeypatch):
    monkeypatch.setenv("MOTIONLAB_RESULTS", str(tmp_path / "results"))
    for key, value in (("sjpe_rf", 1.38), ("sjpe_ff", 1.45)):
        results.record("discord", key, value, note=NOTE, profile="laptop")
    results.record("discord", "sjpe_rf_minus_ff", Estimate(-0.07, 0.03, 160), note=NOTE, profile="laptop")
    row = next(r for r in claims_table("laptop", spread=None, budget=None).rows if "lowers sJPE" in r.statement)
    assert row.verdict == HOLDS and "another draw of test clips moves the difference by ± 0.030 (a paired" in row.ours


def test_verdicts_by_run_judge_each_recorded_run_in_place_of_the_book(tmp_path):
    from motionlab.report.render import verdicts_by_run
    from motionlab.report.rules import Claim

    _write(tmp_path, 0, {"a": 1.0, "b": 2.0}, precision="bf16")  # a < b on one machine's run ...
    _write(tmp_path, 0, {"a": 2.1, "b": 2.0}, precision="fp32")  # ... and a > b on another's
    recorded = {
        k: Result("discord", k.split("/")[1], v, note=NOTE) for k, v in (("discord/a", 1.0), ("discord/b", 2.0))
    }
    claim = Claim("DisCoRD", "Table 1", "a is lower", "", Less("discord/a", "discord/b"))
    # two runs give no spread: each run's point difference decides, and the two machines disagree
    row = verdicts_by_run(load_spread("laptop", tmp_path), recorded, [claim]).rows["DisCoRD: a is lower"]
    assert row == {"this build": HOLDS, "seed 0 (bf16)": HOLDS, "seed 0 (fp32)": FAILS, "agree": "no"}
    # a third run gives the spread (t_2 · sd of −1.0, −0.9, +0.1): it covers every run's difference, so all agree
    _write(tmp_path, 1, {"a": 1.1, "b": 2.0}, precision="bf16")
    row = verdicts_by_run(load_spread("laptop", tmp_path), recorded, [claim]).rows["DisCoRD: a is lower"]
    assert set(row.values()) == {INCONCLUSIVE, "yes"} and len(row) == 5
    other = Claim("DisCoRD", "Table 1", "c", "", Less("discord/c", "discord/b"))
    with pytest.raises(ValueError, match="measured none"):
        verdicts_by_run(load_spread("laptop", tmp_path), recorded, [other])
    elsewhere = {k: replace(r, note="DisCoRD; data real-humanml3d") for k, r in recorded.items()}
    with pytest.raises(ValueError, match="measured none"):  # the study's runs are not a real-data chapter's runs
        verdicts_by_run(load_spread("laptop", tmp_path), elsewhere, [claim])
