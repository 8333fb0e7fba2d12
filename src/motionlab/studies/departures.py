"""Where the laptop build departs from the papers: one row per departure, and whether a verdict rests on it.

Each paper gets a list of :class:`Departure` rows (:func:`discord_departures`, :func:`m2d2m_departures`). A row says
what the paper does and what the build does, both read from the configs the code trains with
(``flow.discord_config("full")`` against the profile's, ``diffusion.diffusion_training_config``, a sampler's
default), so the table cannot drift from the code; why the build does it, with a link to the page holding the
measurement; and whether any verdict of the claims table depends on it.

That last cell is measured where the numbers already exist: the claim is judged *both ways* by its own rule
(:class:`~motionlab.report.rules.Less` and the others, the claims table's one comparison rule), once on the numbers of
the build's setting and once on those of the other setting, which the chapters or the committed studies recorded
beside them (:class:`Setting`). A departure whose other side no record measured says "not measured here" and why.
:func:`departures_table` renders the rows, :func:`dependence_sentence` says in one line which departures a verdict
depends on. Nothing here trains or scores a model: it reads configs, recorded results and committed studies.
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from itertools import groupby
from pathlib import Path
from typing import Any

from motionlab.estimate import Estimate
from motionlab.report.budget import MODEL_FREE, BudgetStudy, EtaAxis, load_budget, load_eta_axis, scale_statement
from motionlab.report.claims import CLAIMS
from motionlab.report.guidance import GuidanceStudy, load_guidance_study
from motionlab.report.quantities import quantity
from motionlab.report.rules import Claim, Rule
from motionlab.report.scale import ScaleStudy, load_scale_study, study_scale
from motionlab.report.spread import TrainingSpread, embedded_data_folder, find_folder, load_spread
from motionlab.report.store import MISSING, Result, load_all

# Links to the pages that hold each measurement (relative: the page sits beside them in notebooks/).
DECODER_SWEEP = "[Choosing a decoder](s1_decoder_sweep.ipynb)"
BUDGETS = "[Training budgets](s2_training_budgets.ipynb)"
DISCORD = "[DisCoRD](05_discord.ipynb)"
DIFFUSION = "[Discrete diffusion](07_discrete_diffusion.ipynb)"
TRANSITIONS = "[Dynamic transitions](08_dynamic_transitions.ipynb)"
TPS = "[Two-Phase Sampling](09_two_phase_sampling.ipynb)"

# The claim keys of the flow decoder and where the other settings' numbers of the same quantity are recorded.
_FLOW_METRICS = ("sjpe", "noise_sjpe", "static_sjpe", "fid", "mpjpe")
XPRED_KEYS = {f"discord/{m}_rf": f"discord/{m}_xpred" for m in _FLOW_METRICS}  # chapter 05's lever, same tokens
STEPS16_KEYS = {f"discord/{m}_rf": f"discord/{m}_steps16" for m in ("sjpe", "noise_sjpe", "fid")}  # Table E
STEPS2_KEYS = {f"discord/{m}_rf": f"discord/{m}_steps2" for m in ("sjpe", "noise_sjpe", "fid")}
# A sweep file names each metric as the evaluation table does (MPJPE in millimetres).
SWEEP_METRICS = {
    "sjpe": "sjpe",
    "noise_sjpe": "noise_sjpe",
    "static_sjpe": "static_sjpe",
    "fid": "fid",
    "mpjpe": "mpjpe_mm",
}
SWEEP_KEYS = tuple(f"discord/{m}_rf" for m in SWEEP_METRICS)  # the claims a sweep variant's scores can judge
# Chapter 09's TPS row with the compound condition in the joint phase, recorded beside the book's own-text row.
COMPOUND_KEYS = {
    "tps/jerk_tps": "tps/jerk_tps_compound",
    "tps/fid_ts90": "tps/fid_tps_compound",
    "tps/r_top3_tps": "tps/r_top3_tps_compound",
}
# Keys of TPS rows sampled with each action's own text: a claim that reads one of them beside the TPS row would
# compare a compound-condition sample with an own-text one, so it is not judged with the compound row substituted.
_OWN_TEXT_ONLY = ("tps/fid_ts50", "tps/jerk_tps_uniform")
# The claims that set dynamic against uniform transitions: what the noise schedule decides.
_DYNAMIC_VS_UNIFORM = ("transitions/fid_dynamic", "tps/jerk_tps_uniform")

SWEEPS = ("book", "data", "discord_sweep")  # study s1's sweeps; the current data's is embedded-v<N>
SWEEP_FOLDER = (*SWEEPS, "embedded-v2")  # study s1's first sweep: the widths, feat_bias
PAPER_WIDTH_RUN = "v-40min"  # s1's run of the paper's decoder above the motion's features, on the current data
VARIANT_SCALE_FOLDER = ("book", "data", "scale", "embedded-v3", "xpred-variant")  # the x-prediction variant's points
SWEEP_SAMPLING = "T1"  # the paper's sampling: start noise at temperature 1


# ---------------------------------------------------------------------------------------------- rows and verdicts


@dataclass(frozen=True)
class Departure:
    """One row of a paper's table: a setting, what the paper and the build do, why, and whether a verdict rests on it.

    ``depends`` is True where a claim's verdict changes with the setting, False where none does (or the build does
    what the paper does), None where nothing measured it; ``verdict`` says so in words, with the verdicts.
    """

    topic: str
    paper: str
    build: str
    why: str
    verdict: str
    depends: bool | None = None

    def cells(self) -> tuple[str, str, str, str]:
        """The four columns, in the table's order."""
        return (self.paper, self.build, self.why, self.verdict)


@dataclass(frozen=True)
class Setting:
    """One way of measuring the claims: a label, the numbers, and which of them stand in for a claim's keys.

    ``keys`` maps a claim key to the key that holds this setting's number of the same quantity (e.g.
    ``discord/sjpe_rf`` to ``discord/sjpe_xpred``); keys it does not name are read as they are. ``spread`` is the
    training-seed study the claims table judges with (None: this setting's numbers alone).
    """

    label: str
    recorded: Mapping[str, Result]
    keys: Mapping[str, str] = field(default_factory=dict)
    spread: TrainingSpread | None = None


@dataclass(frozen=True)
class Judged:
    """One claim's verdict under each setting, in the order the row names the settings."""

    claim: Claim
    verdicts: tuple[tuple[str, str], ...]  # (setting, verdict)

    @property
    def label(self) -> str:
        return claim_label(self.claim)

    @property
    def measured(self) -> list[tuple[str, str]]:
        return [(setting, verdict) for setting, verdict in self.verdicts if verdict != MISSING]

    @property
    def changes(self) -> bool | None:
        """Whether the verdict differs between the measured settings (None: fewer than two were measured)."""
        measured = self.measured
        return None if len(measured) < 2 else len({verdict for _, verdict in measured}) > 1

    def path(self) -> str:
        """``Table 1 (sJPE): holds (the paper's decoder), does not hold (x-prediction variant)``; settings in a row
        with the same verdict are named together."""
        runs = groupby(self.verdicts, key=lambda pair: pair[1])
        return f"{self.label}: " + ", ".join(f"{v} ({', '.join(s for s, _ in run)})" for v, run in runs)


def claim_label(claim: Claim) -> str:
    """``Table 6 (transition Jerk, Handshake)``: where the paper makes the claim, and the quantity it reads (two
    claims of one table may read the same quantity of different methods)."""
    name, condition = quantity(claim.keys[0])
    return f"{claim.source} ({name}, {condition})" if condition else f"{claim.source} ({name})"


def substituted(rule: Rule, keys: Mapping[str, str]) -> Rule:
    """``rule`` reading ``keys[k]`` wherever it read ``k`` (the same rule, other numbers).

    A rule's ``clips`` key is the difference of its own pair, paired over the test clips; it belongs to that pair, so
    it is dropped where either side was replaced (the verdict then rests on the two sides' intervals alone).
    """
    changes: dict[str, Any] = {}
    for f in fields(rule):
        value = getattr(rule, f.name)
        if f.name == "clips":
            continue
        if isinstance(value, str) and value in keys:
            changes[f.name] = keys[value]
        elif isinstance(value, tuple) and any(v in keys for v in value):
            changes[f.name] = tuple(keys.get(v, v) for v in value)
    if changes and getattr(rule, "clips", None) is not None:
        changes["clips"] = None
    return replace(rule, **changes) if changes else rule


def verdict(rule: Rule, recorded: Mapping[str, Result], spread: TrainingSpread | None = None) -> str:
    """The rule's verdict on ``recorded``, or "not yet measured" where a key it reads is missing."""
    if any(key not in recorded for key in rule.keys):
        return MISSING
    return rule.judge(recorded, spread)


def claims_reading(keys: Iterable[str], claims: Sequence[Claim] = CLAIMS, without: Iterable[str] = ()) -> list[Claim]:
    """The claims that read any of ``keys`` and none of ``without``."""
    wanted, excluded = set(keys), set(without)
    return [c for c in claims if wanted & set(c.keys) and not excluded & set(c.keys)]


def judge_settings(claims: Sequence[Claim], settings: Sequence[Setting]) -> list[Judged]:
    """Each claim judged by its own rule under every setting (:func:`substituted` reads the setting's keys)."""
    return [
        Judged(
            claim, tuple((s.label, verdict(substituted(claim.rule, s.keys), s.recorded, s.spread)) for s in settings)
        )
        for claim in claims
    ]


def dependence(judged: Sequence[Judged], missing: str) -> tuple[str, bool | None]:
    """The "does a verdict depend on it" cell and its answer: the claims whose verdict changes between the settings,
    with each setting's verdict, and those that keep theirs; ``missing`` says why where no claim was measured twice.
    """
    measured = [j for j in judged if j.changes is not None]
    if not measured:
        return f"{MISSING} ({missing})", None
    changed = [j for j in measured if j.changes]
    kept = "; ".join(j.path() for j in measured if not j.changes)
    if not changed:
        return f"no: {kept}", False
    text = "yes: " + "; ".join(j.path() for j in changed)
    return (f"{text}; unchanged: {kept}" if kept else text), True


def no_departure(what: str) -> tuple[str, bool]:
    """The cell of a setting the build shares with the paper."""
    return f"none: the build {what} as the paper does", False


# ---------------------------------------------------------------------------------------------- what was measured


@dataclass(frozen=True)
class Measurements:
    """What the rows read besides the configs: this profile's recorded results and the committed studies.

    Any study may be None (not recorded for this profile, or outside the repository): the rows it would measure then
    say "not yet measured" or "not measured here".
    """

    recorded: Mapping[str, Result]
    spread: TrainingSpread | None = None  # the training-seed study, as the claims table judges with it
    # study s1's first decoder sweep, by variant (:func:`motionlab.studies.sweep.load_sweep`)
    sweep: Mapping[str, dict] | None = None
    # study s1's runs on the current embedded data (the paper's decoder at width 272 among them)
    sweep_today: Mapping[str, dict] | None = None
    scale: ScaleStudy | None = None  # the scale study of the paper's decoder and the text-to-motion models
    variant_scale: ScaleStudy | None = None  # the x-prediction variant's scale points (:func:`load_variant_scale`)
    budget: BudgetStudy | None = None  # the M2D2M budget study
    eta: EtaAxis | None = None  # the M2D2M η sweep
    guidance: GuidanceStudy | None = None  # the book's text-to-motion models scored in both guidance spaces

    @classmethod
    def load(cls, profile: str) -> Measurements:
        """Everything recorded for ``profile``, read from the results store and the repository's ``book/data/``."""
        from motionlab.studies.sweep import load_sweep

        budget = load_budget(profile)
        sweep_folder, today_folder = find_folder(SWEEP_FOLDER), embedded_data_folder(SWEEPS)
        return cls(
            recorded=load_all(profile),
            spread=load_spread(profile),
            sweep=load_sweep(sweep_folder) if sweep_folder is not None else None,
            sweep_today=load_sweep(today_folder) if today_folder is not None and today_folder.is_dir() else None,
            scale=load_scale_study(profile),
            variant_scale=load_variant_scale(profile),
            budget=budget,
            eta=load_eta_axis(profile, budget=budget),
            guidance=load_guidance_study(profile),
        )


def load_variant_scale(profile: str, folder: str | Path | None = None) -> ScaleStudy | None:
    """The x-prediction variant's scale points for ``profile`` (None where there are none).

    They were trained when the variant was the laptop's decoder, so their configs are no longer the code's and
    :func:`~motionlab.report.scale.load_scale_study` would set them aside; read by path, they measure the variant.
    """
    folder = Path(folder) if folder is not None else find_folder(VARIANT_SCALE_FOLDER)
    if folder is None:
        return None
    records = {}
    for path in sorted(folder.glob("*.json")):
        record = json.loads(path.read_text())
        if record.get("study") == "scale" and record.get("profile") == profile:
            records[record["group"], float(record["multiple"])] = record
    return ScaleStudy(profile, records) if records else None


def _result(key: str, estimate: Estimate, note: str) -> Result:
    """An estimate as a result the rules read (its interval, where it has one)."""
    chapter, name = key.split("/", 1)
    ci = (estimate.low, estimate.high) if estimate.half_width > 0 else None
    return Result(chapter, name, estimate.mean, ci, estimate.unit, note)


def sweep_results(study: Mapping[str, dict], variant: str, sampling: str = SWEEP_SAMPLING) -> dict[str, Result]:
    """One sweep variant's validation scores under the flow decoder's claim keys (``discord/sjpe_rf``, ...), with the
    feed-forward decoder's on the same clips under the ``_ff`` keys, so that the claims' own rules judge them."""
    from motionlab.studies.sweep import estimate

    run = study[variant]
    note = f"decoder sweep, {variant} at {sampling}, validation clips"
    out = {}
    for metric, name in SWEEP_METRICS.items():
        out[f"discord/{metric}_rf"] = _result(f"discord/{metric}_rf", estimate(run, sampling, name), note)
        out[f"discord/{metric}_ff"] = _result(f"discord/{metric}_ff", Estimate(run["feed_forward"][name]), note)
    return out


# ---------------------------------------------------------------------------------------------- DisCoRD


def _prediction(config: Any) -> str:
    target = {"v": "the velocity", "x": "the clean motion"}[config.prediction]
    t = config.temperature
    noise = "N(0, I)" if t == 1 else "zero noise (temperature 0)" if t == 0 else f"N(0, {t:g}²·I)"
    return f"predicts {target}, decodes from {noise}"


def _steps(config: Any) -> str:
    from motionlab.flow import n_evaluations

    evaluations = n_evaluations(config.sample_steps, config.solver)
    # the paper counts the points of the time grid: n intervals are n + 1 points
    points = config.sample_steps + 1
    return f"{config.sample_steps} {config.solver} intervals ({points} grid points, {evaluations} evaluations)"


def _normalization(config: Any) -> str:
    from motionlab.flow.config import FEAT_BIAS

    if config.normalization == "feat_bias":
        return f"MoMask's feat_bias: root and foot-contact std divided by {FEAT_BIAS:g} (`feat_bias`)"
    return "the tokenizer's per-feature std, every feature alike (`std`)"


def _width(config: Any) -> str:
    return f"{config.width}, levels {tuple(config.width_mults)}"


def _window(config: Any) -> str:
    return f"{config.window} frames ({config.tokens_per_window} tokens)"


def _windows(config: Any) -> str:
    return (
        f"{config.train_steps:,} steps × batch {config.batch_size} = {config.train_steps * config.batch_size:,} windows"
    )


def _build(paper: str, build: str) -> str:
    """The build's cell: its setting, or "as the paper" where it is the same."""
    return f"as the paper: {build}" if build == paper else build


def _sweep_why(study: Mapping[str, dict] | None, variants: Mapping[str, Sequence[str]], what: str) -> str:
    """``what`` chose the setting, then what study s1's sweep measured of ``variants`` (variant -> samplings): its
    validation sJPE after the same minutes of training, the steps each reached, and the link."""
    from motionlab.studies.sweep import estimate

    found = {v: samplings for v, samplings in variants.items() if study is not None and v in study}
    if not found:
        return f"{what}; study s1's sweep records are not in this checkout"
    parts = []
    for v, samplings in found.items():
        scores = ", ".join(f"{estimate(study[v], s, 'sjpe')} at {s}" for s in samplings)
        parts.append(f"`{v}` ({study[v]['checkpoints'][-1]['step']:,} steps) {scores}")
    first = study[next(iter(found))]
    minutes, ff = first["budget_s"] / 60, Estimate(first["feed_forward"]["sjpe"])
    return (
        f"{what}. Validation sJPE after {minutes:.0f} minutes of training each (`T1`: temperature 1): "
        f"{'; '.join(parts)}; feed-forward {ff} — {DECODER_SWEEP}"
    )


def _paper_width(today: Mapping[str, dict] | None) -> str:
    """What study s1's run of the paper's decoder above the motion's features scored (\"\" where it is not here)."""
    from motionlab.studies.sweep import estimate

    if today is None or PAPER_WIDTH_RUN not in today:
        return ""
    run = today[PAPER_WIDTH_RUN]
    width, minutes, ff = run["config"]["width"], run["budget_s"] / 60, Estimate(run["feed_forward"]["sjpe"])
    return (
        f". At width {width}, where the floor is 0, the paper's decoder trained {minutes:.0f} minutes on today's data "
        f"(`{PAPER_WIDTH_RUN}`) scores validation sJPE {estimate(run, SWEEP_SAMPLING, 'sjpe')} at {SWEEP_SAMPLING} "
        f"and {estimate(run, 'T0', 'sjpe')} from zero noise, feed-forward {ff}: above the floor the budget is what "
        "is left"
    )


def _sweep_settings(study: Mapping[str, dict] | None, variants: Mapping[str, str]) -> list[Setting]:
    """A setting per sweep variant present (label -> variant)."""
    if study is None:
        return []
    return [Setting(label, sweep_results(study, v)) for label, v in variants.items() if v in study]


def _sweep_departure(
    topic: str,
    paper: str,
    build: str,
    measured: Measurements,
    compared: Mapping[str, str],
    shown: Sequence[str],
    what: str,
    scope: str,
) -> Departure:
    """A departure judged on study s1's sweep: the claims on each of ``compared`` (label -> variant), decoders trained
    for the same minutes; the why cell says ``what`` chose the setting and shows the ``shown`` variants' scores."""
    settings = _sweep_settings(measured.sweep, compared)
    cell, depends = dependence(judge_settings(claims_reading(SWEEP_KEYS), settings), "study s1's sweep is not here")
    return Departure(
        topic,
        paper,
        _build(paper, build),
        _sweep_why(measured.sweep, dict.fromkeys(shown, (SWEEP_SAMPLING,)), what),
        f"at equal budgets ({scope}), {cell}" if settings else cell,
        depends,
    )


def discord_departures(profile: str, measured: Measurements) -> list[Departure]:
    """DisCoRD's departures at ``profile``: the decoder's config against the paper's (Table A, ``discord_config
    ("full")``), with what each departure does to the verdicts."""
    from motionlab.flow import discord_config
    from motionlab.flow.training import noise_floor
    from motionlab.models import xpred_config

    paper, build = discord_config("full"), discord_config(profile)
    variant = xpred_config(profile, None)
    recorded, spread = measured.recorded, measured.spread
    rows = []

    # prediction target and start noise: chapter 05 decodes the same test clips with the x-prediction variant
    judged = judge_settings(
        claims_reading(XPRED_KEYS),
        [
            Setting("the paper's decoder", recorded, {}, spread),
            Setting("x-prediction variant", recorded, XPRED_KEYS, spread),
        ],
    )
    cell, depends = dependence(judged, "chapter 05 records both decoders on the same test clips when it runs")
    rows.append(
        Departure(
            "prediction target and start noise",
            _prediction(paper),
            f"{_build(_prediction(paper), _prediction(build))}; the lever `discord/rvq-xpred` {_prediction(variant)}, "
            f"{variant.sample_steps} {variant.solver} intervals",
            _sweep_why(
                measured.sweep,
                {"v": (SWEEP_SAMPLING,), "x-w128": (SWEEP_SAMPLING, "T0")},
                "The paper's protocol; study s1 chose the variant when a decoder had minutes to train",
            ),
            cell,
            depends,
        )
    )

    # U-Net width: s1's sweep trained the same decoder at two widths for the same minutes
    floors = f"{noise_floor(paper):.2f} at the paper's width and {noise_floor(build):.2f} at the build's"
    width = _sweep_departure(
        "U-Net width",
        _width(paper),
        _width(build),
        measured,
        {"width 128": "x-w128", "width 64": "x-w64"},
        ("v", "x-w128", "x-w64"),
        "A narrower network trains more steps in the same minutes. Below the motion's "
        f"{build.feature_dim} features a velocity U-Net cannot see part of its start noise: the t = 0 loss has a "
        f"floor (D − w)/D of {floors}, whatever the budget (study s1); the x-prediction lever has none",
        "s1's sweep, x-prediction, temperature 1",
    )
    rows.append(replace(width, why=width.why + _paper_width(measured.sweep_today)))

    # solver steps: Table E decodes the same tokens at the paper's 16 grid points and at 2
    judged = judge_settings(
        claims_reading(STEPS16_KEYS),
        [
            Setting("16 grid points", recorded, STEPS16_KEYS, spread),
            Setting("2 grid points", recorded, STEPS2_KEYS, spread),
        ],
    )
    cell, depends = dependence(judged, "chapter 05's Table E records them when it runs")
    same = _steps(build) == _steps(paper)
    rows.append(
        Departure(
            "solver steps",
            _steps(paper),
            _build(_steps(paper), _steps(build)),
            f"the paper's (Table A); Table E of {DISCORD} decodes with fewer"
            if same
            else f"a decoder trained for seconds only shows the code runs; Table E of {DISCORD} measures the steps",
            f"judged on Table E's decodes, {cell}" if depends is not None else cell,
            depends,
        )
    )

    # training window
    if _window(build) == _window(paper):
        cell, depends = no_departure("trains on windows of the same length")
    else:
        cell, depends = f"not measured here: a decoder on {_window(paper)} is another model to train", None
    rows.append(
        Departure(
            "training window",
            _window(paper),
            _build(_window(paper), _window(build)),
            "the paper's (Table A)" if depends is False else "the profile's tokenizer window",
            cell,
            depends,
        )
    )

    # normalisation: s1's sweep trained the same decoder with and without MoMask's weighting
    rows.append(
        _sweep_departure(
            "feature normalisation",
            _normalization(paper),
            _normalization(build),
            measured,
            {"std": "x-w64", "feat_bias": "x-w64-feat"},
            ("x-w64", "x-w64-feat"),
            "One feature space for the tokenizer and the decoder, so that their errors weigh alike",
            "s1's sweep, width 64, x-prediction, temperature 1",
        )
    )

    # training budget: the scale study's points of the paper's decoder, else the variant's
    rows.append(_discord_budget(paper, build, measured))
    return rows


def _discord_budget(paper: Any, build: Any, measured: Measurements) -> Departure:
    """The decoder's training budget, and the claims judged at the multiples of it that the scale study trained."""
    ratio = paper.train_steps * paper.batch_size / (build.train_steps * build.batch_size)
    claims = claims_reading(XPRED_KEYS)
    scaled = [study_scale(c, measured.scale) for c in claims] if measured.scale is not None else []
    if any(s is not None for s in scaled):  # the paper's decoder at larger multiples, beside this build
        here = Setting("1×", measured.recorded, {}, measured.spread)
        judged = [
            Judged(c, (*judge_settings([c], [here])[0].verdicts, *((f"{m:g}×", v) for m, v in s.verdicts.items())))
            for c, s in zip(claims, scaled, strict=True)
            if s is not None
        ]
        cell, depends = dependence(judged, "this profile has not recorded chapter 05's decoder")
    else:
        cell, depends = f"{MISSING} for the paper's decoder (the scale study has no point of it yet)", None
        variant = measured.variant_scale
        if variant is not None:  # the x-prediction variant's points: its 1× is chapter 05's recorded lever
            settings = [Setting("1×", measured.recorded, XPRED_KEYS, measured.spread)]
            settings += [Setting(f"{m:g}×", variant.results(m)) for m in variant.multiples]
            text, depends = dependence(judge_settings(claims, settings), "chapter 05 has not recorded the variant")
            cell += f"; the x-prediction variant at multiples of the training samples, {text}"
    return Departure(
        "training budget",
        _windows(paper),
        f"{_windows(build)}, {ratio:,.0f}× fewer",
        f"what a laptop trains in minutes; {DECODER_SWEEP} follows sJPE over training minutes",
        cell,
        depends,
    )


# ---------------------------------------------------------------------------------------------- M2D2M


def _m2d2m_config(profile: str) -> Any:
    """The text-to-motion model's training config at ``profile`` (its codebook is the profile's VQ tokenizer's)."""
    from motionlab.diffusion.training import diffusion_training_config
    from motionlab.tokenizers import vq_config

    return diffusion_training_config(profile, num_codes=vq_config(profile).codebook_size)


def _schedule(name: str, T: int) -> str:
    from motionlab.diffusion import get_schedule

    s = get_schedule(name, T)
    alpha, gamma, kbeta = (float(x[-1]) for x in (s.alpha_bar, s.gamma_bar, s.kbeta_bar))
    return f"`{name}`: over T = {T} steps ᾱ falls to {alpha:.2g}, γ̄ rises to {gamma:.2g}, K·β̄ to {kbeta:.2g}"


def _network(t: Any) -> str:
    budget = f"{t.train_steps:,} steps" if t.train_steps else f"{t.epochs} epochs"
    network = f"{t.n_layers} layers, width {t.d_model}, {t.n_heads} heads, feed-forward {t.d_ff}"
    return f"{network}; {budget} at batch {t.batch_size}"


def _default(function: Any, parameter: str) -> Any:
    """A parameter's default, as the code that samples uses it."""
    return inspect.signature(function).parameters[parameter].default


GUIDANCE = {"x0": "p_θ(x₀ ∣ xₜ, y), as VQ-Diffusion's code does", "posterior": "p_θ(xₜ₋₁ ∣ xₜ, y), as Eq. 9 writes"}
JOINT_TEXT = {
    "own": "each action's tokens see their own text only",
    "all": "one compound condition: every action's text, seen by the whole sequence",
}


def m2d2m_departures(profile: str, measured: Measurements) -> list[Departure]:
    """M2D2M's departures at ``profile``: the text-to-motion model's config and samplers against the paper's
    (appendix A.1), with what each departure does to the verdicts."""
    from motionlab.diffusion import get_schedule, sample
    from motionlab.diffusion.schedule import vqdiffusion_code_schedule
    from motionlab.multimotion import MULTI_MOTION_ETA, two_phase_sample

    paper, build = _m2d2m_config("full"), _m2d2m_config(profile)
    recorded, spread = measured.recorded, measured.spread
    rows = []

    text = build.text
    rows.append(
        Departure(
            "text encoder",
            f"a frozen CLIP ViT-B/32 text tower ({paper.transformer.text_dim}-wide token features)",
            f"a word-level transformer trained jointly with the denoiser: width {text.dim}, {text.n_layers} layer(s), "
            f"{text.n_heads} heads",
            f"CLIP's weights are a download and the book downloads nothing when it runs; {DIFFUSION} shows how to "
            "load a local sentence encoder",
            "not measured here: judging it needs CLIP's weights (a download) and every text-to-motion model trained "
            "again",
            None,
        )
    )

    # the noise schedule: the paper's linear ᾱ/γ̄ against the public code's default, where β(t, d) has no mass
    T = paper.transformer.timesteps
    code = vqdiffusion_code_schedule(T)
    bound = float(code.kbeta_bar.max())
    affected = " and ".join(claim_label(c) for c in claims_reading(_DYNAMIC_VS_UNIFORM))
    book_bound = float(get_schedule(build.transformer.schedule, T).kbeta_bar.max())
    public_code = (
        f"under `{code.name}` the dynamic and uniform forward processes differ by at most K·β̄ = {bound:.0e} in total "
        f"variation (here: up to {book_bound:.2g}), so {affected} would compare two all but identical models"
    )
    if build.transformer.schedule == paper.transformer.schedule:
        cell, depends = no_departure("noises its tokens")
        cell += f"; VQ-Diffusion's code would not: {public_code}"
    else:
        cell, depends = f"not measured by training: {public_code}", None
    rows.append(
        Departure(
            "noise schedule",
            _schedule(paper.transformer.schedule, T),
            _build(_schedule(paper.transformer.schedule, T), _schedule(build.transformer.schedule, T)),
            f"VQ-Diffusion's public code defaults to `{code.name}`, where K·β̄ stays below {bound:.0e}: no token is "
            f"ever replaced, which is all that β(t, d) shapes — {DIFFUSION}",
            cell,
            depends,
        )
    )

    # model size and training budget: the budget study and the scale study trained the laptop's models for longer
    rows.append(
        Departure(
            "model size and training budget",
            _network(paper.transformer),
            _network(build.transformer),
            f"a few minutes of a CPU per model; {BUDGETS} trains the same models for longer",
            *_budget_dependence(measured),
        )
    )

    guided = _default(sample, "guidance_on")
    rows.append(
        Departure(
            "guidance space",
            f"classifier-free guidance on {GUIDANCE['posterior']}",
            _build(
                f"classifier-free guidance on {GUIDANCE['posterior']}",
                f"classifier-free guidance on {GUIDANCE[guided]}",
            ),
            f"the code the paper builds on guides the prediction of x₀; an exercise of {DIFFUSION} samples both",
            *_guidance_dependence(measured.guidance, spread),
        )
    )

    # the joint phase's text: chapter 09 samples the same instances with the compound condition
    joint = _default(two_phase_sample, "joint_text")
    judged = judge_settings(
        claims_reading(COMPOUND_KEYS, without=_OWN_TEXT_ONLY),
        [Setting("own text", recorded, {}, spread), Setting("compound condition", recorded, COMPOUND_KEYS, spread)],
    )
    cell, depends = dependence(judged, "chapter 09 records both rows when it runs")
    rows.append(
        Departure(
            "joint-phase text (Two-Phase Sampling)",
            f"{JOINT_TEXT['all']} (A.1's compound condition)",
            _build(JOINT_TEXT["all"], f'{JOINT_TEXT[joint]} (`joint_text="{joint}"`)'),
            f"Algorithm 1 pairs each action with its own text; {TPS} scores both on the same instances",
            cell,
            depends,
        )
    )

    def eta(t: Any) -> str:
        return f"η = {t.eta:g} single motions, {MULTI_MOTION_ETA:g} multi-motion"

    rows.append(
        Departure(
            "η of the dynamic transitions",
            eta(paper.transformer),
            _build(eta(paper.transformer), eta(build.transformer)),
            f"the paper's (A.1); {TRANSITIONS} shows what η does to the forward process, {BUDGETS} trains the "
            "dynamic model at larger η",
            *_eta_dependence(measured.eta, paper.transformer.eta, paper.transformer.guidance_scale),
        )
    )
    return rows


def _guidance_dependence(study: GuidanceStudy | None, spread: TrainingSpread | None) -> tuple[str, bool | None]:
    """Every claim on a generated motion, judged on the book's models sampled with guidance on x₀ and on the
    posterior (``experiments/guidance_space.py``: one machine, one precision, the chapters' sizes and seeds)."""
    if study is None:
        return f"{MISSING} (no guidance-space study is recorded for this profile)", None
    on_x0, on_posterior = study.results("x0"), study.results("posterior")
    settings = [Setting("on x₀", on_x0, {}, spread), Setting("on the posterior", on_posterior, {}, spread)]
    claims = claims_reading(set(on_x0) - MODEL_FREE)
    cell, depends = dependence(judge_settings(claims, settings), "the study measures none of the claims")
    return f"the book's models sampled both ways ({study.where}), {cell}", depends


def _budget_dependence(measured: Measurements) -> tuple[str, bool | None]:
    """Each M2D2M claim at every budget of the budget study and every multiple of the scale study."""
    budget, scale = measured.budget, measured.scale
    if budget is None and scale is None:
        return f"{MISSING} (no budget or scale study is recorded for this profile)", None
    judged = []
    for claim in (c for c in CLAIMS if c.paper == "M2D2M"):
        verdicts: list[tuple[str, str]] = []
        by_steps = scale_statement(claim, budget) if budget is not None else None
        if by_steps is not None:
            laptop = budget.laptop_steps
            verdicts += [(f"{n / laptop:g}× steps", v) for n, v in sorted(by_steps.verdicts.items())]
        by_samples = study_scale(claim, scale) if scale is not None else None
        if by_samples is not None:
            verdicts += [(f"{m:g}× samples", v) for m, v in sorted(by_samples.verdicts.items())]
        if verdicts:
            judged.append(Judged(claim, tuple(verdicts)))
    return dependence(judged, "the studies measure none of the claims")


def _eta_dependence(axis: EtaAxis | None, paper_eta: float, guidance_scale: float) -> tuple[str, bool | None]:
    """The claims that set dynamic against uniform transitions, judged at every η of the η sweep (η = 0 is the
    uniform model every one of them is compared with)."""
    if axis is None or 0.0 not in axis.records:
        return f"{MISSING} (no η sweep is recorded for this profile)", None
    columns = axis.columns(guidance_scale)
    fid, tps, independent = (
        columns[name]
        for name in (f"FID ↓ (s = {guidance_scale:g})", "TPS transition Jerk", "independent transition Jerk")
    )
    settings = []
    for eta in (e for e in axis.etas if e > 0):
        numbers = {
            "transitions/fid_dynamic": fid[eta],
            "transitions/fid_uniform": fid[0.0],
            "tps/jerk_tps": tps[eta],
            "tps/jerk_tps_uniform": tps[0.0],
            "tps/jerk_independent": independent[eta],
        }
        note = f"η sweep, η = {eta:g}"
        label = f"η = {eta:g}" + (" (the paper's)" if eta == paper_eta else "")
        settings.append(Setting(label, {k: _result(k, e, note) for k, e in numbers.items()}))
    claims = [c for c in CLAIMS if set(c.keys) <= set(settings[0].recorded)] if settings else []
    return dependence(judge_settings(claims, settings), "the η sweep measures none of the claims")


# ---------------------------------------------------------------------------------------------- rendering


def columns(profile: str) -> tuple[str, str, str, str]:
    """The table's four columns after the departure's name."""
    return ("what the paper does", f"what the {profile} build does", "why", "does a verdict depend on it")


def departures_table(rows: Sequence[Departure], profile: str):
    """The rows as a :class:`~motionlab.viz.tables.Table` (one line per departure; its Markdown escapes ``|``)."""
    from motionlab.viz.tables import Table

    names = columns(profile)
    # a Markdown table row is one line: a line break inside a cell would end it
    table = {r.topic: {n: " ".join(cell.split()) for n, cell in zip(names, r.cells(), strict=True)} for r in rows}
    return Table("departure", table, names)


def _join(names: Sequence[str]) -> str:
    """``*a*, *b* and *c*``: a row's name may hold an "and" of its own, so each is set apart."""
    names = [f"*{name}*" for name in names]
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def dependence_sentence(rows: Sequence[Departure], paper: str) -> str:
    """One sentence from the rows: which departures a verdict of ``paper`` depends on, which none does, and which
    were not measured."""
    by = {answer: [r.topic for r in rows if r.depends is answer] for answer in (True, False, None)}
    parts = []
    if by[True]:
        parts.append(f"A verdict of {paper} depends on {_join(by[True])}")
        if by[False]:
            parts.append(f"none depends on {_join(by[False])}")
    elif by[False]:
        parts.append(f"No verdict of {paper} depends on {_join(by[False])}")
    else:
        parts.append(f"No departure of {paper} was measured here")
    if by[None]:
        parts.append(f"not measured: {_join(by[None])}")
    return "; ".join(parts) + "."


__all__ = [
    "COMPOUND_KEYS",
    "Departure",
    "Judged",
    "Measurements",
    "Setting",
    "XPRED_KEYS",
    "claims_reading",
    "columns",
    "departures_table",
    "dependence",
    "dependence_sentence",
    "discord_departures",
    "judge_settings",
    "load_variant_scale",
    "m2d2m_departures",
    "substituted",
    "sweep_results",
    "verdict",
]
