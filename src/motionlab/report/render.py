"""The claims table and a chapter's findings box: judged rows, rendered as HTML (site) and Markdown."""

from __future__ import annotations

import html
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace

from motionlab.comparison import compare, this_build
from motionlab.estimate import format_estimate, format_number
from motionlab.profiles import get_profile
from motionlab.viz.tables import Table

from .budget import BudgetStudy, load_budget, scale_statement
from .claims import CLAIMS, FINDINGS
from .gpu import GPURun, newest_gpu_run, table_e_results
from .quantities import quantity
from .rules import Claim, Within, training_difference
from .scale import ScaleStudy, load_scale_study, study_scale
from .spread import TrainingSpread, load_spread
from .store import CHAPTERS, FAILS, HOLDS, INCONCLUSIVE, MISSING, VERDICTS, Result, load_all

# ----------------------------------------------------------------------------------------------
# The table


@dataclass(frozen=True)
class ClaimRow:
    paper: str
    source: str
    statement: str
    paper_value: str
    rule: str
    chapter: str
    ours: str  # our numbers as a phrase, with units and intervals (see describe_values)
    verdict: str
    missing: tuple[str, ...] = ()
    mechanism: str = ""  # one line per Evidence, from the recorded numbers ("" when the claim has none)
    # the claim judged at other training budgets (report.budget) and multiples of the laptop's training samples
    # (report.scale), one line each; "" where neither was measured
    scale: str = ""
    numbers: str = ""  # ``ours`` without the training runs: this build's numbers alone
    runs: str = ""  # what the verdict reads besides this build (``retraining_phrase``); ``ours = numbers + runs``


VERDICT_COLOURS = {HOLDS: "#1a7f37", FAILS: "#cf222e", INCONCLUSIVE: "#9a6700", MISSING: "#57606a"}


def _verdict_html(verdict: str) -> str:
    style = f"color:{VERDICT_COLOURS[verdict]};font-weight:bold"
    return f'<span class="ml-verdict" style="{style}">{html.escape(verdict)}</span>'


def count_sentence(counts: Mapping[str, int], noun: str = "claims") -> str:
    """``5 of 11 claims hold, 4 do not hold, 2 inconclusive``: the verdicts of a group, in words."""
    total = sum(counts.values())
    parts = [f"{counts.get(HOLDS, 0)} of {total} {noun} hold"]
    parts += [
        f"{counts[v]} {'do not hold' if v == FAILS else v}" for v in (FAILS, INCONCLUSIVE, MISSING) if counts.get(v)
    ]
    return ", ".join(parts)


@dataclass
class ClaimsTable:
    """Rows of :func:`claims_table`; renders as HTML in Jupyter and in the book: a summary line per paper, then
    one row per claim (verdict, claim, the paper's number, ours as a phrase) and, under a claim whose mechanism was
    measured, a full-width line with it."""

    rows: list[ClaimRow] = field(default_factory=list)
    profile: str = "laptop"

    def __iter__(self) -> Iterator[ClaimRow]:
        return iter(self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    def counts(self) -> dict[str, int]:
        return {v: sum(row.verdict == v for row in self.rows) for v in VERDICTS}

    def by_paper(self) -> dict[str, dict[str, int]]:
        """``{paper: {verdict: count}}``, papers in the order of the rows."""
        out: dict[str, dict[str, int]] = {}
        for row in self.rows:
            out.setdefault(row.paper, dict.fromkeys(VERDICTS, 0))[row.verdict] += 1
        return out

    def summary(self) -> list[str]:
        """One line per paper: ``DisCoRD: 5 of 11 claims hold, 4 do not hold, 2 inconclusive``."""
        return [f"{paper}: {count_sentence(counts)}" for paper, counts in self.by_paper().items()]

    def _repr_html_(self) -> str:
        return self.html()

    def html(self, summary: bool = True) -> str:
        """The table as HTML; ``summary=False`` leaves out the summary lines (shown elsewhere on the page)."""
        esc = html.escape
        out = ['<div class="ml-claims">']
        for paper, counts in self.by_paper().items() if summary else ():
            out.append(
                f'<p class="ml-claims-summary" style="margin:0.2em 0"><b>{esc(paper)}</b>: '
                f"{esc(count_sentence(counts))}.</p>"
            )
        out += [
            '<table class="ml-claims-table" style="width:100%;font-size:0.9em">',
            f"<caption>Claims vs. our measurements (profile <code>{esc(self.profile)}</code>)</caption>",
            '<colgroup><col style="width:7.5em"><col style="width:36%"><col style="width:24%"><col></colgroup>',
            "<thead><tr><th>Verdict</th><th>Claim</th><th>Paper</th><th>Ours</th></tr></thead><tbody>",
        ]
        for row in self.rows:
            claim = (
                f"{esc(row.statement)}<br><small>{esc(row.paper)}, {esc(row.source)} &middot; "
                f"chapter {esc(row.chapter)}</small>"
            )
            out.append(
                f"<tr><td>{_verdict_html(row.verdict)}</td><td>{claim}</td><td>{esc(row.paper_value)}</td>"
                f"<td>{esc(row.ours)}</td></tr>"
            )
            if row.mechanism:
                lines = "<br>".join(esc(line) for line in row.mechanism.split("\n") if line)
                out.append(
                    f'<tr class="ml-mechanism"><td></td><td colspan="3"><small><b>Why, as measured:</b> '
                    f"{lines}</small></td></tr>"
                )
            if row.scale:
                lines = "<br>".join(esc(line) for line in row.scale.split("\n") if line)
                out.append(
                    f'<tr class="ml-scale"><td></td><td colspan="3"><small><b>At other scales:</b> '
                    f"{lines}</small></td></tr>"
                )
        out.append("</tbody></table></div>")
        return "\n".join(out)

    def to_markdown(self) -> str:
        out = [f"- {line}" for line in self.summary()] + [""]
        out += ["| Paper | Where | Claim | Paper | Ours | Verdict | Measured mechanism | Measured scale |"]
        out += ["|---" * 8 + "|"]
        for r in self.rows:
            mechanism, scale = r.mechanism.replace("\n", "; "), r.scale.replace("\n", "; ")
            cells = (r.paper, r.source, r.statement, r.paper_value, r.ours, r.verdict, mechanism, scale)
            out.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
        return "\n".join(out)


RECORDED = "recorded"  # the default of spread=, budget= and scale=: the study recorded for the profile, if any


def _study(value, kind: type, load, profile: str, name: str):
    """``spread=``, ``budget=`` or ``scale=`` resolved: the study recorded for ``profile``, None, or the one given."""
    if value == RECORDED:
        return load(profile)
    if value is not None and not isinstance(value, kind):
        raise TypeError(f"{name} must be a {kind.__name__}, None or {RECORDED!r}, got {type(value).__name__}")
    return value


def retraining_phrase(rule, recorded: Mapping[str, Result], spread: TrainingSpread | None) -> str:
    """What the verdict reads besides this build's numbers (``""`` where nothing else was measured): each difference
    the rule judges averaged over the training runs, and how far another draw of test clips moves it."""
    parts = []
    for a, b in getattr(rule, "pairs", ()):
        if a in recorded and b in recorded and (others := training_difference(recorded[a], recorded[b], spread)):
            pooled = compare(recorded[a].estimate, recorded[b].estimate, training=others).pooled
            runs = f"{pooled.n} training runs (this build and {pooled.n - 1} recorded)"
            parts.append(f"{format_estimate(pooled.mean, pooled.half_width, pooled.unit)} over {runs}")
    text = f"; the difference averages {', '.join(parts)}" if parts else ""
    if isinstance(rule, Within) and all(k in recorded for k in rule.keys) and (means := rule.pooled(recorded, spread)):
        a, b, n = means
        values = ", ".join(format_estimate(x, unit=recorded[rule.a].unit) for x in (a, b))
        text += f"; averaged over {n} training runs (this build and {n - 1} recorded): {values}, {Within.apart(a, b)}"
    clips = rule.test_set(recorded) if hasattr(rule, "test_set") else None
    if clips is not None:
        half = format_estimate(clips.estimate.half_width, unit=clips.unit, significant=2)
        text += f"; another draw of test clips moves the difference by ± {half} (a paired bootstrap over the clips)"
    return text


def spread_table(spread: TrainingSpread, claims: Sequence[Claim] = CLAIMS) -> Table:
    """Every comparison of ``claims`` the training-seed study measured: ``a − b`` on each run, the spread of one
    training run's difference, and the mean over the runs with its interval (``t · sd / √k``: the verdict reads this
    mean once this build joins it) as a :class:`~motionlab.viz.tables.Table`."""
    rows: dict[str, dict] = {}
    for claim in claims:
        for a, b in getattr(claim.rule, "pairs", ()):
            difference = spread.difference(a, b)
            if difference is None:
                continue
            runs, half = spread.runs(a, b), difference.half_width
            decimals = max(0, 1 - math.floor(math.log10(half))) if half > 0 else None  # two digits of the spread
            by_precision: dict[str, list[str]] = {}
            for r in runs:
                by_precision.setdefault(r.precision, []).append(
                    format_number(spread.values[a][r] - spread.values[b][r], decimals)
                )
            per_run = "; ".join(f"{p}: {', '.join(v)}" for p, v in by_precision.items())
            (name, condition_a), (_, condition_b) = quantity(a), quantity(b)
            label = f"{claim.statement} ({name}: {condition_a} − {condition_b})"
            mean = format_number(difference.mean, decimals)
            rows[label] = {"training runs": len(runs), "a − b on each run": per_run}
            rows[label]["± one run (t · sd)"] = format_number(half, decimals)
            rows[label]["mean ± its 95% interval"] = f"{mean} ± {format_number(half / math.sqrt(len(runs)), decimals)}"
    if not rows:
        raise ValueError("the training-seed study measured none of these claims' comparisons")
    return Table("claim (a − b)", rows, notes=(f"measured on {spread.data}: " + "; ".join(spread.measured),))


def verdicts_by_run(spread: TrainingSpread, recorded: Mapping[str, Result], claims: Sequence[Claim] = CLAIMS) -> Table:
    """Would a build on another machine read the same verdicts? Each claim whose numbers the training-run study
    measured, judged as if this build's models had landed where each recorded run landed (a seed, in bf16 on one CPU
    or fp32 on another): that run's numbers in place of the chapter's, each keeping the chapter's measurement
    interval, averaged with the other recorded runs by the claims table's rule. A row whose verdicts differ between
    runs is one that another machine can flip.

    Columns: this build's verdict, then one column per precision listing the recorded runs by verdict (e.g.
    ``holds: seeds 0, 2; inconclusive: seed 1``), then whether every verdict agrees.
    """
    rows: dict[str, dict] = {}
    for claim in claims:
        if any(k not in recorded for k in claim.keys):
            continue
        # the keys a run changes; the others (real data, ground truth) stay as recorded
        studied = [k for k in claim.keys if spread.moves(k, recorded[k].note)]
        runs = spread.runs(*studied) if studied else []
        if not runs:
            continue
        verdicts: dict = {}
        for run in runs:
            as_run = dict(recorded)
            for key in studied:
                shift = spread.values[key][run] - recorded[key].value
                ci = recorded[key].ci
                as_run[key] = replace(
                    recorded[key],
                    value=spread.values[key][run],
                    ci=None if ci is None else (ci[0] + shift, ci[1] + shift),
                )
            verdicts[run] = claim.rule.judge(as_run, spread)
        here = claim.rule.judge(recorded, spread)
        row = {"this build": here}
        for precision in sorted({run.precision for run in verdicts}):
            row[f"{precision} runs"] = _runs_by_verdict({r: v for r, v in verdicts.items() if r.precision == precision})
        row["agree"] = "yes" if set(verdicts.values()) == {here} else "no"
        rows[f"{claim.paper}: {claim.statement}"] = row
    if not rows:
        raise ValueError("the training-run study measured none of these claims' numbers")
    return Table("claim", rows, notes=(f"measured on {spread.data}: " + "; ".join(spread.measured),))


def _runs_by_verdict(verdicts: Mapping) -> str:
    """``{run: verdict}`` of one precision as ``"holds: seeds 0, 2; inconclusive: seed 1"`` (a cell that wraps)."""
    by_verdict: dict[str, list[int]] = {}
    for run, verdict in sorted(verdicts.items()):
        by_verdict.setdefault(verdict, []).append(run.seed)
    return "; ".join(
        f"{verdict}: seed{'s' if len(seeds) > 1 else ''} {', '.join(map(str, seeds))}"
        for verdict, seeds in by_verdict.items()
    )


def repeat_check(spread: TrainingSpread, recorded: Mapping[str, Result]) -> str:
    """How closely this build repeats the recorded run whose place it takes in the verdicts (seed 0 in its
    precision), as a sentence: for each number the study measured on this data, the gap in run-to-run standard
    deviations (its sd over the recorded runs). Near 0: the same models, trained again; about 1: another run (another
    CPU of that precision); far above 1 on many numbers: the recorded study is stale (the models have changed since)."""
    from statistics import median, stdev

    on_data = [r for r in recorded.values() if spread.moves(r.name, r.note)]
    precisions = {r.precision for r in on_data}
    if not on_data or len(precisions) != 1 or None in precisions:
        return "this build's precision is not recorded with its numbers: it joins the recorded runs as one more"
    build = this_build(precisions.pop())
    gaps = []
    for r in on_data:
        runs = spread.values[r.name]
        sd = stdev(runs.values()) if len(runs) > 1 else 0.0
        if build in runs and sd > 0:
            gaps.append(abs(r.value - runs[build]) / sd)
    if not gaps:
        return f"no recorded run is {build}: this build joins the recorded runs as one more"
    return (
        f"this build takes the place of {build}: over {len(gaps)} numbers it lies a median {median(gaps):.2f} (at "
        f"most {max(gaps):.2f}) run-to-run standard deviations from that run (0: the same models trained again)"
    )


def judge(
    claim: Claim,
    recorded: Mapping[str, Result],
    spread: TrainingSpread | None = None,
    budget: BudgetStudy | None = None,
    scale: ScaleStudy | None = None,
    gpu: Mapping[str, Result] | None = None,
) -> ClaimRow:
    """One row: the claim, our numbers for its keys (a phrase with units and intervals), and the verdict.

    ``spread``: the training-seed study's (:mod:`motionlab.report.spread`); where it measured a comparison's keys,
    its between-run spread joins the verdict's interval and the phrase says how large it is. ``budget``: the budget
    study's (:mod:`motionlab.report.budget`); where it measured the claim's keys, the row says how the claim fares at
    each training budget. ``scale``: the scale study's (:mod:`motionlab.report.scale`), likewise at each multiple of
    the laptop's training samples. ``gpu``: Table E's times as a GPU benchmark run measured them
    (:func:`motionlab.report.gpu.table_e_results`); a claim about them is judged on those too, by the same rule.
    """
    by_budget = scale_statement(claim, budget) if budget is not None else None
    by_samples = study_scale(claim, scale) if scale is not None else None
    scale_lines = [s.sentence() for s in (by_budget, by_samples) if s is not None]
    if gpu is not None and (on_gpu := gpu_line(claim, gpu)):
        scale_lines.append(on_gpu)
    missing = tuple(k for k in claim.keys if k not in recorded)
    verdict = MISSING if missing else claim.rule.judge(recorded, spread)
    mechanism = "\n".join(e.format(recorded) for e in claim.mechanism)
    numbers = claim.rule.sentence(recorded)
    runs = "" if missing else retraining_phrase(claim.rule, recorded, spread)
    return ClaimRow(
        claim.paper,
        claim.source,
        claim.statement,
        claim.paper_value,
        claim.rule.describe(),
        claim.chapter,
        numbers + runs,
        verdict,
        missing,
        mechanism,
        "\n".join(scale_lines),
        numbers,
        runs,
    )


def gpu_line(claim: Claim, on_gpu: Mapping[str, Result]) -> str | None:
    """``claim`` judged on Table E's times as measured on a GPU (:func:`motionlab.report.gpu.table_e_results`), as one
    line (None where the claim reads other keys, or the run did not time them)."""
    if not claim.keys or any(k not in on_gpu for k in claim.keys):
        return None
    where = next(iter(on_gpu.values())).note
    return f"On a GPU ({where}): {claim.rule.sentence(on_gpu)}; {claim.rule.judge(on_gpu, None)}"


def claims_table(
    profile: str | None = None,
    recorded: Mapping[str, Result] | None = None,
    claims: Sequence[Claim] = CLAIMS,
    spread: TrainingSpread | str | None = RECORDED,
    budget: BudgetStudy | str | None = RECORDED,
    scale: ScaleStudy | str | None = RECORDED,
    gpu: GPURun | str | None = RECORDED,
) -> ClaimsTable:
    """Judge every claim on the results recorded for ``profile`` (or on ``recorded`` if given), with the training-seed
    spread recorded for the profile (``spread=None``: on the measurements' intervals alone), and with each claim's
    verdicts at the budget study's training budgets where it was recorded (``budget=None``: without) and at the scale
    study's multiples of the laptop's training samples (``scale=None``: without), and Table E's speed claims on the
    newest GPU benchmark run in ``book/data/gpu`` (``gpu=None``: without)."""
    studies = resolve_studies(profile, recorded, spread, budget, scale, gpu)
    return ClaimsTable([judge(c, *studies.judged_with()) for c in claims], studies.profile)


@dataclass(frozen=True)
class Studies:
    """What a claim is judged on: the numbers recorded for a profile and the studies recorded beside them (each None
    where not recorded or not wanted)."""

    profile: str
    recorded: Mapping[str, Result]
    spread: TrainingSpread | None
    budget: BudgetStudy | None
    scale: ScaleStudy | None
    gpu: GPURun | None

    @property
    def on_gpu(self) -> Mapping[str, Result] | None:
        """Table E's times as the GPU run measured them (:func:`motionlab.report.gpu.table_e_results`)."""
        return table_e_results(self.gpu) if self.gpu is not None else None

    def judged_with(self) -> tuple:
        """:func:`judge`'s arguments after the claim."""
        return self.recorded, self.spread, self.budget, self.scale, self.on_gpu


def resolve_studies(
    profile: str | None = None,
    recorded: Mapping[str, Result] | None = None,
    spread: TrainingSpread | str | None = RECORDED,
    budget: BudgetStudy | str | None = RECORDED,
    scale: ScaleStudy | str | None = RECORDED,
    gpu: GPURun | str | None = RECORDED,
) -> Studies:
    """The profile validated, its recorded numbers (or ``recorded``), and each study: the one recorded for the
    profile (:data:`RECORDED`), None, or the one given (:func:`claims_table` explains each)."""
    profile = get_profile(profile)
    return Studies(
        profile,
        load_all(profile) if recorded is None else recorded,
        _study(spread, TrainingSpread, load_spread, profile, "spread"),
        _study(budget, BudgetStudy, load_budget, profile, "budget"),
        _study(scale, ScaleStudy, load_scale_study, profile, "scale"),
        _study(gpu, GPURun, newest_gpu_run, profile, "gpu"),
    )


@dataclass(frozen=True)
class FindingRow:
    verdict: str
    statement: str
    ours: str  # our numbers as a phrase (this build's, with their intervals)
    source: str  # "DisCoRD, Table 1" for a paper's claim, "" for the chapter's own finding
    mechanism: str = ""  # what the chapter measured about why, one line per piece of evidence ("" when none)
    runs: str = ""  # what the verdict reads besides this build: training runs, test-clip draws ("" when nothing)


@dataclass
class ChapterFindings:
    """What one chapter found, judged on its recorded numbers: the table "What reproduces here" that ends a chapter
    (HTML in Jupyter and the book, Markdown elsewhere). Claim, verdict and why on the page; our numbers and the runs
    behind each verdict folded under each row."""

    chapter: str
    profile: str
    rows: list[FindingRow] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {v: sum(row.verdict == v for row in self.rows) for v in VERDICTS}

    def summary(self) -> str:
        claims = sum(bool(row.source) for row in self.rows)
        return count_sentence(self.counts(), "claims of the papers" if claims == len(self.rows) else "statements")

    def _repr_html_(self) -> str:
        esc = html.escape
        body = []
        for row in self.rows:
            source = f"<br><small>{esc(row.source)}</small>" if row.source else ""
            why = esc(row.mechanism.splitlines()[0]) if row.mechanism else ""
            detail = esc(row.ours + row.runs)
            more = "".join(f"<br>{esc(line)}" for line in row.mechanism.splitlines()[1:])
            body.append(
                f"<tr><td>{esc(row.statement)}{source}</td><td>{_verdict_html(row.verdict)}</td>"
                f'<td>{why}<details class="ml-ours"><summary>our numbers</summary>{detail}.{more}</details></td></tr>'
            )
        rows = "\n".join(body) if body else '<tr><td colspan="3">This chapter recorded nothing yet.</td></tr>'
        return (
            f'<div class="ml-findings"><table class="ml-claims-table ml-findings-table">'
            f"<caption>{esc(self.summary())}</caption>"
            "<thead><tr><th>claim</th><th>verdict</th><th>why, as measured</th></tr></thead>"
            f"<tbody>{rows}</tbody></table></div>"
        )

    def _repr_markdown_(self) -> str:
        lines = [
            f"**What reproduces here**: {self.summary()}",
            "",
            "| claim | verdict | why, as measured |",
            "|---|---|---|",
        ]
        for r in self.rows:
            claim = r.statement + (f" ({r.source})" if r.source else "")
            why = r.mechanism.splitlines()[0] if r.mechanism else f"ours: {r.ours}"
            lines.append(f"| {claim} | **{r.verdict}** | {why} |".replace("\n", " "))
        return "\n".join(lines)

    def __str__(self) -> str:
        return self._repr_markdown_()


def chapter_findings(
    chapter: str,
    profile: str | None = None,
    recorded: Mapping[str, Result] | None = None,
    spread: TrainingSpread | str | None = RECORDED,
) -> ChapterFindings:
    """The papers' claims judged on keys of ``chapter`` (a prefix such as ``"discord"``), then its own findings,
    each judged as :func:`claims_table` judges it."""
    if chapter not in CHAPTERS:
        raise ValueError(f"unknown chapter prefix {chapter!r}; one of {sorted(CHAPTERS)}")
    studies = resolve_studies(profile, recorded, spread, budget=None, scale=None, gpu=None)
    profile, recorded, spread = studies.profile, studies.recorded, studies.spread
    rows = []
    for claim in CLAIMS:
        if claim.keys[0].split("/", 1)[0] == chapter:
            row = judge(claim, recorded, spread)
            source = f"{claim.paper}, {claim.source}"
            rows.append(FindingRow(row.verdict, claim.statement, row.numbers, source, row.mechanism, row.runs))
    for finding in FINDINGS.get(chapter, ()):
        missing = any(k not in recorded for k in finding.keys)
        verdict = MISSING if missing else finding.rule.judge(recorded, spread)
        runs = "" if missing else retraining_phrase(finding.rule, recorded, spread)
        rows.append(FindingRow(verdict, finding.statement, finding.rule.sentence(recorded), "", "", runs))
    return ChapterFindings(chapter, profile, rows)
