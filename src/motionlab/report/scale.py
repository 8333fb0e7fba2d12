"""At what scale does each claim hold? The scale study's records, judged by the claims' own rules.

``experiments/scale.py`` trains the models the claims rest on at multiples of the laptop budget (counted in training
samples, at the laptop's widths) and scores each point with the chapters' evaluations, one record per model group
and multiple (``book/data/scale/embedded-v<N>/<group>-x<multiple>.json``, :mod:`motionlab.evaluation.scale`).
:func:`load_scale_study` reads them, setting aside a record whose configs are no longer the code's;
:func:`study_scale` judges a claim at every recorded multiple with the rule and intervals the claims table uses (the
evaluation's own intervals; no training-seed spread, which was measured at the laptop's budget), which gives the
"Measured scale" column its second line beside the budget study's (:func:`motionlab.report.budget.scale_statement`):
the smallest multiple from which the claim holds, with the device and precision it was trained in, or the largest
multiple tried and what the numbers do there.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import groupby
from pathlib import Path

from motionlab.comparison import Sentence
from motionlab.estimate import Estimate, format_estimate

from .budget import MODEL_FREE
from .rules import Greater, Less
from .store import HOLDS, Result

FOLDER = ("book", "data", "scale")
GPU_COMMAND = "PYTHONPATH=src python experiments/scale.py --device cuda --minutes 8 --out $OUT/scale"


def profile_text(profile: str) -> str:
    """Whose budget a multiple multiplies: ``the laptop's``, ``the smoke profile's``."""
    return "the laptop's" if profile == "laptop" else f"the {profile} profile's"


def multiple_text(multiple: float) -> str:
    """``10×``, ``0.5×``: a multiple of the laptop budget as the table prints it."""
    return f"{multiple:g}×"


@dataclass(frozen=True)
class ScaleStudy:
    """The scale study's records: ``records[(group, multiple)]`` is one file's JSON."""

    profile: str
    records: dict[tuple[str, float], dict]
    set_aside: tuple[str, ...] = ()  # files measured with other configs than the code's (:func:`read_scale_records`)
    _results: dict = field(default_factory=dict, compare=False, repr=False)  # results per multiple, built once

    @property
    def groups(self) -> set[str]:
        """The model groups with at least one recorded point (``discord``, ``projection``, ``m2d2m``)."""
        return {g for g, _ in self.records}

    @property
    def multiples(self) -> list[float]:
        """The multiples at which at least one group was recorded (sorted)."""
        return sorted({m for _, m in self.records})

    def results(self, multiple: float) -> dict[str, Result]:
        """Every claim number recorded at ``multiple`` (all its groups), as results the rules read."""
        if multiple not in self._results:
            out = {}
            for (_, m), record in self.records.items():
                if m == multiple:
                    out |= _record_results(record, self.profile)
            self._results[multiple] = out
        return self._results[multiple]

    def where_all(self) -> str:
        """Every device and precision the study's points were trained in, joined by ``/``."""
        return " / ".join(sorted({self.where(m) for m in self.multiples}))

    def where(self, multiple: float, keys=None) -> str:
        """Where the models of ``multiple`` were trained: ``NVIDIA H200, bf16`` (several joined by ``/``), from the
        records holding any of ``keys`` (default: all of that multiple)."""
        found = sorted(
            {
                f"{r.get('device', r.get('cpu', '?'))}, {r.get('precision', '?')}"
                for (_, m), r in self.records.items()
                if m == multiple and (keys is None or any(k in r.get("values", {}) for k in keys))
            }
        )
        return " / ".join(found)


def _record_results(record: dict, profile: str) -> dict[str, Result]:
    note = f"scale study, {multiple_text(record['multiple'])} the laptop's training samples ({record['group']})"
    return record_results(record, profile, note)


def record_results(record: dict, profile: str, note: str) -> dict[str, Result]:
    """A study record's claim numbers (``"values"``: mean and 95% half-width per key, as
    :func:`motionlab.studies.scale.estimate_json` writes them) as results the rules read, each with ``note``."""
    out = {}
    for name, value in record["values"].items():
        chapter, key = name.split("/", 1)
        half = float(value.get("half_width", 0.0))
        ci = (value["mean"] - half, value["mean"] + half) if half > 0 else None
        precision = record.get("precision")
        out[name] = Result(chapter, key, value["mean"], ci, value.get("unit"), note, profile, precision=precision)
    return out


def load_scale_study(profile: str, folder: str | Path | None = None) -> ScaleStudy | None:
    """The scale study recorded for ``profile`` (None where none was): the repository's
    ``book/data/scale/embedded-v<N>`` of the current embedded data unless ``folder`` is given."""
    from .spread import study_folder

    folder = study_folder(FOLDER, folder)
    if folder is None or not folder.is_dir():
        return None
    found, set_aside = read_scale_records(folder, profile)
    records = {(r["group"], float(r["multiple"])): r for r in found}
    if not records and not set_aside:
        return None
    return ScaleStudy(profile, records, tuple(set_aside))


def read_scale_records(folder: Path, profile: str) -> tuple[list[dict], list[str]]:
    """The scale-study files of ``profile`` in ``folder`` that measured the code's models and evaluations, and a line
    per file set aside (:func:`~motionlab.report.spread.read_current` with
    :func:`motionlab.evaluation.scale.point_changes`)."""
    from motionlab.evaluation.scale import point_changes

    from .spread import read_current

    return read_current(folder, profile, point_changes, study="scale")


@dataclass(frozen=True)
class StudyScale:
    """A claim judged at each multiple of the scale study, and the sentence the claims table prints."""

    verdicts: dict[float, str]
    where: dict[float, str]  # device and precision per multiple
    largest: str  # our numbers at the largest multiple, as the claims table phrases them
    trend: str = ""  # what the compared difference does over the multiples ("" where the rule has no single pair)

    def sentence(self) -> str:
        multiples = sorted(self.verdicts)
        machines = set(self.where.values())
        one = machines.pop() if len(machines) == 1 else None  # then said once, not at every multiple
        tried = "; ".join(
            f"{multiple_text(m)}{'' if one else f' ({self.where[m]})'}: {self.verdicts[m]}" for m in multiples
        )
        holding = [m for m in multiples if self.verdicts[m] == HOLDS]
        if holding and all(self.verdicts[m] == HOLDS for m in multiples if m >= holding[0]):
            first = holding[0]
            reading = f"holds from {multiple_text(first)} the laptop's training samples ({self.where[first]})"
        else:
            last = multiples[-1]
            reading = f"the largest multiple tried, {multiple_text(last)}: {self.largest}"
            reading += f"; {self.trend}" if self.trend else ""
        where = f", {one}" if one else ""
        return f"By training samples (scale study, laptop widths{where}): {tried} — {reading}"


def study_scale(claim, study: ScaleStudy) -> StudyScale | None:
    """``claim`` judged by its own rule at every multiple of ``study`` that recorded all its keys (None where none
    did, or where the claim reads real motions only)."""
    if set(claim.keys) <= MODEL_FREE:
        return None
    verdicts, where, per_multiple = {}, {}, {}
    for multiple in study.multiples:
        recorded = study.results(multiple)
        if any(k not in recorded for k in claim.keys):
            continue
        verdicts[multiple] = claim.rule.judge(recorded)
        where[multiple] = study.where(multiple, claim.keys)
        per_multiple[multiple] = recorded
    if not verdicts:
        return None
    largest = claim.rule.sentence(per_multiple[max(verdicts)])
    return StudyScale(verdicts, where, largest, gap_trend(claim.rule, per_multiple))


def gap_trend(rule, per_multiple: Mapping[float, Mapping[str, Result]]) -> str:
    """For a rule comparing one pair (``a < b`` or ``a > b``): ``a − b`` at each multiple and whether it moves toward
    the claim's side; "" for other rules or a single multiple."""
    if not isinstance(rule, Less) or len(per_multiple) < 2:
        return ""
    multiples = sorted(per_multiple)
    gaps = [per_multiple[m][rule.a].value - per_multiple[m][rule.b].value for m in multiples]
    unit = per_multiple[multiples[-1]][rule.a].unit
    wanted = 1 if isinstance(rule, Greater) else -1  # the sign the claim expects of a − b
    moving = (gaps[-1] - gaps[-2]) * wanted
    direction = "toward the claim" if moving > 0 else "away from it" if moving < 0 else "flat"
    path = " → ".join(format_estimate(g, unit=unit) for g in gaps)
    span = f"{multiple_text(multiples[0])} to {multiple_text(multiples[-1])}"
    return f"a − b went {path} from {span}, last step {direction}"


def scale_study_note(study: ScaleStudy | None) -> str:
    """One sentence for the book: what the scale study has measured, or that it has not yet been run on a GPU."""
    if study is None or not study.records:
        aside = f" ({len(study.set_aside)} record(s) set aside)" if study is not None and study.set_aside else ""
        return f"Scale study: not yet measured on a GPU{aside}; a GPU run needs `{GPU_COMMAND}`."
    gpu = any(r.get("device_type") == "cuda" for r in study.records.values())
    points = ", ".join(f"{multiple_text(m)} ({study.where(m)})" for m in study.multiples)
    groups = sorted(study.groups)
    text = f"Scale study: {len(study.records)} point(s) of {', '.join(groups)} at {points}"
    if not gpu:
        text += "; not yet measured on a GPU"
    if study.set_aside:
        text += f"; {len(study.set_aside)} record(s) set aside"
    return text + "."


def scale_verdicts(rows, study: ScaleStudy, claims=None):
    """Every claim's verdict at each recorded multiple next to this build's (``rows``: a claims table's rows, in the
    order of ``claims``, default :data:`~motionlab.report.claims.CLAIMS`), as a :class:`~motionlab.viz.tables.Table`;
    "–" where a multiple did not measure the claim's keys."""
    from motionlab.viz.tables import Table

    from .claims import CLAIMS

    claims = CLAIMS if claims is None else claims
    if not study.records:
        raise ValueError("the scale study recorded no point: nothing to set beside this build's verdicts")
    columns = ("this build", *(multiple_text(m) for m in study.multiples))
    table = {}
    for claim, row in zip(claims, rows, strict=True):
        judged = study_scale(claim, study)
        verdicts = judged.verdicts if judged is not None else {}
        cells = {"this build": row.verdict}
        cells |= {multiple_text(m): verdicts.get(m) for m in study.multiples}
        table[f"{claim.paper}: {claim.statement}"] = cells
    notes = [f"{multiple_text(m)}: {study.where(m)}" for m in study.multiples]
    return Table("claim", table, columns, notes=("trained on: " + "; ".join(notes),))


def chapter_claims(chapter: str, claims=None) -> list:
    """The claims of ``chapter`` (the results' chapter name, e.g. ``"diffusion"``: the prefix of their keys)."""
    from .claims import CLAIMS

    claims = CLAIMS if claims is None else claims
    found = [c for c in claims if c.keys[0].split("/", 1)[0] == chapter]
    if not found:
        raise ValueError(f"no claim reads chapter {chapter!r}'s results")
    return found


def scale_changes(table, study: ScaleStudy | None, chapter: str, claims=None) -> Sentence:
    """One sentence for a chapter: which of its claims change verdict between this build (the claims table ``table``,
    whose rows follow ``claims``, default :data:`~motionlab.report.claims.CLAIMS`) and the scale study's multiples,
    or that none does, or that the study has no point for them yet."""
    from .claims import CLAIMS
    from .store import MISSING

    claims = CLAIMS if claims is None else claims
    rows = dict(zip(claims, table, strict=True))
    scaled = {c: study_scale(c, study) for c in chapter_claims(chapter, claims)} if study is not None else {}
    scaled = {c: s for c, s in scaled.items() if s is not None}
    if not scaled:
        return Sentence(
            "The scale study has no point for this chapter's claims yet (it needs a GPU run; chapter 99 gives the "
            "command), so their verdicts are this build's alone."
        )
    judged = {c: s for c, s in scaled.items() if rows[c].verdict != MISSING}
    if not judged:
        return Sentence("The scale study has points for this chapter's claims, but this build has not measured them.")
    multiples = sorted({m for s in judged.values() for m in s.verdicts})
    machines = sorted({w for s in judged.values() for w in s.where.values()})
    samples = f"{profile_text(study.profile)} training samples"
    at = f"At {', '.join(multiple_text(m) for m in multiples)} {samples} ({' / '.join(machines)})"
    changed = [c for c, s in judged.items() if any(v != rows[c].verdict for v in s.verdicts.values())]
    claims_judged = "1 claim" if len(judged) == 1 else f"{len(judged)} claims"
    if not changed:
        return Sentence(f"{at}, no verdict of this chapter changes ({claims_judged} judged).")
    if len(judged) == 1:
        count = "its one verdict changes"
    else:
        count = f"{len(changed)} of {len(judged)} verdicts {'changes' if len(changed) == 1 else 'change'}"

    def path(claim) -> str:
        verdicts = judged[claim].verdicts
        return f"“{claim.statement}” " + verdict_path(rows[claim].verdict, [(m, verdicts[m]) for m in sorted(verdicts)])

    return Sentence(f"{at}, {count}: " + "; ".join(map(path, changed)) + ".")


def verdict_path(here: str, scaled: Sequence[tuple[float, str]]) -> str:
    """A claim's verdicts from this build through the scale study's multiples, a run of equal verdicts said once:
    ``"does not hold here and at 10×, holds at 30× and 100×"``."""
    points = [(None, here), *scaled]  # None: this build
    runs = [(verdict, [m for m, _ in run]) for verdict, run in groupby(points, key=lambda point: point[1])]

    def places(where: list) -> str:
        multiples = [multiple_text(m) for m in where if m is not None]
        if not multiples:
            return "here"
        at = f"at {multiples[0]}" if len(multiples) == 1 else f"at {', '.join(multiples[:-1])} and {multiples[-1]}"
        return f"here and {at}" if None in where else at

    return ", ".join(f"{verdict} {places(where)}" for verdict, where in runs)


def scale_points(study: ScaleStudy, key: str) -> list[tuple[float, Estimate]]:
    """``[(multiple, estimate), ...]``: ``key`` at every multiple that recorded it, smallest first."""
    return [(m, study.results(m)[key].estimate) for m in study.multiples if key in study.results(m)]


_SCALE_MARKER = {"marker": "D", "mfc": "none", "ms": 4, "ls": "none"}  # the scale study's points: hollow diamonds


def _scale_legend_handle(where: str):
    """The legend entry for the scale study's points: a grey hollow diamond, ``scale study (<where>)``."""
    from matplotlib.lines import Line2D

    return Line2D([], [], color="gray", label=f"scale study ({where})", **_SCALE_MARKER)


def plot_training_scale(
    panels: Mapping[str, Sequence[str]],
    *,
    budget=None,
    scale: ScaleStudy | None = None,
    this_build: Mapping[str, Result] | None = None,
    axes=None,
    figsize: tuple[float, float] = (7.4, 2.4),
):
    """Claim numbers against training samples, in multiples of the laptop's: one panel per entry of ``panels`` (title
    -> claim keys, e.g. ``{"sJPE ↓": ["discord/sjpe_rf", "discord/sjpe_ff"]}``), one colour per key, 95% intervals.

    ``budget`` (a :class:`~motionlab.report.budget.BudgetStudy`: the same models trained for more steps at the
    laptop's batch) draws a line of circles per key; ``scale`` (a :class:`ScaleStudy`, which also scales the
    tokenizer) its points as hollow diamonds, beside a budget point at the same multiple; ``this_build`` (key ->
    :class:`~motionlab.report.store.Result`, e.g. ``results.load_all(profile)``) a circle at 1× where no budget line
    draws one. The real motions' Jerks (:data:`~motionlab.report.budget.MODEL_FREE`) have no scale points. Budgets
    trained in several precisions say which under their ticks. Returns the axes.
    """
    from matplotlib.lines import Line2D

    from motionlab.viz.plots import panel_axes  # only when drawn: the claims table must not pay for pyplot

    from .budget import budget_curves
    from .quantities import quantity

    if not panels:
        raise ValueError("need at least one panel")
    if budget is None and scale is None:
        raise ValueError("need a budget study or a scale study to draw")
    laptop = budget.laptop_steps if budget is not None else None
    axes = panel_axes(len(panels), axes, figsize=figsize)
    for ax, (title, keys) in zip(axes, panels.items()):
        curves = budget_curves(budget, keys) if budget is not None else {}
        ticks = {1.0: multiple_text(1.0)}
        drawn_scale = drawn_here = False
        for i, key in enumerate(keys):
            dodge = 1.0 + 0.04 * (i - (len(keys) - 1) / 2)  # side by side on the log axis, so the bars do not hide
            style = {"color": f"C{i}", "capsize": 2}
            label = quantity(key)[1] or key
            if key in curves:
                multiples = [n / laptop for n, _ in curves[key]]
                _errorbar(ax, multiples, [e for _, e in curves[key]], dodge, marker="o", ms=3, label=label, **style)
                mixed = budget.mixed_precision  # then each budget says what it was trained in
                for m, (n, _) in zip(multiples, curves[key]):
                    ticks[m] = multiple_text(m) + (f"\n{budget.precision(n)}" if mixed else "")
                label = None
            elif this_build is not None and key in this_build:
                _errorbar(ax, [1.0], [this_build[key].estimate], dodge, marker="o", ms=3, label=label, **style)
                label, drawn_here = None, True
            points = scale_points(scale, key) if scale is not None and key not in MODEL_FREE else []
            if not points and label is not None:
                raise KeyError(f"nothing to draw for {key!r}: the scale study recorded no {key!r}")
            beside = 1.06 if curves else 1.0  # a scale point beside a budget point at the same multiple
            multiples, estimates = [m for m, _ in points], [e for _, e in points]
            _errorbar(ax, multiples, estimates, dodge * beside, label=label, **style, **_SCALE_MARKER)
            ticks |= {m: ticks.get(m, multiple_text(m)) for m, _ in points}
            drawn_scale = drawn_scale or bool(points)
        ax.axvline(1.0, color="gray", ls="--", lw=1)
        ax.set_xscale("log")
        ax.set_xticks(sorted(ticks), [ticks[m] for m in sorted(ticks)])
        ax.minorticks_off()
        profile = budget.profile if budget is not None else scale.profile
        ax.set_xlabel(f"training samples (× {profile_text(profile)}, dashed)")
        ax.set_title(title, fontsize=9)
        handles, _ = ax.get_legend_handles_labels()
        if drawn_scale:
            handles.append(_scale_legend_handle(scale.where_all()))
        if drawn_here:
            handles.append(Line2D([], [], color="gray", marker="o", ms=3, ls="none", label="this build"))
        ax.legend(handles=handles, fontsize=7, framealpha=0.8)
    return axes


def _errorbar(ax, multiples: Sequence[float], estimates: Sequence[Estimate], dodge: float, **style) -> None:
    """Points at ``multiples`` (times ``dodge``) with their 95% intervals; nothing where there are none."""
    if multiples:
        means, halves = [e.mean for e in estimates], [e.half_width for e in estimates]
        ax.errorbar([m * dodge for m in multiples], means, yerr=halves, **style)


__all__ = [
    "GPU_COMMAND",
    "chapter_claims",
    "plot_training_scale",
    "scale_changes",
    "scale_points",
    "ScaleStudy",
    "StudyScale",
    "load_scale_study",
    "multiple_text",
    "read_scale_records",
    "record_results",
    "scale_study_note",
    "scale_verdicts",
    "study_scale",
    "gap_trend",
]
