"""What reproduces, at a glance: one compact table per paper, then every claim in full with its detail folded.

:func:`claims_overview` judges the claims once (:func:`~motionlab.report.render.claims_table`) and lays the judged
rows out for a first screen: per claim its statement, its verdict, one line of *why* (the first piece of evidence the
claim's registry entry names, as measured, without intervals; our numbers where it names none) and the scale at which
it holds beyond this build, or the largest scale tried (the budget study's multiples of the laptop's training steps,
the scale study's multiples of its training samples, the GPU benchmark for Table E's times). Cells stay short so that
nothing scrolls sideways; :meth:`Overview.details` shows the same rows in full, the long lines folded.

Every verdict is the claims table's own: the overview only shortens what it prints, never what it judges.
"""

from __future__ import annotations

import html
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace

from .budget import BudgetStudy, scale_statement
from .claims import CLAIMS
from .gpu import GPURun
from .quantities import quantity
from .render import (
    RECORDED,
    VERDICT_COLOURS,
    ClaimRow,
    ClaimsTable,
    claims_table,
    count_sentence,
    resolve_studies,
)
from .rules import Claim, describe_values
from .scale import ScaleStudy, study_scale
from .spread import TrainingSpread
from .store import FAILS, HOLDS, INCONCLUSIVE, MISSING, VERDICTS, Result

# one CSS class per verdict (its colour is the claims table's); the site and Jupyter both read the <style> below
VERDICT_CLASSES = {
    HOLDS: "ml-verdict-holds",
    FAILS: "ml-verdict-fails",
    INCONCLUSIVE: "ml-verdict-inconclusive",
    MISSING: "ml-verdict-missing",
}
HEADERS = ("claim", "verdict", "why, as measured", "at scale")

_STYLE = (
    "<style>"
    ".ml-overview table{width:100%;table-layout:fixed;font-size:0.78rem;line-height:1.3;margin:0.3em 0 1em 0}"
    ".ml-overview caption{caption-side:top;text-align:left;padding:0.2em 0}"
    ".ml-overview td,.ml-overview th{vertical-align:top;text-align:left;padding:0.15rem 0.35rem;"
    "overflow-wrap:break-word}"
    ".ml-overview .ml-where{opacity:0.7;font-size:0.9em;white-space:nowrap}"
    ".ml-overview details>summary{cursor:pointer;opacity:0.8}"
    ".ml-overview .ml-verdict{font-weight:bold;white-space:nowrap}"
    + "".join(f".ml-overview .{VERDICT_CLASSES[v]}{{color:{VERDICT_COLOURS[v]}}}" for v in VERDICTS)
    + "</style>"
)
# claim | verdict | why | at scale: the verdict column fits "does not hold" on one line
_COLUMNS = '<colgroup><col style="width:34%"><col style="width:7.6em"><col><col style="width:20%"></colgroup>'


def _drop_remarks(text: str, depth: int = 0) -> str:
    """``text`` without its parenthesised remarks deeper than ``depth``: depth 0 drops every ``" (...)"`` group that
    follows a space (``β(t,d)`` stays), depth 1 keeps the outer groups and drops those inside them."""
    out, level, dropped = [], 0, 0
    for i, ch in enumerate(text):
        if ch == "(":
            level += 1
            if level > depth and not dropped and (depth or (i and text[i - 1] == " ")):
                dropped = level
        if not dropped:
            out.append(ch)
        if ch == ")":
            if dropped == level:
                dropped = 0
            level -= 1
    return re.sub(r"\s+([.,;:)])", r"\1", re.sub(r" {2,}", " ", "".join(out))).strip()


def _bare(recorded: Mapping[str, Result]) -> dict[str, Result]:
    """``recorded`` without intervals: the overview prints values; the full table prints their intervals."""
    return {k: replace(r, ci=None) for k, r in recorded.items()}


def _values(keys: Sequence[str], recorded: Mapping[str, Result]) -> str:
    """``1.23 (TPS), 1.80 (actions decoded alone)``: each value named by its condition where the conditions tell the
    keys apart, else by its quantity and condition (remarks left out)."""
    names = [quantity(k) for k in keys]
    if len(keys) == 1:  # one number: what it is (its condition often repeats the evidence's label)
        return f"{recorded[keys[0]].describe()} ({_drop_remarks(names[0][0])})"
    short = [_drop_remarks(condition or name) for name, condition in names]
    if len(set(short)) < len(short):
        short = [_drop_remarks(f"{name}, {condition}" if condition else name) for name, condition in names]
    return ", ".join(f"{recorded[k].describe()} ({label})" for k, label in zip(keys, short, strict=True))


def why_line(claim: Claim, recorded: Mapping[str, Result]) -> str:
    """One line of why: the claim's first piece of evidence as measured (its label up to a colon, without remarks,
    then its values without intervals), or our numbers for the claim's own keys where it names no evidence; "" where
    those are not measured. The chapter's table at its end (``book.what_reproduces_here``) reads the same evidence."""
    bare = _bare(recorded)
    if claim.mechanism:
        evidence = claim.mechanism[0]
        if any(k not in recorded for k in evidence.keys):
            return ""
        values = _values(evidence.keys, bare)
        head = _drop_remarks(evidence.label).split(": ", 1)[0]  # what follows a colon, the values name again
        return f"{head}: {values}"
    if any(k not in recorded for k in claim.keys):
        return ""
    return "ours: " + _drop_remarks(describe_values(claim.keys, bare), 1)


def _reach(verdicts: Mapping[float, str], unit: str) -> tuple[str, str]:
    """``(reading, where)`` of a claim judged at several multiples: ``("holds from", "4× steps")``,
    ``("inconclusive up to", "10× steps")``, ``("does not hold at", "10× samples")``."""
    multiples = sorted(verdicts)
    largest = f"{multiples[-1]:g}× {unit}"
    holding = [m for m in multiples if verdicts[m] == HOLDS]
    if holding and all(verdicts[m] == HOLDS for m in multiples if m >= holding[0]):
        first = holding[0]
        return ("holds up to", largest) if first == multiples[0] else ("holds from", f"{first:g}× {unit}")
    if len(set(verdicts.values())) == 1:
        return f"{verdicts[multiples[-1]]} up to", largest
    return f"{verdicts[multiples[-1]]} at", largest


def scale_line(
    claim: Claim,
    profile: str,
    budget: BudgetStudy | None = None,
    scale: ScaleStudy | None = None,
    on_gpu: Mapping[str, Result] | None = None,
) -> str:
    """Where ``claim`` holds beyond this build, or what it reads at the largest scale tried, in a few words:
    multiples of the laptop's training steps (the budget study) and training samples (the scale study), and Table E's
    times on a GPU. Readings that agree are said once: ``"holds from 4× steps, 10× samples"``."""
    readings: dict[str, list[str]] = {}
    if budget is not None and (by_steps := scale_statement(claim, budget)) is not None:
        verdicts = {steps / by_steps.laptop_steps: v for steps, v in by_steps.verdicts.items()}
        reading, where = _reach(verdicts, "steps")
        readings.setdefault(reading, []).append(where)
    if scale is not None and (by_samples := study_scale(claim, scale)) is not None:
        reading, where = _reach(by_samples.verdicts, "samples")
        readings.setdefault(reading, []).append(where)
    parts = [f"{reading} {', '.join(where)}" for reading, where in readings.items()]
    if on_gpu and claim.keys and all(k in on_gpu for k in claim.keys):
        parts.append(f"on a GPU: {claim.rule.judge(on_gpu, None)}")
    return "; ".join(parts) if parts else f"only at {profile} scale"


@dataclass(frozen=True)
class OverviewRow:
    """One claim as the overview prints it: short cells, the verdict as judged in the claims table."""

    claim: str  # the statement, its parenthesised remarks left out
    source: str  # where the paper makes it: "Table 1"
    chapter: str  # the chapter that measures it: "05 DisCoRD"
    verdict: str
    why: str  # one line of :func:`why_line` ("" where not measured)
    scale: str  # :func:`scale_line`


def _verdict_html(verdict: str) -> str:
    return f'<span class="ml-verdict {VERDICT_CLASSES[verdict]}">{html.escape(verdict)}</span>'


def _markdown_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


@dataclass
class PaperOverview:
    """The overview of one paper's claims: a table one screen high (HTML in Jupyter and the book, else Markdown)."""

    paper: str
    profile: str
    rows: list[OverviewRow] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {v: sum(row.verdict == v for row in self.rows) for v in VERDICTS}

    def caption(self) -> str:
        """``DisCoRD: 7 of 12 claims hold, 3 do not hold, 2 inconclusive (profile laptop)``."""
        return f"{self.paper}: {count_sentence(self.counts())} (profile {self.profile})"

    def html(self, style: bool = True) -> str:
        esc = html.escape
        body = []
        for row in self.rows:
            where = f"{row.source} · ch. {row.chapter.split(' ', 1)[0]}"
            body.append(
                f"<tr><td>{esc(row.claim)} <span class='ml-where'>{esc(where)}</span></td>"
                f"<td>{_verdict_html(row.verdict)}</td><td>{esc(row.why) or '—'}</td><td>{esc(row.scale)}</td></tr>"
            )
        head = "".join(f"<th>{h}</th>" for h in HEADERS)
        return (
            f'<div class="ml-overview">{_STYLE if style else ""}<table class="ml-overview-table">'
            f"<caption><b>{esc(self.paper)}</b>: {esc(count_sentence(self.counts()))}</caption>{_COLUMNS}"
            f"<thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table></div>"
        )

    def _repr_html_(self) -> str:
        return self.html()

    def _repr_markdown_(self) -> str:
        lines = [f"**{self.paper}**: {count_sentence(self.counts())}", ""]
        lines += ["| " + " | ".join(HEADERS) + " |", "|---" * len(HEADERS) + "|"]
        for row in self.rows:
            claim = f"{row.claim} ({row.source}, ch. {row.chapter.split(' ', 1)[0]})"
            cells = (claim, f"**{row.verdict}**", row.why or "—", row.scale)
            lines.append("| " + " | ".join(_markdown_cell(c) for c in cells) + " |")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self._repr_markdown_()


@dataclass(frozen=True)
class DetailRow:
    """One claim in full: the judged row, our numbers alone, and what the verdict reads besides them."""

    row: ClaimRow
    ours: str  # our numbers for the claim's keys, with their intervals
    runs: str  # the training runs and test-clip draws the verdict averages over ("" where none)


@dataclass
class ClaimsDetail:
    """Every claim in full, one row each (verdict, claim, the paper's numbers, ours), with why as measured, the
    scales tried and the runs behind the verdict folded under the row."""

    rows: list[DetailRow]
    profile: str
    table: ClaimsTable  # the judged table the rows come from (its Markdown is this table's)

    def _repr_html_(self) -> str:
        esc = html.escape
        body = []
        for detail in self.rows:
            row = detail.row
            folded = [
                (title, lines)
                for title, lines in (
                    ("why, as measured", row.mechanism),
                    ("at other scales", row.scale),
                    ("what the verdict averages over", detail.runs),
                )
                if lines
            ]
            more = "".join(
                f"<p style='margin:0.2em 0'><b>{title}:</b><br>"
                + "<br>".join(esc(line) for line in lines.split("\n") if line)
                + "</p>"
                for title, lines in folded
            )
            fold = f"<details><summary>{', '.join(t for t, _ in folded)}</summary>{more}</details>" if folded else ""
            body.append(
                f"<tr><td>{_verdict_html(row.verdict)}</td><td>{esc(row.statement)}<br><span class='ml-where'>"
                f"{esc(row.paper)}, {esc(row.source)} · ch. {esc(row.chapter.split(' ', 1)[0])}</span></td>"
                f"<td>{esc(row.paper_value)}</td><td>{esc(detail.ours)}{fold}</td></tr>"
            )
        return (
            f'<div class="ml-overview">{_STYLE}<table class="ml-claims-detail">'
            '<colgroup><col style="width:7.2em"><col style="width:34%"><col style="width:22%"><col></colgroup>'
            "<thead><tr><th>verdict</th><th>claim</th><th>paper</th><th>ours</th></tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table></div>"
        )

    def _repr_markdown_(self) -> str:
        return self.table.to_markdown()


@dataclass
class Overview:
    """One :class:`PaperOverview` per paper, in the claims' order; shows them one after the other."""

    papers: list[PaperOverview]
    table: ClaimsTable  # the judged claims table behind every row
    detail_rows: list[DetailRow] = field(default_factory=list, repr=False)

    def __iter__(self) -> Iterator[PaperOverview]:
        return iter(self.papers)

    def __getitem__(self, paper: str) -> PaperOverview:
        for overview in self.papers:
            if overview.paper == paper:
                return overview
        raise KeyError(f"no claims of {paper!r}; papers: {[p.paper for p in self.papers]}")

    @property
    def rows(self) -> list[OverviewRow]:
        return [row for paper in self.papers for row in paper.rows]

    def details(self) -> ClaimsDetail:
        """Every claim in full, the long lines folded (:class:`ClaimsDetail`)."""
        return ClaimsDetail(self.detail_rows, self.table.profile, self.table)

    def _repr_html_(self) -> str:
        return _STYLE + "".join(paper.html(style=False) for paper in self.papers)

    def _repr_markdown_(self) -> str:
        return "\n\n".join(paper._repr_markdown_() for paper in self.papers)

    def __str__(self) -> str:
        return self._repr_markdown_()


def claims_overview(
    profile: str | None = None,
    recorded: Mapping[str, Result] | None = None,
    claims: Sequence[Claim] = CLAIMS,
    spread: TrainingSpread | str | None = RECORDED,
    budget: BudgetStudy | str | None = RECORDED,
    scale: ScaleStudy | str | None = RECORDED,
    gpu: GPURun | str | None = RECORDED,
) -> Overview:
    """The claims judged as :func:`~motionlab.report.render.claims_table` judges them (same arguments, same
    studies), laid out per paper for a first screen; ``.details()`` holds every row in full."""
    studies = resolve_studies(profile, recorded, spread, budget, scale, gpu)
    profile, recorded, on_gpu = studies.profile, studies.recorded, studies.on_gpu
    table = claims_table(profile, recorded, claims, studies.spread, studies.budget, studies.scale, studies.gpu)
    papers: dict[str, PaperOverview] = {}
    details = []
    for claim, row in zip(claims, table, strict=True):
        papers.setdefault(row.paper, PaperOverview(row.paper, profile)).rows.append(
            OverviewRow(
                _drop_remarks(row.statement),
                row.source,
                row.chapter,
                row.verdict,
                why_line(claim, recorded),
                scale_line(claim, profile, studies.budget, studies.scale, on_gpu),
            )
        )
        details.append(DetailRow(row, row.numbers, row.runs.removeprefix("; ")))
    return Overview(list(papers.values()), table, details)
