"""Measured results and the papers' claims they are judged against: the names chapters and tests import.

The implementation lives in :mod:`motionlab.report` (``store``: recording; ``quantities``: what each key measures;
``rules``: how a claim is judged, by the one comparison rule; ``claims``: the registry; ``render``: the claims table
and a chapter's findings box). This module keeps ``from motionlab import results; results.record(...)`` working::

    from motionlab import results
    results.record("discord", "sjpe_rf", estimate, note="16 Euler steps, 64 clips")
    results.claims_table().to_markdown()
"""

from __future__ import annotations

from motionlab.estimate import format_estimate
from motionlab.report.budget import BudgetStudy, EtaAxis, load_budget, load_eta_axis
from motionlab.report.claims import CLAIMS, FINDINGS, PAPER_NUMBERS, Finding, claim_keys, paper_results
from motionlab.report.quantities import QUANTITIES, quantity
from motionlab.report.render import (
    VERDICT_COLOURS,
    ChapterFindings,
    ClaimRow,
    ClaimsTable,
    FindingRow,
    chapter_findings,
    claims_table,
    count_sentence,
    judge,
    repeat_check,
    spread_table,
    verdicts_by_run,
)
from motionlab.report.rules import AtMost, Between, Claim, Evidence, Greater, Increasing, Less, Rule, Within
from motionlab.report.scale import ScaleStudy, load_scale_study, scale_study_note, scale_verdicts
from motionlab.report.spread import TrainingSpread, load_spread
from motionlab.report.store import (
    CHAPTERS,
    FAILS,
    HOLDS,
    INCONCLUSIVE,
    MISSING,
    RESULTS_ENV,
    VERDICTS,
    Result,
    load_all,
    record,
    record_table,
    results_dir,
)

__all__ = [
    "CHAPTERS",
    "CLAIMS",
    "FAILS",
    "FINDINGS",
    "HOLDS",
    "INCONCLUSIVE",
    "MISSING",
    "PAPER_NUMBERS",
    "QUANTITIES",
    "RESULTS_ENV",
    "VERDICTS",
    "VERDICT_COLOURS",
    "AtMost",
    "Between",
    "BudgetStudy",
    "ChapterFindings",
    "Claim",
    "ClaimRow",
    "ClaimsTable",
    "EtaAxis",
    "Evidence",
    "Finding",
    "FindingRow",
    "Greater",
    "Increasing",
    "Less",
    "Result",
    "Rule",
    "ScaleStudy",
    "TrainingSpread",
    "Within",
    "chapter_findings",
    "claim_keys",
    "claims_table",
    "count_sentence",
    "format_estimate",
    "paper_results",
    "judge",
    "load_all",
    "load_budget",
    "load_eta_axis",
    "load_scale_study",
    "load_spread",
    "quantity",
    "record",
    "record_table",
    "results_dir",
    "repeat_check",
    "scale_study_note",
    "scale_verdicts",
    "spread_table",
    "verdicts_by_run",
]
