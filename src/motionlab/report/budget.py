"""At what training budget does an M2D2M claim hold? The budget study's numbers, judged by the claims' own rules.

``experiments/m2d2m_budget.py`` trains the laptop profile's text-to-motion models of both arms (dynamic β(t, d) at the
paper's η = 0.5, and uniform) for more steps than the laptop's and scores each budget with chapter 07's and chapter
09's evaluations (``book/data/m2d2m_budget/embedded-v<N>/<arm>-seed<k>-steps<n>.json``). :func:`budget_results` turns
one budget's files into the claim keys (``tps/...``, ``diffusion/...``, ``transitions/...``), and
:func:`scale_statement` judges a claim at every budget with the same rule the claims table uses, which gives each
M2D2M row its *scale*: the budget from which it holds, or the largest budget tried and what the numbers do there.

Two differences from the chapters, stated with every statement: the multi-motion claims are judged on the dynamic
arm (η = 0.5) where chapter 09 uses its η = 0.25 model (their forward processes differ by at most 0.0024 in total
variation at the laptop's codebook, chapter 08), and the intervals are the evaluation's (over the training seeds,
with Student's t, where a budget has several).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from motionlab.estimate import Estimate, mean_ci

from .store import HOLDS, Result

FOLDER = ("book", "data", "m2d2m_budget")
ARMS = ("dynamic", "uniform")
MODEL_FREE = {"tps/jerk_gt_single", "tps/jerk_gt_concat", "tps/jerk_concat_minus_inside"}  # the real motions' Jerks


@dataclass(frozen=True)
class BudgetStudy:
    """The budget study's records: ``records[(arm, training_seed, steps)]`` is one file's JSON."""

    profile: str
    laptop_steps: int
    records: dict[tuple[str, int, int], dict] = field(default_factory=dict)
    set_aside: tuple[str, ...] = ()  # files measured with other configs than the code's (:func:`read_records`)
    # budget_results per (steps, guidance scale): each claim of the table reads them, the tables are parsed once
    _results: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def budgets(self) -> list[int]:
        """The training steps at which both arms were scored (sorted)."""
        steps = [{n for arm_, _, n in self.records if arm_ == arm} for arm in ARMS]
        return sorted(steps[0] & steps[1])

    def seeds(self, steps: int) -> list[int]:
        """The training seeds scored at ``steps`` in both arms."""
        per_arm = [{k for arm_, k, n in self.records if arm_ == arm and n == steps} for arm in ARMS]
        return sorted(per_arm[0] & per_arm[1])

    def precision(self, steps: int) -> str:
        """The precision the models of ``steps`` were trained and sampled in (``"fp32"``, ``"bf16"``, or both joined
        by ``/`` where the seeds it is judged on differ): a budget trained in another precision is another run."""
        found = {self.records[arm, k, steps].get("precision", "fp32") for k in self.seeds(steps) for arm in ARMS}
        return "/".join(sorted(found))

    @property
    def mixed_precision(self) -> bool:
        """Whether the budgets were not all measured in one precision (then every budget is labelled with its own)."""
        return len({self.precision(n) for n in self.budgets}) > 1


def load_budget(profile: str, folder: str | Path | None = None) -> BudgetStudy | None:
    """The budget study recorded for ``profile`` (None where none was): the repository's
    ``book/data/m2d2m_budget/embedded-v<N>`` of the current embedded data unless ``folder`` is given."""
    from motionlab.sizes import DENOISER

    from .spread import study_folder

    folder = study_folder(FOLDER, folder)
    if folder is None:
        return None
    found, set_aside = read_records(folder, profile)
    records = {(r["arm"], int(r["training_seed"]), int(r["steps"])): r for r in found}
    if not records:
        return None
    if "train_steps" not in DENOISER.get(profile, {}):
        raise ValueError(f"the budget study is measured against a profile's own steps; {profile!r} sets none")
    return BudgetStudy(profile, DENOISER[profile]["train_steps"], records, tuple(set_aside))


def read_records(folder: Path, profile: str) -> tuple[list[dict], list[str]]:
    """The budget-study (or η-axis) files of ``profile`` in ``folder`` that measured the code's models and evaluations,
    and a line per file set aside (:func:`~motionlab.report.spread.read_current` with
    :func:`motionlab.evaluation.studies.budget_changes`)."""
    from motionlab.evaluation.studies import budget_changes

    from .spread import read_current

    return read_current(folder, profile, budget_changes)


def _cells(record: dict, arm: str, guidance_scale: float) -> dict[str, Estimate]:
    """One file's claim numbers: every multi-motion claim cell, and the guidance rows of its t2m table."""
    from motionlab.evaluation import EvaluationTable, multi_claim_cells

    multi = EvaluationTable.from_json_dict(record["multi"])
    t2m = EvaluationTable.from_json_dict(record["t2m"])
    out: dict[str, Estimate] = {}
    cells = multi_claim_cells(multi)
    if arm == "dynamic":
        out |= {f"tps/{key}": multi.estimate(row, m) for key, (row, m) in cells.items()}
    else:
        out["tps/jerk_tps_uniform"] = multi.estimate(*cells["jerk_tps"])

    def fid(scale: float) -> Estimate:
        return t2m.estimate(f"{record['model']}, s = {scale:g}", "fid")

    out[f"transitions/fid_{arm}"] = fid(guidance_scale)
    if arm == "dynamic":
        out |= {"diffusion/fid_guided": fid(4.0), "diffusion/fid_unguided": fid(0.0)}
    return out


def budget_results(study: BudgetStudy, steps: int, guidance_scale: float = 4.0) -> dict[str, Result]:
    """The claim numbers at ``steps`` training steps, as results the rules read: one seed's estimate, or with several
    seeds the mean over them with Student's t interval (the training runs' own variance). ``guidance_scale`` is
    chapter 08's s for the dynamic-vs-uniform FID (M2D2M's 4)."""
    if (steps, guidance_scale) in study._results:
        return study._results[steps, guidance_scale]
    seeds = study.seeds(steps)
    if not seeds:
        raise ValueError(f"no budget of {steps} steps in both arms; budgets: {study.budgets}")
    per_seed: dict[str, list[Estimate]] = {}
    for seed in seeds:
        for arm in ARMS:
            for key, estimate in _cells(study.records[(arm, seed, steps)], arm, guidance_scale).items():
                per_seed.setdefault(key, []).append(estimate)
    out = {}
    for key, estimates in per_seed.items():
        chapter, name = key.split("/", 1)
        e = estimates[0] if len(estimates) == 1 else mean_ci([x.mean for x in estimates])
        ci = (e.mean - e.half_width, e.mean + e.half_width) if e.half_width > 0 else None
        note = f"budget study, {steps} training steps, seeds {seeds}"
        out[key] = Result(chapter, name, e.mean, ci, note=note, profile=study.profile)
    study._results[steps, guidance_scale] = out
    return out


@dataclass(frozen=True)
class Scale:
    """A claim judged at each budget: ``verdicts[steps]``, and the sentence the claims table prints."""

    verdicts: dict[int, str]
    laptop_steps: int
    largest: str  # our numbers at the largest budget, as the claims table phrases them
    precisions: dict[int, str] = field(default_factory=dict)  # per budget, where the budgets' precisions differ

    def sentence(self) -> str:
        steps = sorted(self.verdicts)

        def budget(n: int) -> str:
            precision = f", {self.precisions[n]}" if n in self.precisions else ""
            return f"{n:,} steps ({n / self.laptop_steps:g}×{precision})"

        tried = "; ".join(f"{budget(n)}: {self.verdicts[n]}" for n in steps)
        holding = [n for n in steps if self.verdicts[n] == HOLDS]
        if holding and all(self.verdicts[n] == HOLDS for n in steps if n >= holding[0]):
            reading = f"holds from {holding[0]:,} training steps ({holding[0] / self.laptop_steps:g}× the laptop's)"
        else:
            last = steps[-1]
            reading = f"the largest budget tried, {last:,} steps ({last / self.laptop_steps:g}×): {self.largest}"
        return f"By training budget: {tried} — {reading}"


def scale_statement(claim, study: BudgetStudy, guidance_scale: float = 4.0) -> Scale | None:
    """``claim`` judged by its own rule at every budget of ``study`` (None where the study lacks one of its keys)."""
    if set(claim.keys) <= MODEL_FREE:
        return None  # real motions only: no training budget moves them
    verdicts, largest = {}, ""
    for steps in study.budgets:
        recorded = budget_results(study, steps, guidance_scale)
        if any(k not in recorded for k in claim.keys):
            return None
        verdicts[steps] = claim.rule.judge(recorded)
        largest = claim.rule.sentence(recorded)
    if not verdicts:
        return None
    precisions = {n: study.precision(n) for n in verdicts} if study.mixed_precision else {}
    return Scale(verdicts, study.laptop_steps, largest, precisions)


def budget_curves(study: BudgetStudy, keys: Sequence[str], guidance_scale: float = 4.0) -> dict[str, list]:
    """``{key: [(steps, Estimate), ...]}`` over the budgets, for a figure (a budget lacking a key is skipped)."""
    per_budget = {steps: budget_results(study, steps, guidance_scale) for steps in study.budgets}
    curves = {}
    for key in keys:
        points = [(steps, recorded[key].estimate) for steps, recorded in per_budget.items() if key in recorded]
        if not points:
            raise KeyError(f"the budget study measures no {key!r}; it has {sorted(next(iter(per_budget.values())))}")
        curves[key] = points
    return curves


ETA_FOLDER = ("book", "data", "m2d2m_eta")


@dataclass(frozen=True)
class EtaAxis:
    """The dynamic model at several η, each trained for the profile's steps and scored like a budget:
    ``records[η]`` (η = 0 and the paper's 0.5 are the budget study's two arms at the laptop's steps)."""

    profile: str
    records: dict[float, dict]
    set_aside: tuple[str, ...] = ()  # files measured with other configs than the code's

    @property
    def etas(self) -> list[float]:
        return sorted(self.records)

    def columns(self, guidance_scale: float = 4.0) -> dict[str, dict[float, Estimate]]:
        """``{column: {η: Estimate}}``: single-motion FID at ``guidance_scale``, and the transition Jerk of TPS and of
        independent sampling (chapter 08's η table takes them as columns)."""
        from motionlab.evaluation import EvaluationTable, multi_claim_cells

        out: dict[str, dict[float, Estimate]] = {}
        for eta in self.etas:
            record = self.records[eta]
            t2m, multi = (EvaluationTable.from_json_dict(record[k]) for k in ("t2m", "multi"))
            cells = multi_claim_cells(multi)
            fid = t2m.estimate(f"{record['model']}, s = {guidance_scale:g}", "fid")
            out.setdefault(f"FID ↓ (s = {guidance_scale:g})", {})[eta] = fid
            out.setdefault("TPS transition Jerk", {})[eta] = multi.estimate(*cells["jerk_tps"])
            out.setdefault("independent transition Jerk", {})[eta] = multi.estimate(*cells["jerk_independent"])
        return out


def load_eta_axis(profile: str, folder: str | Path | None = None, budget: BudgetStudy | None = None) -> EtaAxis | None:
    """The η axis recorded for ``profile`` (None where none was): the η study's files (``folder``, default the
    repository's ``book/data/m2d2m_eta/embedded-v<N>``), with η = 0 and η = 0.5 from ``budget``'s laptop-steps seed-0
    records (default: the recorded budget study) where they are not in the folder."""
    from motionlab.diffusion.training import PAPER_ETA

    from .spread import study_folder

    folder = study_folder(ETA_FOLDER, folder)
    found, set_aside = read_records(folder, profile) if folder is not None else ([], [])
    records = {float(record["eta"]): record for record in found}
    if not records:
        return None
    budget = load_budget(profile) if budget is None else budget
    if budget is not None:
        for arm, eta in (("uniform", 0.0), ("dynamic", PAPER_ETA)):
            key = (arm, 0, budget.laptop_steps)
            if eta not in records and key in budget.records:
                records[eta] = budget.records[key]
    return EtaAxis(profile, records, tuple(set_aside))


__all__ = [
    "BudgetStudy",
    "EtaAxis",
    "Scale",
    "budget_curves",
    "budget_results",
    "load_budget",
    "load_eta_axis",
    "scale_statement",
]
