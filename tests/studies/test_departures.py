"""The departures page (study s7): rows read from the configs, four columns each, claims judged both ways by their own
rule, and "not yet measured" where a number is missing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from motionlab import sizes
from motionlab.flow import discord_config
from motionlab.report.claims import CLAIMS
from motionlab.report.rules import Less
from motionlab.report.store import FAILS, HOLDS, MISSING, Result
from motionlab.studies import departures
from motionlab.studies.departures import Departure, Measurements, Setting

ROOT = Path(__file__).resolve().parents[2]
NOTHING = Measurements(recorded={})  # no recorded result and no study: every measured cell is missing


def _row(rows: list[Departure], topic: str) -> Departure:
    return next(r for r in rows if r.topic == topic)


def _result(key: str, value: float, half: float | None = None) -> Result:
    chapter, name = key.split("/", 1)
    return Result(chapter, name, value, None if half is None else (value - half, value + half))


def test_the_width_cell_follows_the_laptop_config(monkeypatch):
    before = _row(departures.discord_departures("laptop", NOTHING), "U-Net width")
    assert str(discord_config("laptop").width) in before.build
    assert before.paper.startswith(f"{discord_config('full').width},")  # the paper's column is the full config's

    monkeypatch.setitem(sizes.DISCORD_DECODER, "laptop", {**sizes.DISCORD_DECODER["laptop"], "width": 96})
    after = _row(departures.discord_departures("laptop", NOTHING), "U-Net width")
    assert after.build.startswith("96,") and after.paper == before.paper


def test_a_setting_the_laptop_shares_with_the_paper_says_so(monkeypatch):
    row = _row(departures.discord_departures("laptop", NOTHING), "training window")
    assert row.build.startswith("as the paper") and row.depends is False and row.verdict.startswith("none")

    monkeypatch.setitem(sizes.DISCORD_DECODER, "laptop", {**sizes.DISCORD_DECODER["laptop"], "window": 32})
    row = _row(departures.discord_departures("laptop", NOTHING), "training window")
    assert row.build.startswith("32 frames") and row.depends is None


def test_the_m2d2m_cells_follow_the_denoiser_config(monkeypatch):
    before = _row(departures.m2d2m_departures("laptop", NOTHING), "model size and training budget")
    steps = sizes.DENOISER["laptop"]["train_steps"]
    assert f"{steps:,} steps" in before.build and "110 epochs" in before.paper

    monkeypatch.setitem(sizes.DENOISER, "laptop", {**sizes.DENOISER["laptop"], "train_steps": 1234})
    after = _row(departures.m2d2m_departures("laptop", NOTHING), "model size and training budget")
    assert "1,234 steps" in after.build and after.paper == before.paper


@pytest.mark.parametrize("profile", ["smoke", "laptop"])
def test_every_row_has_all_four_columns(profile):
    for rows in (departures.discord_departures(profile, NOTHING), departures.m2d2m_departures(profile, NOTHING)):
        assert rows and len({r.topic for r in rows}) == len(rows)
        for row in rows:
            assert all(cell.strip() for cell in row.cells()), row
        lines = departures.departures_table(rows, profile).to_markdown().splitlines()
        assert lines[0].count(" | ") == 4 and f"what the {profile} build does" in lines[0]
        assert len(lines) == 2 + len(rows)


def test_a_bar_in_a_cell_is_escaped_and_a_line_break_joined():
    row = Departure("a | b", "p(x | y)", "one\ntwo", "why", "none")
    line = departures.departures_table([row], "laptop").to_markdown().splitlines()[-1]
    assert "p(x \\| y)" in line and "a \\| b" in line and "one two" in line


def test_the_sjpe_claim_is_judged_both_ways_by_its_own_rule():
    recorded = {
        "discord/sjpe_rf": _result("discord/sjpe_rf", 1.0, 0.01),
        "discord/sjpe_ff": _result("discord/sjpe_ff", 1.5),
        "discord/sjpe_xpred": _result("discord/sjpe_xpred", 2.0, 0.01),
        "discord/sjpe_rf_minus_ff": _result("discord/sjpe_rf_minus_ff", -0.5, 0.05),
    }
    claim = next(c for c in CLAIMS if c.keys == ("discord/sjpe_rf", "discord/sjpe_ff"))
    swapped = departures.substituted(claim.rule, departures.XPRED_KEYS)
    # the same rule on the variant's number; the rf pair's paired difference is not the variant's
    assert swapped == Less("discord/sjpe_xpred", "discord/sjpe_ff", clips=None)
    ((judged),) = departures.judge_settings(
        [claim], [Setting("paper", recorded), Setting("variant", recorded, departures.XPRED_KEYS)]
    )
    assert judged.verdicts == (("paper", claim.rule.judge(recorded)), ("variant", swapped.judge(recorded)))
    assert [v for _, v in judged.verdicts] == [HOLDS, FAILS] and judged.changes

    row = _row(departures.discord_departures("laptop", Measurements(recorded)), "prediction target and start noise")
    assert row.depends is True and row.verdict.startswith("yes")
    assert f"{HOLDS} (the paper's decoder), {FAILS} (x-prediction variant)" in row.verdict


def test_missing_keys_read_as_not_yet_measured():
    rows = departures.discord_departures("laptop", NOTHING)
    for topic in ("prediction target and start noise", "solver steps"):
        row = _row(rows, topic)
        assert row.verdict.startswith(MISSING) and row.depends is None
    # one side recorded, the other not: still not measured, never a verdict from half the numbers
    half = {k: _result(k, 1.0) for k in ("discord/sjpe_rf", "discord/sjpe_ff")}
    row = _row(departures.discord_departures("laptop", Measurements(half)), "prediction target and start noise")
    assert row.verdict.startswith(MISSING)
    m2d2m = departures.m2d2m_departures("laptop", NOTHING)
    assert _row(m2d2m, "joint-phase text (Two-Phase Sampling)").verdict.startswith(MISSING)
    assert departures.verdict(Less("a/x", "a/y"), {}) == MISSING


def test_the_sentence_is_read_from_the_rows():
    rows = [
        Departure("width", "p", "b", "w", "yes", True),
        Departure("window", "p", "b", "w", "none", False),
        Departure("encoder", "p", "b", "w", "not measured here", None),
    ]
    sentence = departures.dependence_sentence(rows, "DisCoRD")
    assert sentence == "A verdict of DisCoRD depends on *width*; none depends on *window*; not measured: *encoder*."
    assert departures.dependence_sentence(rows[1:], "M2D2M") == (
        "No verdict of M2D2M depends on *window*; not measured: *encoder*."
    )
    assert departures.dependence_sentence(rows[2:], "M2D2M").startswith("No departure of M2D2M was measured here")


def test_the_committed_studies_measure_the_laptop_rows():
    measured = Measurements.load("laptop")
    if measured.sweep is None or measured.eta is None:
        pytest.skip("the committed studies are not in this checkout")
    discord = departures.discord_departures("laptop", measured)
    for topic in ("U-Net width", "feature normalisation"):
        assert _row(discord, topic).depends is not None  # s1's sweep judged the claims both ways
    m2d2m = departures.m2d2m_departures("laptop", measured)
    eta = _row(m2d2m, "η of the dynamic transitions")
    assert eta.depends is not None and "η = 0.5 (the paper's)" in eta.verdict
    assert measured.guidance is not None and _row(m2d2m, "guidance space").depends is not None


def test_the_page_is_a_study_of_the_book():
    toc = yaml.safe_load((ROOT / "book" / "_toc.yml").read_text())
    studies = next(part for part in toc["parts"] if part["caption"] == "Studies")
    assert {"file": "notebooks/s7_departures"} in studies["chapters"]
    from motionlab.build.book_models import CHAPTER_MODELS

    assert CHAPTER_MODELS["s7_departures"] == ()  # it trains nothing
    page = json.loads((ROOT / "notebooks" / "s7_departures.ipynb").read_text())
    assert page["metadata"]["motionlab"]["run_last"]  # it reads what the chapters recorded
    for linking in ("99_what_reproduces", "98_full_scale"):
        assert "s7_departures.ipynb" in (ROOT / "notebooks" / f"{linking}.ipynb").read_text()


def test_the_width_row_reads_the_paper_decoder_above_its_floor():
    def runs(*sjpe: float) -> dict:
        return {"runs": [{"sjpe": value} for value in sjpe]}

    run = {
        "config": {"width": 272},
        "budget_s": 2400.0,
        "feed_forward": {"sjpe": 1.44},
        "checkpoints": [{"samplings": {"T1": runs(2.6, 2.7, 2.65), "T0": runs(1.23)}}],
    }
    without = _row(departures.discord_departures("laptop", NOTHING), "U-Net width")
    assert "At width" not in without.why  # no run of it in this checkout: the cell says nothing of it
    measured = Measurements(recorded={}, sweep_today={departures.PAPER_WIDTH_RUN: run})
    row = _row(departures.discord_departures("laptop", measured), "U-Net width")
    assert row.why.startswith(without.why) and "At width 272, where the floor is 0" in row.why
    assert "2.65 ± " in row.why and "at T1 and 1.23 from zero noise, feed-forward 1.44" in row.why


def _guidance_records(folder: Path, values: dict[str, dict[str, float]], profile: str = "laptop") -> None:
    """One record per guidance space in ``folder``, as experiments/guidance_space.py writes them."""
    from motionlab.evaluation.studies import guidance_configs

    for space, numbers in values.items():
        record = {
            "study": "guidance_space",
            "guidance_on": space,
            "profile": profile,
            "cpu": "a test CPU",
            "precision": "bf16",
            "configs": guidance_configs(space, profile),
            "values": {k: {"mean": v, "half_width": 0.01, "n": 3, "unit": None} for k, v in numbers.items()},
        }
        (folder / f"{profile}-bf16-{space}.json").write_text(json.dumps(record))


def test_the_guidance_row_judges_the_guided_claims_in_both_spaces(tmp_path):
    from motionlab.report.guidance import load_guidance_study

    row = _row(departures.m2d2m_departures("laptop", NOTHING), "guidance space")
    assert row.verdict.startswith(MISSING) and row.depends is None  # no study: not measured, and why
    # Supp. Table 2: guidance lowers FID on x0 (0.5 < 0.6), not on the posterior (0.7 > 0.6); the real-motion Jerks are
    # the same in both spaces and carry no claim of their own here
    x0 = {"diffusion/fid_guided": 0.5, "diffusion/fid_unguided": 0.6, "tps/jerk_gt_single": 1.0}
    _guidance_records(tmp_path, {"x0": x0, "posterior": {**x0, "diffusion/fid_guided": 0.7}})
    study = load_guidance_study("laptop", tmp_path)
    row = _row(departures.m2d2m_departures("laptop", Measurements({}, guidance=study)), "guidance space")
    assert row.depends is True and "a test CPU, bf16" in row.verdict
    assert f"Supp. Table 2 (FID, guided, s = 4): {HOLDS} (on x₀), {FAILS} (on the posterior)" in row.verdict
    assert "Table 1, Fig. 5" not in row.verdict  # the claim on real motions only is not this row's
    same = {"x0": x0, "posterior": x0}
    for path in tmp_path.glob("*.json"):
        path.unlink()
    _guidance_records(tmp_path, same)
    measured = Measurements({}, guidance=load_guidance_study("laptop", tmp_path))
    row = _row(departures.m2d2m_departures("laptop", measured), "guidance space")
    assert row.depends is False and "bf16), no: Supp. Table 2" in row.verdict


def test_a_guidance_study_needs_both_spaces_of_the_code_configs(tmp_path):
    from motionlab.report.guidance import load_guidance_study

    numbers = {"diffusion/fid_guided": 0.5, "diffusion/fid_unguided": 0.6}
    _guidance_records(tmp_path, {"posterior": numbers})
    assert load_guidance_study("laptop", tmp_path) is None  # one space is no comparison
    _guidance_records(tmp_path, {"x0": numbers})
    study = load_guidance_study("laptop", tmp_path)
    assert study is not None and study.results("posterior")["diffusion/fid_guided"].ci == pytest.approx((0.49, 0.51))
    assert load_guidance_study("smoke", tmp_path) is None  # another profile's sizes
    # a record measured with other evaluation sizes is set aside, and the pair with it
    record = json.loads((tmp_path / "laptop-bf16-x0.json").read_text())
    record["configs"]["evaluations"]["guidance"]["repeats"] += 1
    (tmp_path / "laptop-bf16-x0.json").write_text(json.dumps(record))
    assert load_guidance_study("laptop", tmp_path) is None


def test_the_schedule_row_follows_the_paper_unless_the_profile_departs(monkeypatch):
    row = _row(departures.m2d2m_departures("laptop", NOTHING), "noise schedule")
    assert row.build.startswith("as the paper") and row.depends is False  # no departure, no verdict resting on it
    assert row.verdict.startswith("none: ") and "vqdiffusion_code" in row.verdict  # the public code's still named
    from dataclasses import replace

    paper_config = departures._m2d2m_config

    def public_code_schedule(profile):  # a build that noised as VQ-Diffusion's code does
        config = paper_config(profile)
        if profile == "full":
            return config
        return replace(config, transformer=replace(config.transformer, schedule="vqdiffusion_code"))

    monkeypatch.setattr(departures, "_m2d2m_config", public_code_schedule)
    row = _row(departures.m2d2m_departures("laptop", NOTHING), "noise schedule")
    assert row.build.startswith("`vqdiffusion_code`") and row.depends is None
    assert row.verdict.startswith("not measured by training")
