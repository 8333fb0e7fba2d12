"""motionlab.results: recording numbers atomically, and judging the papers' claims with them."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from motionlab import results
from motionlab.estimate import Estimate
from motionlab.results import (
    CLAIMS,
    FAILS,
    HOLDS,
    INCONCLUSIVE,
    MISSING,
    Between,
    Claim,
    Greater,
    Increasing,
    Less,
    Result,
    Within,
)


@pytest.fixture
def results_root(tmp_path, monkeypatch):
    root = tmp_path / "results"
    monkeypatch.setenv(results.RESULTS_ENV, str(root))
    monkeypatch.delenv("MOTIONLAB_PROFILE", raising=False)
    return root


def r(value, ci=None, key="k"):
    return Result("c", key, float(value), ci)


# ---------------------------------------------------------------------------------------------- recording


def test_record_round_trip_and_file_layout(results_root):
    out = results.record("discord", "sjpe_rf", np.float32(0.25), ci=0.05, unit="", note="16 steps", profile="smoke")
    assert out.name == "discord/sjpe_rf" and out.ci == pytest.approx((0.2, 0.3))
    results.record("discord", "sjpe_ff", 0.5, ci=(0.4, 0.55), profile="smoke")
    results.record("tps", "jerk_tps", 1, profile="smoke")

    path = results_root / "smoke" / "discord.json"
    payload = json.loads(path.read_text())
    assert payload["chapter"] == "discord" and payload["profile"] == "smoke"
    assert set(payload["results"]) == {"sjpe_rf", "sjpe_ff"}
    assert not list((results_root / "smoke").glob("*.tmp")), "atomic write left a temporary file"

    loaded = results.load_all("smoke")
    assert set(loaded) == {"discord/sjpe_rf", "discord/sjpe_ff", "tps/jerk_tps"}
    assert loaded["discord/sjpe_rf"].value == pytest.approx(0.25)
    assert loaded["discord/sjpe_rf"].note == "16 steps"
    assert loaded["discord/sjpe_ff"].ci == (0.4, 0.55)
    assert loaded["tps/jerk_tps"].ci is None
    assert results.load_all("laptop") == {}, "profiles must not see each other's numbers"


def test_record_again_replaces_and_profile_defaults_to_env(results_root, monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PROFILE", "full")
    results.record("vq", "usage", 0.5)
    results.record("vq", "usage", 0.75)
    loaded = results.load_all("full")
    assert loaded["vq/usage"].value == 0.75 and len(loaded) == 1


def test_default_folder_is_inside_the_cache(isolated_cache, monkeypatch):
    monkeypatch.delenv(results.RESULTS_ENV, raising=False)
    results.record("flow", "loss", 0.1, profile="smoke")
    assert (isolated_cache / "results" / "smoke" / "flow.json").is_file()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"chapter": "Bad Name"}, "chapter"),
        ({"chapter": "a/b"}, "chapter"),
        ({"key": ""}, "key"),
        ({"value": float("nan")}, "finite"),
        ({"value": "0.3"}, "real number"),
        ({"value": True}, "real number"),
        ({"value": np.ones(3)}, "real number"),
        ({"ci": -1.0}, ">= 0"),
        ({"ci": (0.5, 0.6)}, "contain"),
        ({"ci": (0.1, 0.2, 0.3)}, "pair"),
        ({"unit": 3}, "unit"),
        ({"profile": "huge"}, "profile"),
    ],
)
def test_record_validates(results_root, kwargs, match):
    args = {"chapter": "discord", "key": "sjpe_rf", "value": 0.3} | kwargs
    with pytest.raises(ValueError, match=match):
        results.record(**args)


# ---------------------------------------------------------------------------------------------- rules


def test_rules_on_points():
    rec = {"a": r(1.0), "b": r(2.0), "c": r(3.0)}
    assert Less("a", "b").judge(rec) == HOLDS and Less("b", "a").judge(rec) == FAILS
    assert Greater("c", "a").judge(rec) == HOLDS and Greater("a", "c").judge(rec) == FAILS
    assert Between("b", "a", "c").judge(rec) == HOLDS and Between("a", "b", "c").judge(rec) == FAILS
    assert Increasing(("a", "b", "c")).judge(rec) == HOLDS
    assert Increasing(("a", "c", "b")).judge(rec) == FAILS
    assert Within("b", "c", 0.34).judge(rec) == HOLDS and Within("b", "c", 0.3).judge(rec) == FAILS


def test_overlapping_intervals_are_inconclusive_but_a_clear_failure_is_not():
    rec = {"a": r(1.0, (0.8, 1.2)), "b": r(1.1, (0.9, 1.3)), "far": r(5.0, (4.9, 5.1)), "pt": r(1.1)}
    assert Less("a", "b").judge(rec) == INCONCLUSIVE
    assert Less("a", "pt").judge(rec) == INCONCLUSIVE  # the point lies inside a's interval
    assert Less("a", "far").judge(rec) == HOLDS
    assert Greater("a", "far").judge(rec) == FAILS
    assert Between("b", "a", "far").judge(rec) == INCONCLUSIVE  # low side overlaps, high side is clear


def test_a_difference_is_judged_by_its_own_interval_not_by_overlapping_intervals():
    # 1.0 ± 0.1 and 1.16 ± 0.1 overlap (1.1 > 1.06), yet the difference 0.16 exceeds sqrt(0.1² + 0.1²) = 0.141
    rec = {"a": r(1.0, (0.9, 1.1)), "c": r(1.16, (1.06, 1.26)), "d": r(1.14, (1.04, 1.24)), "pt": r(1.19)}
    assert Less("a", "c").judge(rec) == HOLDS and Greater("a", "c").judge(rec) == FAILS
    assert Less("a", "d").judge(rec) == INCONCLUSIVE  # 0.14 < 0.141
    assert Less("a", "pt").judge(rec) == HOLDS  # against a point, a's own half-width alone: 0.19 > 0.1
    assert Less("a", "c").judge({"a": r(1.0, (0.95, 1.2)), "c": rec["c"]}) == INCONCLUSIVE  # the wider side counts
    assert Estimate(1.0, 0.1).apart_from(Estimate(1.16, 0.1)) and not Estimate(1.0, 0.1).apart_from(Estimate(1.14, 0.1))


def test_missing_keys_give_a_row_not_a_gap():
    claim = Claim("P", "Table 1", "x is small", "1 vs 2", Less("c/x", "c/y"))
    row = results.judge(claim, {"c/x": r(1.0, key="x")})
    assert row.verdict == MISSING and row.missing == ("c/y",)
    assert row.ours == "x 1.00 vs y not yet measured"  # keys without a label are shown by their name
    mixed = results.judge(Claim("P", "T", "s", "v", Less("a/x", "b/y")), {})
    assert mixed.ours == "x not yet measured vs y not yet measured"


# ---------------------------------------------------------------------------------------------- registry


def test_registry_is_well_formed():
    assert len(CLAIMS) >= 15
    assert {c.paper for c in CLAIMS} == {"DisCoRD", "M2D2M"}
    for claim in CLAIMS:
        for key in claim.keys:
            prefix, _, name = key.partition("/")
            assert prefix in results.CHAPTERS, f"{key}: unknown chapter prefix"
            assert re.fullmatch(r"[a-z0-9][a-z0-9_.\-]*", name), key
        assert claim.statement and claim.paper_value and claim.source
    assert set(results.PAPER_NUMBERS) <= set(results.claim_keys())


def test_rules_reproduce_each_papers_conclusion_on_its_own_numbers():
    """Judged on the papers' own numbers, every claim that has them must hold: the rules point right."""
    table = results.claims_table("smoke", recorded=results.paper_results())
    judged = [row for row in table if row.verdict != MISSING]
    assert len(judged) >= 14
    assert all(row.verdict == HOLDS for row in judged), [(r.rule, r.verdict) for r in judged]
    # ...and flipping a number breaks the claim that reads it.
    flipped = dict(results.paper_results())
    flipped["discord/sjpe_rf"] = Result("discord", "sjpe_rf", 0.9)
    assert results.claims_table("smoke", recorded=flipped).rows[0].verdict == FAILS


def test_claims_table_with_nothing_recorded_lists_every_claim(results_root):
    table = results.claims_table("laptop")
    assert len(table) == len(CLAIMS)
    assert table.counts()[MISSING] == len(CLAIMS)
    html = table._repr_html_()
    assert html.count("<tr>") == len(CLAIMS) + 1 and "not yet measured" in html
    assert sum(line.startswith("| ") for line in table.to_markdown().splitlines()) == len(CLAIMS) + 1


def test_claims_table_uses_recorded_numbers(results_root):
    results.record("discord", "sjpe_rf", 0.40, ci=0.01, profile="smoke")
    results.record("discord", "sjpe_ff", 0.52, ci=0.01, profile="smoke")
    results.record("tps", "jerk_gt_single", 1.2, profile="smoke")
    results.record("tps", "jerk_gt_concat", 1.1, profile="smoke")
    rows = {row.rule: row for row in results.claims_table("smoke")}
    assert rows["discord/sjpe_rf < discord/sjpe_ff"].verdict == HOLDS
    assert rows["tps/jerk_gt_concat > tps/jerk_gt_single"].verdict == FAILS
    assert "<script" not in results.claims_table("smoke")._repr_html_()


def test_mechanism_rows_show_recorded_numbers_and_never_change_the_verdict(results_root):
    from motionlab.results import Evidence

    claim = Claim(
        "P",
        "T",
        "guidance helps",
        "1 vs 2",
        Less("c/a", "c/b"),
        mechanism=(Evidence("entropy, s = 0 → 4", ("c/h0", "c/h4")), Evidence("repeats", ("c/rep",))),
    )
    rec = {"c/a": r(2.0, key="a"), "c/b": r(1.0, key="b"), "c/h0": r(3.74, key="h0"), "c/h4": r(1.22, key="h4")}
    row = results.judge(claim, rec)
    assert row.verdict == FAILS  # the mechanism explains, it does not judge
    assert row.mechanism == "entropy, s = 0 → 4: h0 3.74, h4 1.22\nrepeats: not yet measured"
    assert claim.mechanism_keys == ("c/h0", "c/h4", "c/rep")
    assert results.judge(Claim("P", "T", "s", "v", Less("c/a", "c/b")), rec).mechanism == ""
    # The guidance and dynamic-β claims of M2D2M carry their mechanism, on keys of their own chapters.
    explained = {c.rule.describe(): c for c in CLAIMS if c.mechanism}
    assert {
        "diffusion/fid_guided < diffusion/fid_unguided",
        "transitions/fid_dynamic < transitions/fid_uniform",
    } <= set(explained)
    for c in explained.values():  # a mechanism may read another chapter's keys, each one a reader can name
        assert all(k.split("/")[0] in results.CHAPTERS and k in results.QUANTITIES for k in c.mechanism_keys)
    table = results.ClaimsTable([row], "smoke")
    assert "Why, as measured" in table._repr_html_() and "h4 1.22" in table.to_markdown()


# ---------------------------------------------------------------------------------------------- reading


def test_estimates_read_with_units_and_only_real_intervals():
    fmt = results.format_estimate
    assert fmt(0.41234, (0.39912, 0.42556)) == "0.412 ± 0.013"
    assert fmt(177.2, (175.4, 179.0), "mm") == "177.2 ± 1.8 mm"
    assert fmt(1.283, (1.283, 1.283)) == "1.28"  # a zero-width interval (a deterministic value) is not shown
    assert fmt(25.0, (-3.0, 53.0)) == "25 ± 28"
    assert fmt(1.0, (0.5, 2.0), "s") == "1.0 (95% CI 0.5 to 2.0) s"
    assert fmt(0.00815) == "0.00815" and fmt(-15.14) == "-15.1" and fmt(12_345.0) == "12,345"
    assert Result("c", "k", 1.283, (1.283, 1.283), "mm").describe() == "1.28 mm"


def test_ours_is_a_phrase_without_raw_keys():
    rec = {
        "discord/sjpe_rf": Result("discord", "sjpe_rf", 0.412, (0.399, 0.425)),
        "discord/sjpe_ff": Result("discord", "sjpe_ff", 0.512),
    }
    assert (
        Less("discord/sjpe_rf", "discord/sjpe_ff").sentence(rec)
        == "sJPE: 0.412 ± 0.013 (flow decoder) < 0.512 (feed-forward decoder)"
    )
    # two different values never print alike
    close = {
        "discord/sjpe_steps2": Result("discord", "sjpe_steps2", 3.6161),
        "discord/sjpe_steps16": Result("discord", "sjpe_steps16", 3.6152),
    }
    assert (
        Greater("discord/sjpe_steps2", "discord/sjpe_steps16").sentence(close)
        == "sJPE: 3.616 (2 steps) > 3.615 (16 steps)"
    )
    within = {
        "discord/fid_steps2": Result("discord", "fid_steps2", 0.034),
        "discord/fid_steps16": Result("discord", "fid_steps16", 0.032),
    }
    assert (
        Within("discord/fid_steps2", "discord/fid_steps16", 0.25).sentence(within)
        == "FID: 0.0340 (2 steps), 0.0320 (16 steps): 6% apart (the claim allows 25%)"
    )


def test_every_key_a_page_reads_has_a_label():
    """Claims, mechanisms and chapter findings name their keys in words: no raw key reaches a page."""
    keys = set(results.claim_keys()) | {k for c in CLAIMS for k in c.mechanism_keys}
    keys |= {k for findings in results.FINDINGS.values() for f in findings for k in f.keys}
    unlabelled = sorted(keys - set(results.QUANTITIES))
    assert not unlabelled, f"add these keys to results.QUANTITIES (quantity, condition): {unlabelled}"


def test_claims_page_shows_no_raw_key_and_a_summary_per_paper():
    recorded = {
        name: Result(*name.split("/", 1), 1.0 + i / 10, (0.9 + i / 10, 1.1 + i / 10))
        for i, name in enumerate(set(results.claim_keys()) | {k for c in CLAIMS for k in c.mechanism_keys})
    }
    table = results.claims_table("smoke", recorded=recorded)
    html = table._repr_html_()
    raw = [k for k in recorded if k in html or k.split("/", 1)[1] in html]
    assert not raw, f"raw result keys on the claims page: {raw}"
    summary = table.summary()
    assert [line.split(":")[0] for line in summary] == ["DisCoRD", "M2D2M"]
    by_paper = table.by_paper()
    for line, (paper, counts) in zip(summary, by_paper.items(), strict=True):
        assert line.startswith(paper)
        assert f"{counts[HOLDS]} of {sum(counts.values())} claims hold" in line
    assert sum(sum(c.values()) for c in by_paper.values()) == len(CLAIMS)
    assert html.index("DisCoRD</b>:") < html.index("<table")  # the summary comes before the table
    assert html.count('class="ml-mechanism"') == sum(bool(c.mechanism) for c in CLAIMS)


def test_chapter_findings_judge_the_chapters_claims_and_its_own_findings():
    rec = {
        "vq/mpjpe_vq": Result("vq", "mpjpe_vq", 40.0, None, "mm"),
        "vq/mpjpe_rvq": Result("vq", "mpjpe_rvq", 30.0, (29.0, 31.0), "mm"),
    }
    found = results.chapter_findings("vq", "smoke", recorded=rec)
    assert [r.verdict for r in found.rows] == [HOLDS, MISSING, MISSING]
    assert found.rows[0].ours == "MPJPE: 30.0 ± 1.0 mm (residual VQ) < 40.0 mm (VQ, one codebook)"
    html = found._repr_html_()
    assert "1 of 3 statements hold" in html and "mpjpe" not in html
    assert found.rows[0].runs == ""  # no training-seed study given: the verdict reads this build alone
    discord = results.chapter_findings("discord", "smoke", recorded={})
    assert len(discord.rows) == sum(c.keys[0].startswith("discord/") for c in CLAIMS)
    assert all(r.source.startswith("DisCoRD") and r.verdict == MISSING for r in discord.rows)
    with pytest.raises(ValueError, match="chapter prefix"):
        results.chapter_findings("nope", "smoke", recorded={})
    at_most = results.AtMost("motion_data/roundtrip_error", 1e-5)
    ok = {"motion_data/roundtrip_error": Result("motion_data", "roundtrip_error", 2e-7, None, "m")}
    assert at_most.judge(ok) == HOLDS and "at most 1e-05 m" in at_most.sentence(ok)
