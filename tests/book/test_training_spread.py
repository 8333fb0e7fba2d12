"""The training-seed study: recorded per run, read back, and pooled with this build's run by the one rule."""

from __future__ import annotations

import functools
import json
from dataclasses import replace

import pytest
from scipy.special import stdtrit

from motionlab import report, results
from motionlab.comparison import Run, RunDifferences, this_build
from motionlab.estimate import Estimate
from motionlab.evaluation.studies import config_changes, study_configs, study_plan
from motionlab.report.render import chapter_findings, claims_table
from motionlab.report.spread import TrainingSpread, load_spread, read_spread
from motionlab.results import FAILS, HOLDS, INCONCLUSIVE, Less, Result

DATA = "embedded-v3-n3000-s0-abc"
NOTE = f"DisCoRD; evaluate reconstruction: profile laptop, bf16, data {DATA}, split test"


@functools.cache
def _configs(study: str, profile: str) -> str:
    return json.dumps(study_configs(study, profile))


def _write(folder, seed, values, profile="laptop", data=DATA, study="discord", precision="fp32", configs=None):
    """A study file as experiments/training_seeds.py writes it; ``configs`` None: the code's own (an up-to-date run)."""
    record = {
        "study": study,
        "training_seed": seed,
        "profile": profile,
        "data": data,
        "cpu": "CPU",
        "precision": precision,
    }
    configs = json.loads(_configs(study, profile)) if configs is None else configs
    record |= {"commit": "abc1234", "configs": configs, "values": values}
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


def _pooled_half(d, here_half=0.0):
    """The rule's half-width, written out: hypot(t_{n−1} · sd, h_here) / √n over the n runs' differences."""
    n = len(d)
    mean = sum(d) / n
    sd = (sum((x - mean) ** 2 for x in d) / (n - 1)) ** 0.5
    return (stdtrit(n - 1, 0.975) ** 2 * sd**2 + here_half**2) ** 0.5 / n**0.5


def test_other_runs_leave_out_the_run_this_build_repeats(spread_folder):
    spread = load_spread("laptop", spread_folder)
    keys = ("discord/sjpe_rf", "discord/sjpe_ff")
    others = spread.other_runs(*keys, Run("fp32", 0))  # an fp32 build is the recorded fp32 seed 0, made again
    assert others.runs == (Run("fp32", 1), Run("fp32", 2)) and others.values == pytest.approx((-0.01, -0.10))
    assert len(spread.other_runs(*keys, Run("bf16", 0)).runs) == 3  # a bf16 build repeats none of them
    assert len(spread.other_runs(*keys, None).runs) == 3
    assert spread.other_runs("discord/sjpe_rf", "discord/unknown", None) is None
    assert this_build("bf16") == Run("bf16", 0)


def test_two_runs_left_out_of_two_give_nothing_to_pool(tmp_path):
    for seed in (0, 1):
        _write(tmp_path, seed, {"a": seed, "b": 0.0})
    spread = load_spread("laptop", tmp_path)
    assert spread.other_runs("discord/a", "discord/b", None) is not None  # with this build: three runs
    assert spread.other_runs("discord/a", "discord/b", Run("fp32", 1)) is None  # with this build: two
    with pytest.raises(ValueError, match="2 or more recorded runs"):
        RunDifferences((Run("fp32", 0),), (0.1,))


def test_the_pooled_difference_is_the_mean_over_the_runs_with_the_means_interval():
    others = RunDifferences((Run("fp32", 1), Run("fp32", 2)), (-0.01, -0.10))
    pooled = others.pooled(Estimate(-0.07))
    assert pooled.n == 3 and pooled.mean == pytest.approx(-0.06)
    assert pooled.half_width == pytest.approx(_pooled_half([-0.01, -0.10, -0.07]))  # the mean's: / √n
    # this build's measurement interval joins over √n (every run is measured alike)
    measured = others.pooled(Estimate(-0.07, 0.05))
    assert measured.half_width == pytest.approx(_pooled_half([-0.01, -0.10, -0.07], 0.05))
    assert measured.half_width > pooled.half_width


def test_a_comparison_with_other_runs_judges_their_mean_with_this_one():
    a, b = Estimate(1.38), Estimate(1.45)
    assert report.compare(a, b).judge("lower") == HOLDS  # two points: no interval at all
    scattered = RunDifferences((Run("fp32", 1), Run("fp32", 2)), (-0.01, -0.10))
    wide = report.compare(a, b, "DisCoRD", "feed-forward", quantity="sJPE", training=scattered)
    assert wide.pooled.mean == pytest.approx(-0.06) and not wide.apart and wide.judge("lower") == INCONCLUSIVE
    text = str(wide)
    assert "over 3 training runs (this one and 2 recorded), DisCoRD − feed-forward = -0.06 ± 0.11" in text
    assert text.endswith("not distinguishable from 0 at 95%")
    close = RunDifferences((Run("bf16", 0), Run("bf16", 1)), (-0.072, -0.068))
    assert report.compare(a, b, training=close).judge("lower") == HOLDS
    # the mean decides, not this run: here a < b, but the other runs put a above b beyond the noise
    runs = tuple(Run(p, s) for p in ("bf16", "fp32") for s in (0, 1, 2))
    above = RunDifferences(runs, (0.30, 0.32, 0.31, 0.29, 0.30, 0.31))
    flipped = report.compare(a, b, "DisCoRD", "feed-forward", training=above)
    assert flipped.pooled.mean == pytest.approx((1.83 - 0.07) / 7)
    assert flipped.direction == "higher" and flipped.judge("lower") == FAILS
    assert "(this one and 6 recorded), DisCoRD − feed-forward = 0.25 ± 0.1" in str(flipped)
    assert str(flipped).endswith("DisCoRD is higher")
    with pytest.raises(TypeError, match="training must be RunDifferences"):
        report.compare(a, b, training=Estimate(-0.07, 0.12, 3))


def test_rules_pool_the_runs_only_for_results_on_the_studys_data(spread_folder):
    spread = load_spread("laptop", spread_folder)
    on_data = {
        "discord/sjpe_rf": Result("discord", "sjpe_rf", 1.38, note=NOTE, precision="fp32"),
        "discord/sjpe_ff": Result("discord", "sjpe_ff", 1.45, note=NOTE, precision="fp32"),
        "discord/fid_rf": Result("discord", "fid_rf", 0.0405, note=NOTE, precision="fp32"),
        "discord/fid_ff": Result("discord", "fid_ff", 0.0201, note=NOTE, precision="fp32"),
    }
    sjpe = Less("discord/sjpe_rf", "discord/sjpe_ff")
    assert sjpe.judge(on_data) == HOLDS  # no study: two points
    # this fp32 build takes fp32 seed 0's place: −0.07, −0.01, −0.10 average −0.06 ± 0.11
    assert sjpe.judge(on_data, spread) == INCONCLUSIVE
    assert Less("discord/fid_rf", "discord/fid_ff").judge(on_data, spread) == FAILS  # every run: rf above ff
    # a build whose precision was not recorded repeats none of the runs: it joins them as a fourth
    unknown = {k: replace(r, precision=None) for k, r in on_data.items()}
    d = [-0.07, -0.01, -0.10, -0.07]
    assert abs(sum(d) / 4) > _pooled_half(d)  # −0.0625 ± 0.060
    assert sjpe.judge(unknown, spread) == HOLDS
    elsewhere = {k: replace(r, note="data HumanML3D-abc") for k, r in on_data.items()}
    assert sjpe.judge(elsewhere, spread) == HOLDS


def test_the_claims_table_and_the_findings_box_judge_with_the_recorded_runs(spread_folder, tmp_path, monkeypatch):
    monkeypatch.setenv(results.RESULTS_ENV, str(tmp_path / "results"))
    monkeypatch.setenv("MOTIONLAB_PRECISION", "fp32")  # this build is the study's fp32 seed 0, on any CPU
    results.record("discord", "sjpe_rf", 1.38, note=NOTE, profile="laptop")
    results.record("discord", "sjpe_ff", 1.45, note=NOTE, profile="laptop")
    assert results.load_all("laptop")["discord/sjpe_rf"].precision == "fp32"
    spread = load_spread("laptop", spread_folder)
    rule = "discord/sjpe_rf < discord/sjpe_ff"
    with_spread = {row.rule: row for row in claims_table("laptop", spread=spread)}[rule]
    without = {row.rule: row for row in claims_table("laptop", spread=None)}[rule]
    assert (with_spread.verdict, without.verdict) == (INCONCLUSIVE, HOLDS)
    assert "the difference averages -0.06 ± 0.11 over 3 training runs (this build and 2 recorded)" in with_spread.ours
    assert "training runs" not in without.ours
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
        "mean ± its 95% interval": "-0.06 ± 0.11",
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
    # the test clips' interval joins the pooled one in quadrature: every run was measured on the same clips
    close = RunDifferences((Run("bf16", 0), Run("bf16", 1)), (-0.072, -0.068))
    pooled = report.compare(a, b, training=close).pooled
    assert pooled.half_width < 0.07 < (pooled.half_width**2 + 0.07**2) ** 0.5
    both = report.compare(a, b, training=close, test_set=Estimate(-0.07, 0.07, 160))
    assert not both.apart and report.compare(a, b, training=close).apart
    assert "recorded), a − b = -0.070 ± 0.070: not distinguishable from 0 at 95%; another draw of test" in str(both)
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
    assert rule.judge(narrow) == HOLDS
    fp32 = {k: replace(r, precision="fp32", note=NOTE) for k, r in narrow.items()}
    assert rule.judge(fp32, load_spread("laptop", spread_folder)) == INCONCLUSIVE  # the runs scatter more


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
    recorded = {  # this build: fp32, so it takes the fp32 run's place
        k: Result("discord", k.split("/")[1], v, note=NOTE, precision="fp32")
        for k, v in (("discord/a", 1.0), ("discord/b", 2.0))
    }
    claim = Claim("DisCoRD", "Table 1", "a is lower", "", Less("discord/a", "discord/b"))
    # one other run is nothing to average with: each run's point difference decides, and the two machines disagree
    row = verdicts_by_run(load_spread("laptop", tmp_path), recorded, [claim]).rows["DisCoRD: a is lower"]
    assert row == {"this build": HOLDS, "bf16 runs": f"{HOLDS}: seed 0", "fp32 runs": f"{FAILS}: seed 0", "agree": "no"}
    other = Claim("DisCoRD", "Table 1", "c", "", Less("discord/c", "discord/b"))
    with pytest.raises(ValueError, match="measured none"):
        verdicts_by_run(load_spread("laptop", tmp_path), recorded, [other])
    elsewhere = {k: replace(r, note="DisCoRD; data real-humanml3d") for k, r in recorded.items()}
    with pytest.raises(ValueError, match="measured none"):  # the study's runs are not a real-data chapter's runs
        verdicts_by_run(load_spread("laptop", tmp_path), elsewhere, [claim])


def test_the_mean_over_runs_reads_alike_where_single_runs_would_not(tmp_path):
    from motionlab.report.render import verdicts_by_run
    from motionlab.report.rules import Claim

    # a − b: three bf16 runs near −1, three fp32 runs near −0.6 (a shift between precisions, as measured)
    for precision, ds in (("bf16", (-1.0, -0.9, -1.1)), ("fp32", (-0.5, -0.7, -0.6))):
        for seed, d in enumerate(ds):
            _write(tmp_path, seed, {"a": 2.0 + d, "b": 2.0}, precision=precision)
    spread = load_spread("laptop", tmp_path)
    one_run = spread.difference("discord/a", "discord/b").half_width  # t_5 · sd: how far one run lands
    assert 0.5 < one_run < 1.1  # judged alone, fp32 seed 0 would read inconclusive and bf16 seed 2 holds
    recorded = {
        k: Result("discord", k.split("/")[1], v, note=NOTE, precision="fp32")
        for k, v in (("discord/a", 1.5), ("discord/b", 2.0))
    }
    claim = Claim("DisCoRD", "Table 1", "a is lower", "", Less("discord/a", "discord/b"))
    row = verdicts_by_run(spread, recorded, [claim]).rows["DisCoRD: a is lower"]
    every_seed = f"{HOLDS}: seeds 0, 1, 2"  # this build and six runs in its place, one verdict
    assert row == {"this build": HOLDS, "bf16 runs": every_seed, "fp32 runs": every_seed, "agree": "yes"}


def test_a_ground_truth_number_no_run_moves_pools_with_the_model_beside_it(tmp_path):
    # Handshake's Jerk against real single motions: the real side is the same on every run and names no model's data
    for seed, jerk in enumerate((1.50, 1.44, 1.43)):
        _write(tmp_path, seed, {"tps/jerk_handshake": jerk, "tps/jerk_gt": 1.60}, study="m2d2m")
    spread = load_spread("laptop", tmp_path)
    model = Result("tps", "jerk_handshake", 1.51, ci=(1.41, 1.61), note=NOTE, precision="fp32")
    real = Result("tps", "jerk_gt", 1.60, ci=(1.57, 1.63), note="ground truth on 91 instances", precision="fp32")
    rule = Less("tps/jerk_handshake", "tps/jerk_gt")
    recorded = {"tps/jerk_handshake": model, "tps/jerk_gt": real}
    assert rule.judge(recorded) == INCONCLUSIVE  # this run alone: −0.09 ± 0.10
    # pooled: −0.09 (this build, in fp32 seed 0's place), −0.16, −0.17
    d = [-0.09, -0.16, -0.17]
    half = (stdtrit(2, 0.975) ** 2 * (sum((x - sum(d) / 3) ** 2 for x in d) / 2) + 0.10**2 + 0.03**2) ** 0.5 / 3**0.5
    assert abs(sum(d) / 3) > half and rule.judge(recorded, spread) == HOLDS
    # a ground truth of other data (another value than the study's) is not the study's: no pooling
    other_real = {"tps/jerk_handshake": model, "tps/jerk_gt": replace(real, value=1.70, ci=(1.67, 1.73))}
    assert report.compare(model.estimate, other_real["tps/jerk_gt"].estimate).judge("lower") == HOLDS
    from motionlab.report.rules import training_difference

    assert training_difference(model, other_real["tps/jerk_gt"], spread) is None
    assert training_difference(real, real, spread) is None  # two ground truths: no model to average over


def test_a_relative_tolerance_reads_the_means_over_runs(tmp_path):
    from motionlab.report.rules import Within

    # FID at 2 steps against 16: 30% apart on this run, 5% and 0% on the two others
    for seed, (two, sixteen) in enumerate(((0.050, 0.040), (0.042, 0.040), (0.040, 0.040))):
        _write(tmp_path, seed, {"fid_steps2": two, "fid_steps16": sixteen})
    spread = load_spread("laptop", tmp_path)
    recorded = {
        f"discord/{k}": Result("discord", k, v, note=NOTE, precision="bf16")  # a bf16 build: a fourth run
        for k, v in (("fid_steps2", 0.052), ("fid_steps16", 0.040))
    }
    rule = Within("discord/fid_steps2", "discord/fid_steps16", 0.25)
    assert rule.judge(recorded) == FAILS  # 30% apart
    a, b, n = rule.pooled(recorded, spread)
    assert (a, b, n) == (pytest.approx((0.050 + 0.042 + 0.040 + 0.052) / 4), pytest.approx(0.040), 4)
    assert rule.judge(recorded, spread) == HOLDS  # 15% apart
    row = {r.rule: r for r in claims_table("laptop", recorded=recorded, spread=spread, budget=None)}[rule.describe()]
    assert row.verdict == HOLDS
    assert "averaged over 4 training runs (this build and 3 recorded): 0.0460, 0.0400, 15% apart" in row.ours


def test_the_repeat_check_measures_how_far_this_build_is_from_the_run_it_replaces(spread_folder):
    from motionlab.report.render import repeat_check

    spread = load_spread("laptop", spread_folder)
    same = {
        f"discord/{k}": Result("discord", k, v, note=NOTE, precision="fp32")
        for k, v in (("sjpe_rf", 1.38), ("sjpe_ff", 1.45))  # fp32 seed 0's numbers, trained again
    }
    text = repeat_check(spread, same)
    assert "takes the place of seed 0 (fp32): over 2 numbers it lies a median 0.00 (at most 0.00)" in text
    sd = (sum((x - 1.3766667) ** 2 for x in (1.38, 1.40, 1.35)) / 2) ** 0.5  # sjpe_rf over the runs: 0.025
    moved = same | {"discord/sjpe_rf": replace(same["discord/sjpe_rf"], value=1.38 + 4 * sd)}
    assert "a median 2.00 (at most 4.00)" in repeat_check(spread, moved)
    bf16 = {k: replace(r, precision="bf16") for k, r in same.items()}
    assert repeat_check(spread, bf16).startswith("no recorded run is seed 0 (bf16): this build joins the recorded")
    unknown = {k: replace(r, precision=None) for k, r in same.items()}
    assert "precision is not recorded" in repeat_check(spread, unknown)


def test_a_run_measured_with_other_configs_is_set_aside(tmp_path):
    """A run recorded before a studied model or its evaluation changed measured something else: it joins no verdict,
    and the spread says which run and what changed. So does a run recorded without its configs."""
    for seed in range(3):
        _write(tmp_path, seed, {"sjpe_rf": 1.38 + seed / 100, "sjpe_ff": 1.45})
    configs = study_configs("discord", "laptop")
    configs["models"]["discord/rvq"]["train_steps"] += 1000
    configs["evaluations"]["reconstruction"]["test_clips"] = 999
    _write(tmp_path, 3, {"sjpe_rf": 9.0, "sjpe_ff": 1.45}, configs=configs)
    legacy = _write(tmp_path, 1, {"sjpe_rf": 9.0, "sjpe_ff": 1.45}, precision="bf16")
    legacy.write_text(json.dumps({k: v for k, v in json.loads(legacy.read_text()).items() if k != "configs"}))
    spread = load_spread("laptop", tmp_path)
    assert spread.runs("discord/sjpe_rf", "discord/sjpe_ff") == [Run("fp32", 0), Run("fp32", 1), Run("fp32", 2)]
    assert len(spread.measured) == 3 and len(spread.set_aside) == 2
    changed, missing = sorted(spread.set_aside, key=lambda line: "seed 3" not in line)
    assert "seed 3 (fp32)" in changed and "models.discord/rvq.train_steps" in changed
    assert "evaluations.reconstruction.test_clips" in changed
    assert "seed 1 (bf16)" in missing and "without the configs" in missing
    for path in tmp_path.glob("*-fp32-*.json"):  # now every run measured other models: as if none were recorded
        path.unlink()
    with pytest.warns(UserWarning, match="every recorded run"):
        assert load_spread("laptop", tmp_path) is None


def test_config_changes_name_every_differing_field():
    recorded = {"models": {"a": {"steps": 1, "lr": 0.1}, "b": {"width": 8}}, "evaluations": {"e": {"clips": 5}}}
    current = {"models": {"a": {"steps": 2, "lr": 0.1}}, "evaluations": {"e": {"clips": 5, "seeds": 3}}}
    assert config_changes(recorded, current) == ["evaluations.e.seeds", "models.a.steps", "models.b"]
    assert config_changes(current, current) == []


def test_a_field_added_at_its_old_value_does_not_set_a_record_aside():
    recorded = {"evaluations": {"t2m": {"repeats": 3}}}  # measured before the configs had guidance_on
    assert config_changes(recorded, {"evaluations": {"t2m": {"repeats": 3, "guidance_on": "x0"}}}) == []
    changed = {"evaluations": {"t2m": {"repeats": 3, "guidance_on": "posterior"}}}
    assert config_changes(recorded, changed) == ["evaluations.t2m.guidance_on"]  # a record never guided there


def test_the_study_plans_name_the_models_each_seed_trains():
    assert study_plan("discord", 2, "laptop").models == ("tokenizer/rvq-seed2", "evaluator", "discord/rvq-seed2")
    assert study_plan("transitions", 0, "laptop").models == ("t2m/uniform", "t2m/dynamic")
    m2d2m = study_plan("m2d2m", 1, "laptop")
    assert m2d2m.models == ("t2m/multi-eta0.25-seed1", "t2m/uniform-seed1", "t2m/dynamic-seed1")
    assert m2d2m.evaluations["multi"].model == "t2m/multi-eta0.25-seed1"
    assert study_plan("discord", 0, "laptop").evaluations["reconstruction"].timing_repeats == 0
    with pytest.raises(ValueError, match="study"):
        study_plan("tps", 0, "laptop")
    with pytest.raises(ValueError, match="training_seed"):
        study_plan("discord", -1, "laptop")


def test_the_recorded_studies_measured_the_books_models_and_evaluations():
    """Every run under book/data/training_seeds/ was measured with the configs the code builds now. A change to a
    studied model (its training steps, its width, ...) or to the evaluation that scores it fails here until the study
    is recorded again (experiments/training_seeds.py), instead of pooling runs of other models into the verdicts."""
    from motionlab.data.embedded.generator import VERSION
    from motionlab.report.spread import FOLDER, find_folder

    spread = load_spread("laptop")
    assert spread is not None, "no training-seed study recorded for the laptop profile"
    assert not spread.set_aside, "\n".join(spread.set_aside)
    files = list((find_folder(FOLDER) / f"embedded-v{VERSION}").glob("*-laptop-*.json"))
    assert len(spread.measured) == len(files) >= 12  # every recorded run joins: three seeds of each study at least
    assert {line.split()[0] for line in spread.measured} == {"discord", "m2d2m", "transitions"}


def test_checking_the_configs_draws_nothing_from_the_global_rng():
    """Chapters read the study mid-way (chapters 05, 08): checking its configs must not move their random draws."""
    import torch

    torch.manual_seed(0)
    expected = torch.rand(3)
    torch.manual_seed(0)
    for study in ("discord", "m2d2m", "transitions"):
        study_configs(study, "laptop")
    assert torch.equal(torch.rand(3), expected)
