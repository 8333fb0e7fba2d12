"""The first screen of "What reproduces": one short table per paper, the verdicts the claims table judges."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from motionlab.report import overview as ov
from motionlab.report.claims import CLAIMS
from motionlab.report.render import claims_table
from motionlab.report.rules import Claim, Evidence, Less
from motionlab.report.store import FAILS, HOLDS, INCONCLUSIVE, MISSING, Result

ROOT = Path(__file__).resolve().parents[2]
NO_STUDIES = {"spread": None, "budget": None, "scale": None, "gpu": None}


def recorded_for(claims, value_of) -> dict[str, Result]:
    """Every key the claims and their evidence read, valued by ``value_of(key)`` with a 2% interval."""
    keys = dict.fromkeys(k for c in claims for k in (*c.keys, *c.mechanism_keys))
    out = {}
    for key in keys:
        value = value_of(key)
        chapter, name = key.split("/", 1)
        out[key] = Result(chapter, name, value, (0.98 * value, 1.02 * value), note="test", profile="smoke")
    return out


def test_one_table_per_paper_with_the_claims_tables_own_verdicts():
    recorded = recorded_for(CLAIMS, lambda key: 1.0 + (hash(key) % 97) / 50)
    overview = ov.claims_overview("smoke", recorded, **NO_STUDIES)
    table = claims_table("smoke", recorded, **NO_STUDIES)
    assert [p.paper for p in overview] == ["DisCoRD", "M2D2M"]
    assert [row.verdict for row in overview.rows] == [row.verdict for row in table]
    assert len(overview["DisCoRD"].rows) + len(overview["M2D2M"].rows) == len(CLAIMS)
    assert {row.verdict for row in overview.rows} <= {HOLDS, FAILS, INCONCLUSIVE}
    with pytest.raises(KeyError, match="papers"):
        overview["MoMask"]
    for row, claim in zip(overview.rows, CLAIMS, strict=True):
        assert " (" not in row.claim and row.claim.endswith(".")  # remarks left out, the sentence kept
        assert row.scale == "only at smoke scale"  # no study given: nothing beyond this build
        if claim.mechanism:
            assert row.why.startswith(claim.mechanism[0].label.split(" (")[0].split(": ")[0])
        else:
            assert row.why.startswith("ours: ")
        assert "±" not in row.why  # values only: the full table has the intervals
    assert "β(t,d)" in " ".join(row.claim for row in overview.rows)  # a symbol's parentheses are not a remark


def test_html_colours_verdicts_by_class_and_markdown_is_a_table():
    claims = (
        Claim("P", "Table 1", "A is lower (on purpose).", "1 → 2", Less("x/a", "x/b")),
        Claim("P", "Table 2", "B is lower.", "", Less("x/b", "x/a"), (Evidence("why (remark): more", ("x/c",)),)),
        Claim("Q", "Fig. 1", "C is lower.", "", Less("x/c", "x/d")),
        Claim("Q", "Fig. 2", "D is lower.", "", Less("x/d", "x/e")),
    )
    values = {"x/a": 1.0, "x/b": 2.0, "x/c": 3.0, "x/d": 3.01}
    recorded = {k: Result("x", k[2:], v, (v - 0.1, v + 0.1), profile="smoke") for k, v in values.items()}
    overview = ov.claims_overview("smoke", recorded, claims, **NO_STUDIES)
    assert [r.verdict for r in overview.rows] == [HOLDS, FAILS, INCONCLUSIVE, MISSING]
    first, second = overview["P"].rows
    assert first.claim == "A is lower." and first.why == "ours: a 1.00 < b 2.00"
    assert second.why == "why: 3.00 (c)"
    assert overview["Q"].rows[1].why == ""
    page = overview._repr_html_()
    for verdict in (HOLDS, FAILS, INCONCLUSIVE, MISSING):
        css = ov.VERDICT_CLASSES[verdict]
        assert f'class="ml-verdict {css}"' in page and f".{css}{{color:" in page
    assert page.count("<table") == 2 and page.count("<style>") == 1
    assert "<th>why, as measured</th>" in page and "Table 2 · ch. x" in page
    markdown = overview._repr_markdown_()
    assert markdown.startswith("**P**: 1 of 2 claims hold, 1 do not hold")
    assert "| claim | verdict | why, as measured | at scale |" in markdown
    assert "| B is lower. (Table 2, ch. x) | **does not hold** | why: 3.00 (c) | only at smoke scale |" in markdown
    assert str(overview["Q"]).count("\n|") == 4  # header, rule, two rows
    details = overview.details()
    assert details._repr_markdown_() == overview.table.to_markdown()
    html = details._repr_html_()
    assert html.count("<details>") == 1 and "why (remark): more: 3.00" in html  # the evidence in full, folded


def test_the_scale_cell_says_where_a_claim_holds_or_the_largest_scale_tried():
    assert ov._reach({1: INCONCLUSIVE, 4: HOLDS, 10: HOLDS}, "steps") == ("holds from", "4× steps")
    assert ov._reach({10: HOLDS, 30: HOLDS}, "samples") == ("holds up to", "30× samples")
    assert ov._reach({1: INCONCLUSIVE, 10: INCONCLUSIVE}, "steps") == ("inconclusive up to", "10× steps")
    assert ov._reach({1: HOLDS, 10: FAILS}, "steps") == ("does not hold at", "10× steps")
    assert ov._reach({1: FAILS, 4: HOLDS, 10: INCONCLUSIVE}, "steps") == ("inconclusive at", "10× steps")
    # Table E's times on a GPU, judged by the claim's own rule
    time_claim = next(c for c in CLAIMS if c.keys == ("discord/time_steps2", "discord/time_steps16"))
    on_gpu = {k: Result(*k.split("/"), v, unit="s", profile="full") for k, v in zip(time_claim.keys, (0.02, 0.1))}
    assert ov.scale_line(time_claim, "laptop", on_gpu=on_gpu) == "on a GPU: holds"


def test_the_laptop_studies_fill_the_m2d2m_scale_cells():
    from motionlab.report.budget import load_budget
    from motionlab.report.scale import load_scale_study

    budget, scale = load_budget("laptop"), load_scale_study("laptop")
    if budget is None:
        pytest.skip("no budget study committed under book/data/m2d2m_budget")
    lines = {c.statement: ov.scale_line(c, "laptop", budget, scale) for c in CLAIMS if c.paper == "M2D2M"}
    by_steps = [line for line in lines.values() if "× steps" in line]
    assert by_steps, lines
    verdict = re.compile(r"^(holds|does not hold|inconclusive) (from|up to|at) \d")
    assert all(verdict.match(line) for line in by_steps)
    assert all(len(line) < 70 for line in lines.values())  # a short cell


def test_chapter_99_opens_with_the_overview_and_the_studies_page_is_in_the_book():
    chapter = json.loads((ROOT / "notebooks" / "99_what_reproduces.ipynb").read_text())
    cells = [c for c in chapter["cells"] if "remove-cell" not in c["metadata"].get("tags", [])]
    title, first_code = cells[0], next(c for c in cells if c["cell_type"] == "code")
    assert "".join(title["source"]).startswith("# What reproduces") and "claims_overview(" in "".join(
        first_code["source"]
    )
    toc = yaml.safe_load((ROOT / "book" / "_toc.yml").read_text())
    studies = next(part for part in toc["parts"] if part["caption"] == "Studies")
    assert {"file": "notebooks/s6_judging_verdicts"} in studies["chapters"]
    from motionlab.build.book_models import CHAPTER_MODELS
    from motionlab.build.notebook_runner import runs_last

    assert CHAPTER_MODELS["s6_judging_verdicts"] == ()  # it trains nothing
    assert runs_last(ROOT / "notebooks" / "s6_judging_verdicts.ipynb")  # it reads what the chapters recorded
