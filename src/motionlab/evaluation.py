"""The papers' evaluation tables, computed end to end from a dataset and the book's cached models.

Three tasks, one function each; every one returns an :class:`EvaluationTable` (rows × metrics, each cell a
:class:`~motionlab.metrics.Estimate`: mean, 95 % half-width from Student's t with n − 1 degrees of freedom,
n runs):

==================  =========================================================================================
task                what is measured
==================  =========================================================================================
``reconstruction``  DisCoRD Table 1: test clips → tokens → decoded; FID, MPJPE (mm), sJPE, Noise/Static sJPE
                    (:mod:`motionlab.flow.reconstruction`). The tokenizer's feed-forward decoder is one
                    deterministic run; the DisCoRD decoder repeats over sampling seeds.
``t2m``             the text-to-motion protocol (both papers' main tables): R-precision top 1–3, FID,
                    MM-Dist, Diversity (+ MultiModality) of the diffusion model, and the real motions as
                    "Ground Truth" (:func:`motionlab.diffusion.pipeline.evaluate_text_to_motion`).
``multi``           M2D2M's multi-motion table: per-action and transition metrics of TPS and the baselines
                    on multi-action instances (:func:`motionlab.multimotion.evaluate_methods`).
==================  =========================================================================================

Models come from the cache, trained on first use exactly as ``motionlab train`` does, so the numbers are
those of the chapters' models. Every random draw is seeded from ``config.seed``: the same seed gives the
same table. :func:`write_json` stores a table atomically (a temporary file, then ``os.replace``).
"""

from __future__ import annotations

import json
import logging
import math
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from motionlab.metrics.protocol import Estimate, summarize_runs
from motionlab.precision import network_precision
from motionlab.profiles import get_profile

TASKS = ("reconstruction", "t2m", "multi")
SPLITS = ("train", "val", "test")
DEFAULT_REPEATS = {"smoke": 2, "laptop": 5, "full": 20}  # the papers use 20
R_PRECISION_BATCH = 32  # the T2M protocol ranks each text among 32 motions

RECONSTRUCTION_METRICS = ("fid", "mpjpe_mm", "sjpe", "noise_sjpe", "static_sjpe", "sjpe_ratio")
T2M_METRICS = ("top1", "top2", "top3", "fid", "mm_dist", "diversity", "multimodality")
MULTI_METRICS = ("r_top3", "fid", "mm_dist", "diversity", "transition_fid", "transition_diversity", "jerk")

# Column headers as the papers print them (↓ lower is better, ↑ higher, → closer to the real data).
METRIC_LABELS = {
    "fid": "FID ↓", "mpjpe_mm": "MPJPE (mm) ↓", "sjpe": "sJPE ↓", "noise_sjpe": "Noise sJPE ↓",
    "static_sjpe": "Static sJPE ↓", "sjpe_ratio": "sJPE (ratio, paper scale) ↓",
    "noise_sjpe_ratio": "Noise sJPE (ratio) ↓", "static_sjpe_ratio": "Static sJPE (ratio) ↓",
    "top1": "R-Top1 ↑", "top2": "R-Top2 ↑", "top3": "R-Top3 ↑", "r_top3": "R-Top3 ↑",
    "mm_dist": "MM-Dist ↓", "diversity": "Diversity →", "multimodality": "MModality ↑",
    "transition_fid": "Transition FID ↓", "transition_diversity": "Transition Diversity →", "jerk": "Jerk →",
}  # fmt: skip


# ----------------------------------------------------------------------------------------------- the table


@dataclass
class EvaluationTable:
    """One evaluation: ``rows[row][metric]`` is an :class:`Estimate` (mean, 95 % half-width, n runs).

    ``metrics`` orders the columns; a row may lack some (printed "–"). Rows in ``deterministic`` come from
    one run of a deterministic computation: their half-width is 0 by construction, not by measurement.
    """

    task: str
    profile: str
    data: str  # the dataset's key (folder name + normalisation digest)
    split: str
    repeats: int
    seed: int
    config: dict[str, Any]
    counts: dict[str, int]  # what was evaluated, e.g. {"clips": 42} or {"instances": 3, "actions": 4}
    metrics: tuple[str, ...]
    rows: dict[str, dict[str, Estimate]]
    deterministic: tuple[str, ...] = ()
    notes: list[str] = field(default_factory=list)
    precision: str = "fp32"  # what the models were trained and sampled in (motionlab.precision); metrics are fp32

    def header(self) -> str:
        """One line: task, profile, precision, dataset key, what was evaluated, repeats and seed."""
        counts = ", ".join(f"{n} {what}" for what, n in self.counts.items())
        repeats = f"{self.repeats} repeat{'s' if self.repeats != 1 else ''}"
        return (f"evaluate {self.task}: profile {self.profile}, {self.precision}, data {self.data}, split "
                f"{self.split}, {counts}, {repeats}, seed {self.seed}")  # fmt: skip

    def to_markdown(self, digits: int = 3) -> str:
        """A Markdown table, ``mean ± half-width`` per cell (the mean alone in deterministic or one-run rows)."""
        lines = ["| | " + " | ".join(METRIC_LABELS.get(m, m) for m in self.metrics) + " |",
                 "|---|" + "---:|" * len(self.metrics)]  # fmt: skip
        for name, row in self.rows.items():
            fixed = name in self.deterministic
            cells = [_cell(row[m], digits, fixed) if m in row else "–" for m in self.metrics]
            label = f"{name} (deterministic)" if fixed else name
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
        interval = "± = 95% interval of the mean, Student's t with n − 1 degrees of freedom."
        return "\n".join(lines + [f"\n{note}" for note in [*self.notes, interval]])

    def to_json_dict(self) -> dict[str, Any]:
        """Plain JSON types; a non-finite number becomes ``null`` (JSON has no NaN)."""
        rows = {name: {m: {"mean": _finite(e.mean), "ci95": _finite(e.half_width), "n": e.n} for m, e in row.items()}
                for name, row in self.rows.items()}  # fmt: skip
        return {"task": self.task, "profile": self.profile, "precision": self.precision, "data": self.data,
                "split": self.split,
                "repeats": self.repeats, "seed": self.seed, "config": self.config, "counts": self.counts,
                "metrics": list(self.metrics), "deterministic": list(self.deterministic), "notes": self.notes,
                "rows": rows}  # fmt: skip


def _cell(e: Estimate, digits: int, fixed: bool) -> str:
    # one run has no spread to report: print its value alone rather than a "± 0" that looks measured
    return f"{e.mean:.{digits}f}" if fixed or e.n < 2 else f"{e.mean:.{digits}f} ± {e.half_width:.{digits}f}"


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def check_json_path(path: str | Path, force: bool = False) -> Path:
    """Validate an output path *before* the work: its folder exists, and it is new unless ``force``."""
    path = Path(path)
    if path.suffix != ".json":
        raise ValueError(f"the JSON output must end in .json, got {str(path)!r}")
    if not path.parent.is_dir():
        raise ValueError(f"folder {str(path.parent)!r} of the JSON output does not exist")
    if path.exists() and not force:
        raise ValueError(f"{path} exists; pass force=True (--force) to replace it")
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a file")
    return path


def write_json(table: EvaluationTable, path: str | Path, force: bool = False) -> Path:
    """Write ``table.to_json_dict()`` to ``path`` atomically: a reader sees no file or the whole file."""
    from motionlab.io.common import write_text_atomic

    path = check_json_path(path, force)
    text = json.dumps(table.to_json_dict(), indent=1, ensure_ascii=False, allow_nan=False)
    return write_text_atomic(path, text + "\n")


# ----------------------------------------------------------------------------------------------- configs


def _check_int(name: str, value: Any, minimum: int, why: str = "") -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}{why}, got {value!r}")


def _check_common(cfg: Any, min_limit: int, why: str = "") -> None:
    if cfg.split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS}, got {cfg.split!r}")
    _check_int("repeats", cfg.repeats, 1)
    _check_int("seed", cfg.seed, 0)
    if getattr(cfg, "limit", None) is not None:
        _check_int("limit", cfg.limit, min_limit, why)


def _check_flow_options(cfg: Any, uses_flow: bool) -> None:
    """``steps``/``solver`` (and the decoder options) configure DisCoRD; refuse them where no flow decoder runs."""
    if not uses_flow and (cfg.steps is not None or cfg.solver is not None):
        raise ValueError("steps and solver set the DisCoRD decoder's ODE; they need decoder='discord'")
    chosen = [name for name in FLOW_OPTIONS if getattr(cfg, name, None) is not None]
    if not uses_flow and chosen:
        raise ValueError(f"{', '.join(chosen)} configure the DisCoRD decoder; they need decoder='discord'")
    if chosen:
        from motionlab.flow import DisCoRDConfig

        DisCoRDConfig(**{name: getattr(cfg, name) for name in chosen})  # validates each value
    if cfg.steps is not None:
        _check_int("steps", cfg.steps, 1)
    if cfg.solver is not None:
        from motionlab.flow import SOLVERS

        if cfg.solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, got {cfg.solver!r}")


# DisCoRD decoder options a reconstruction can choose (None: the profile's): which trained decoder, then how it samples.
FLOW_TRAINING_OPTIONS = ("prediction", "normalization", "time_distribution")
FLOW_SAMPLING_OPTIONS = ("temperature", "spacing", "final_prediction")
FLOW_OPTIONS = FLOW_TRAINING_OPTIONS + FLOW_SAMPLING_OPTIONS


@dataclass(frozen=True)
class ReconstructionConfig:
    """DisCoRD Table 1. ``decoder``: ``"vq"``/``"rvq"`` (that tokenizer's feed-forward decoder alone) or
    ``"discord"`` (the feed-forward row and the DisCoRD row, both on ``tokenizer``'s ids; default ``"rvq"``
    as MoMask + DisCoRD, ``"vq"`` gives T2M-GPT + DisCoRD). ``repeats`` applies to the DisCoRD row only.
    ``prediction``/``normalization``/``time_distribution`` choose (and train on first use) a decoder other than
    the profile's; ``temperature``/``spacing``/``final_prediction`` change only how it samples."""

    decoder: str = "discord"
    tokenizer: str | None = None
    steps: int | None = None  # ODE intervals (None: the decoder's config)
    solver: str | None = None  # "euler" | "midpoint" (None: the decoder's config)
    prediction: str | None = None  # "v" | "x"
    normalization: str | None = None  # "std" | "feat_bias"
    time_distribution: str | None = None  # "uniform" | "logit_normal"
    temperature: float | None = None  # start-noise scale
    spacing: str | None = None  # "uniform" | "data_dense"
    final_prediction: bool | None = None  # x-prediction: return x̂1 at the last step
    split: str = "test"
    limit: int | None = None  # the first `limit` clips of the split
    repeats: int = 1
    seed: int = 0

    def __post_init__(self):
        if self.decoder not in ("vq", "rvq", "discord"):
            raise ValueError(f"decoder must be 'vq', 'rvq' or 'discord', got {self.decoder!r}")
        if self.tokenizer is not None and self.tokenizer not in ("vq", "rvq"):
            raise ValueError(f"tokenizer must be 'vq' or 'rvq', got {self.tokenizer!r}")
        if self.tokenizer is not None and self.decoder != "discord":
            raise ValueError(f"decoder={self.decoder!r} is that tokenizer's own decoder; tokenizer= chooses the "
                             "tokens of decoder='discord' only")  # fmt: skip
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, 2, " (FID needs two clips)")

    @property
    def tokenizer_kind(self) -> str:
        return self.decoder if self.decoder != "discord" else (self.tokenizer or "rvq")


@dataclass(frozen=True)
class TextToMotionConfig:
    """The text-to-motion protocol. ``decoder``: ``"vq"`` or ``"discord"`` (the diffusion model's VQ tokens
    decoded by DisCoRD). ``num_steps``/``guidance_scale`` go to the sampler (None: all T steps, s = 4);
    MultiModality (when ``multimodality``) generates each of the first ``mm_texts`` captions ``mm_repeats``
    times per repeat (the T2M protocol: 100 × 30)."""

    decoder: str = "vq"
    steps: int | None = None
    solver: str | None = None
    num_steps: int | None = None
    guidance_scale: float | None = None
    multimodality: bool = False
    mm_texts: int = 100
    mm_repeats: int = 30
    split: str = "test"
    limit: int | None = None
    repeats: int = 1
    seed: int = 0

    def __post_init__(self):
        if self.decoder not in ("vq", "discord"):
            raise ValueError(f"decoder must be 'vq' or 'discord' (the diffusion model samples VQ tokens), "
                             f"got {self.decoder!r}")  # fmt: skip
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, R_PRECISION_BATCH, f" (R-precision ranks batches of {R_PRECISION_BATCH} clips)")
        _check_sampling(self)
        _check_int("mm_texts", self.mm_texts, 2)
        _check_int("mm_repeats", self.mm_repeats, 10, " (10 pairs are drawn among them)")


@dataclass(frozen=True)
class MultiMotionConfig:
    """M2D2M's multi-motion table: ``methods`` (of :data:`motionlab.multimotion.METHODS`) on ``instances``
    seeded instances of ``actions`` single-action captions (None: as many as the split's pool covers once).
    ``T_s`` is TPS's switch step (None: 0.9·T); ``num_steps``/``guidance_scale`` go to the sampler (None:
    all T steps, M2D2M's multi-motion s = 2)."""

    methods: tuple[str, ...] = ("tps", "independent")
    decoder: str = "vq"
    steps: int | None = None
    solver: str | None = None
    instances: int | None = None
    actions: int = 4
    T_s: int | None = None
    num_steps: int | None = None
    guidance_scale: float | None = None
    split: str = "test"
    repeats: int = 1
    seed: int = 0

    def __post_init__(self):
        from motionlab.multimotion import METHODS

        object.__setattr__(self, "methods", tuple(self.methods))
        if not self.methods or len(set(self.methods)) != len(self.methods):
            raise ValueError(f"methods must be a non-empty list without repeats, got {list(self.methods)}")
        unknown = [m for m in self.methods if m not in METHODS]
        if unknown:
            raise ValueError(f"unknown method(s) {unknown}; choose from {', '.join(METHODS)}")
        if self.decoder not in ("vq", "discord"):
            raise ValueError(f"decoder must be 'vq' or 'discord', got {self.decoder!r}")
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, 0)
        _check_sampling(self)
        _check_int("actions", self.actions, 2, " (a multi-motion has at least one transition)")
        if self.instances is not None:
            _check_int("instances", self.instances, 1)
            if self.instances * (self.actions - 1) < 2:
                raise ValueError(f"{self.instances} instance(s) of {self.actions} actions give fewer than the 2 "
                                 "transitions the transition metrics need")  # fmt: skip
        if self.T_s is not None:
            _check_int("T_s", self.T_s, 0)


# ------------------------------------------------------------------------------------------ size bounds

_MOTION_BYTES = 196 * 263 * 4  # one generated motion at the longest evaluated length, float32 features


def estimated_memory(config: Any) -> tuple[int, str]:
    """Bytes the generated motions of one evaluation step hold at once (an upper estimate), and which option
    sets it: multi holds every instance's actions for every method; MultiModality generates ``mm_texts ×
    mm_repeats`` motions in one go. Reconstruction is bounded by the dataset itself."""
    if isinstance(config, MultiMotionConfig) and config.instances is not None:
        n = config.instances * config.actions * (len(config.methods) + 1)
        return n * _MOTION_BYTES * 2, f"--instances {config.instances}"  # features and joints
    if isinstance(config, TextToMotionConfig) and config.multimodality:
        n = config.mm_texts * config.mm_repeats
        return n * _MOTION_BYTES * 2, f"--mm-texts {config.mm_texts} × --mm-repeats {config.mm_repeats}"
    return 0, ""


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``), None where unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_sampling(cfg: Any) -> None:
    if cfg.num_steps is not None:
        _check_int("num_steps", cfg.num_steps, 1)
    if cfg.guidance_scale is not None and not (math.isfinite(cfg.guidance_scale) and cfg.guidance_scale >= 0):
        raise ValueError(f"guidance_scale must be a finite number >= 0, got {cfg.guidance_scale!r}")


def default_repeats(profile: str | None = None) -> int:
    """Repeats per profile: 2 (smoke), 5 (laptop), the papers' 20 (full)."""
    return DEFAULT_REPEATS[get_profile(profile)]


# ----------------------------------------------------------------------------------------------- helpers


def _check_dataset(dataset: Any) -> None:
    for name in ("split", "normalizer", "key"):
        if not hasattr(dataset, name):
            raise ValueError(f"dataset must be a MotionDataset (split, normalizer, key); it lacks {name!r}")


def _split_clips(dataset: Any, split: str, limit: int | None, minimum: int, why: str) -> list:
    _check_dataset(dataset)
    clips = list(dataset.split(split))[:limit]
    if len(clips) < minimum:
        raise ValueError(f"the {split} split gives {len(clips)} clips but {why} needs at least {minimum}")
    return clips


def repeat_seed(seed: int, repeat: int, stream: int = 0) -> int:
    """A 32-bit seed for repeat ``repeat`` of ``stream``, drawn from ``SeedSequence([seed, stream, repeat])``:
    unrelated across repeats even where a decode adds a batch index to it (``decode_clips`` does)."""
    return int(np.random.SeedSequence([int(seed), int(stream), int(repeat)]).generate_state(1)[0])


def _once(scores: Mapping[str, float]) -> dict[str, Estimate]:
    """One deterministic run as estimates: half-width 0, n = 1."""
    return {k: Estimate(float(v), 0.0, 1) for k, v in scores.items()}


def _bar(total: int, desc: str, progress: bool, unit: str = "it"):
    return tqdm(total=total, desc=desc, disable=not progress, file=sys.stderr, leave=False, unit=unit)


# One INFO line per phase (the CLI shows them when stderr is a log file rather than a terminal).
log = logging.getLogger("motionlab.evaluate")


def _phase(text: str) -> None:
    log.info(text)


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


@dataclass
class _FlowSteps:
    """A DisCoRD decoder with the ODE's ``steps``/``solver`` fixed (callers that pass none get these)."""

    decoder: Any
    steps: int | None
    solver: str | None

    def decode(self, ids, tokenizer=None, steps=None, solver=None, generator=None, seed=None):
        steps = self.steps if steps is None else steps
        solver = self.solver if solver is None else solver
        return self.decoder.decode(ids, tokenizer=tokenizer, steps=steps, solver=solver, generator=generator,
                                   seed=seed)  # fmt: skip


def _flow_label(decoder: Any, steps: int | None, solver: str | None) -> str:
    cfg = decoder.config
    return f"{cfg.sample_steps if steps is None else steps} {cfg.solver if solver is None else solver} steps"


def _flow_options_label(decoder: Any) -> str:
    """``", x-prediction, temperature 0.5"``: what sets this decoder apart from the paper's (or "")."""
    from motionlab.flow import DisCoRDConfig

    cfg, paper = decoder.config, DisCoRDConfig()  # the class defaults are the paper's (the full profile)
    labels = {"prediction": f"{cfg.prediction}-prediction", "normalization": f"{cfg.normalization} normalisation",
              "time_distribution": f"{cfg.time_distribution} times", "temperature": f"temperature {cfg.temperature:g}",
              "spacing": f"{cfg.spacing} grid", "final_prediction": "last step x̂1"}  # fmt: skip
    return "".join(", " + text for name, text in labels.items() if getattr(cfg, name) != getattr(paper, name))


def _pipeline_and_decoder(dataset, cfg, profile: str, device, progress: bool):
    """The cached diffusion model, the evaluator, and the DisCoRD decoder of its VQ tokens (or None)."""
    from motionlab.diffusion.pipeline import text_to_motion_for_dataset
    from motionlab.metrics.evaluator_training import load_or_train_evaluator

    pipe = text_to_motion_for_dataset(dataset, profile, device=device, progress=progress)
    evaluator = load_or_train_evaluator(dataset, profile, device=device, progress=progress)
    if cfg.decoder != "discord":
        return pipe, evaluator, None, "VQ decoder"
    from motionlab.flow import train_or_load_discord

    flow = train_or_load_discord(dataset, pipe.tokenizer, profile, device=device, progress=progress)
    name = f"DisCoRD ({_flow_label(flow, cfg.steps, cfg.solver)})"
    return pipe, evaluator, _FlowSteps(flow, cfg.steps, cfg.solver), name


def _config(config: Any, kind: type) -> Any:
    if config is None:
        return kind()
    if not isinstance(config, kind):
        raise ValueError(f"config must be a {kind.__name__}, got {type(config).__name__}")
    return config


def _sampling(cfg) -> dict[str, Any]:
    options = {"num_steps": cfg.num_steps, "guidance_scale": cfg.guidance_scale}
    return {k: v for k, v in options.items() if v is not None}


def _table(task: str, dataset, profile: str, cfg, counts, metrics, rows, device=None, **kw) -> EvaluationTable:
    from .train.device import get_device

    return EvaluationTable(task, profile, dataset.key, cfg.split, cfg.repeats, cfg.seed, asdict(cfg), counts,
                           tuple(metrics), rows, precision=network_precision(get_device(device)), **kw)  # fmt: skip


# ----------------------------------------------------------------------------------------------- the tasks


def evaluate_reconstruction(dataset, config: ReconstructionConfig | None = None, profile: str | None = None, *,
                            device: str | None = None, progress: bool = False) -> EvaluationTable:  # fmt: skip
    """DisCoRD Table 1 on ``config.split``: ground truth → tokens → decoded, scored against the ground truth.

    The ground truth is each clip cropped to whole tokens (raw features); FID compares evaluator embeddings
    of the reconstructions with those of the ground truth. The feed-forward row is one run (deterministic);
    the DisCoRD row repeats ``config.repeats`` times, repeat r decoding from seed ``repeat_seed(seed, r)``, except
    at sampling temperature 0, where every seed decodes the same motion and one run is the whole distribution.
    """
    from motionlab.flow.reconstruction import decode_clips, reconstruction_scores
    from motionlab.metrics import ClipJoints
    from motionlab.metrics.evaluator_training import load_or_train_evaluator
    from motionlab.tokenizers import tokenizer_for_dataset

    cfg = _config(config, ReconstructionConfig)
    profile = get_profile(profile)
    clips = _split_clips(dataset, cfg.split, cfg.limit, 2, "FID")
    kind = cfg.tokenizer_kind
    _phase(f"reconstruction: {len(clips)} {cfg.split} clips; loading (or training) the {kind} tokenizer and "
           "the evaluator")  # fmt: skip
    tokenizer = tokenizer_for_dataset(kind, dataset, profile, device=device, progress=progress)
    evaluator = load_or_train_evaluator(dataset, profile, device=device, progress=progress)
    q, normalizer = int(tokenizer.downsample), dataset.normalizer
    normalized = [normalizer.normalize(c.features) for c in clips]  # (T_i, D) each, what the tokenizer reads
    gt = [c.features[: len(c.features) // q * q] for c in clips]  # raw, whole tokens
    gt_embeddings = evaluator.embed_motions(gt)  # (N, d), shared by every row's FID
    gt_joints = ClipJoints.from_features(gt)  # recovered once, shared by every row's MPJPE and sJPE

    def score(recon: list[np.ndarray]) -> dict[str, float]:
        raw = [normalizer.denormalize(r) for r in recon]
        return reconstruction_scores(raw, gt, evaluator.embed_motions, gt_embeddings, gt_joints).as_dict()

    name = "VQ-VAE" if kind == "vq" else "RVQ-VAE"
    feed_forward = f"{name} decoder"
    _phase(f"scoring the {feed_forward}")
    rows = {feed_forward: _once(score(decode_clips(normalized, tokenizer)))}
    deterministic = [feed_forward]
    notes = ["The feed-forward decoder is deterministic: one run, no interval."]
    if cfg.decoder == "discord":
        from motionlab.flow import discord_config, train_or_load_discord

        chosen = {name: getattr(cfg, name) for name in FLOW_OPTIONS if getattr(cfg, name) is not None}
        training = {k: v for k, v in chosen.items() if k in FLOW_TRAINING_OPTIONS}
        flow_config = discord_config(profile, tokenizer=tokenizer, **training)
        _phase("loading (or training) the DisCoRD decoder")
        flow = train_or_load_discord(dataset, tokenizer, profile, config=flow_config, device=device,
                                     progress=progress)  # fmt: skip
        sampling = {k: v for k, v in chosen.items() if k in FLOW_SAMPLING_OPTIONS}
        flow = flow.with_sampling(**sampling) if sampling else flow
        seeded = not flow.deterministic  # at temperature 0 every seed decodes the same motion
        repeats = cfg.repeats if seeded else 1
        runs = []
        with _bar(repeats, "DisCoRD repeats", progress) as bar:
            for r in range(repeats):
                _phase(f"DisCoRD repeat {r + 1} of {repeats}")
                recon = decode_clips(normalized, tokenizer, flow, steps=cfg.steps, solver=cfg.solver,
                                     seed=repeat_seed(cfg.seed, r))  # fmt: skip
                runs.append(score(recon))
                bar.update()
        flow_row = f"{name} tokens + DisCoRD ({_flow_label(flow, cfg.steps, cfg.solver)}{_flow_options_label(flow)})"
        rows[flow_row] = summarize_runs(runs) if seeded else _once(runs[0])
        if seeded:
            notes.append(f"DisCoRD: {cfg.repeats} sampling seeds.")
        else:
            notes.append("DisCoRD at temperature 0 decodes every seed to the same motion: one run, no interval.")
            deterministic.append(flow_row)
    return _table("reconstruction", dataset, profile, cfg, {"clips": len(clips)}, RECONSTRUCTION_METRICS, rows,
                  device, deterministic=tuple(deterministic), notes=[" ".join(notes)])  # fmt: skip


def evaluate_t2m(dataset, config: TextToMotionConfig | None = None, profile: str | None = None, *,
                 device: str | None = None, progress: bool = False) -> EvaluationTable:  # fmt: skip
    """The text-to-motion protocol on ``config.split``: a "Ground Truth" row (the real motions scored against
    drawn captions) and the diffusion model's row, each over ``config.repeats`` caption draws / generations
    (:func:`~motionlab.diffusion.pipeline.evaluate_text_to_motion`; repeat r: captions ``default_rng([seed,
    r])``, generation seed ``1000·seed + r``). MultiModality repeat r generates from ``repeat_seed(seed, r, 1)``.
    """
    from motionlab.diffusion.pipeline import evaluate_ground_truth, evaluate_text_to_motion, multimodality_score

    cfg = _config(config, TextToMotionConfig)
    profile = get_profile(profile)
    clips = _split_clips(dataset, cfg.split, cfg.limit, R_PRECISION_BATCH, "R-precision (batches of 32)")
    _phase(f"t2m: {len(clips)} {cfg.split} clips; loading (or training) the diffusion model and the evaluator")
    pipe, evaluator, decoder, decoder_name = _pipeline_and_decoder(dataset, cfg, profile, device, progress)
    sampling = _sampling(cfg)
    mm_clips = clips[: cfg.mm_texts]
    mm_motions = len(mm_clips) * cfg.mm_repeats  # per repeat, vs len(clips) for the protocol itself
    # The bar counts generated motions, so its ETA stays honest when the (much longer) MultiModality starts.
    bar = _bar(cfg.repeats * (len(clips) + (mm_motions if cfg.multimodality else 0)), "t2m generations", progress,
               unit="motion")  # fmt: skip
    timing = {"motions": 0, "seconds": 0.0}

    def generate(texts, lengths, *, seed, **kw):
        _phase(f"generating {len(texts)} motions (repeat {timing['motions'] // len(clips) + 1} of {cfg.repeats})")
        start = time.perf_counter()
        motions = pipe.generate(texts, lengths, seed=seed, decoder=decoder, **kw)
        timing["seconds"] += time.perf_counter() - start
        timing["motions"] += len(texts)
        bar.update(len(texts))
        return motions

    with bar:
        truth = evaluate_ground_truth(evaluator, clips, repeats=cfg.repeats, seed=cfg.seed)
        runs = evaluate_text_to_motion(generate, evaluator, clips, repeats=cfg.repeats, seed=cfg.seed, **sampling)
        if cfg.multimodality:
            per_motion = timing["seconds"] / max(timing["motions"], 1)
            _phase(f"MultiModality: {cfg.repeats} × {mm_motions} motions ({len(mm_clips)} texts × {cfg.mm_repeats}), "
                   f"about {_duration(cfg.repeats * mm_motions * per_motion)} at the "
                   f"{per_motion:.2f} s per motion measured so far")  # fmt: skip
            for r, run in enumerate(runs):
                _phase(f"MultiModality repeat {r + 1} of {cfg.repeats}")
                run["multimodality"] = multimodality_score(pipe, evaluator, mm_clips, n_repeats=cfg.mm_repeats,
                                                           seed=repeat_seed(cfg.seed, r, 1), decoder=decoder,
                                                           **sampling)  # fmt: skip
                bar.update(mm_motions)
    rows = {"Ground Truth": summarize_runs(truth), f"Discrete diffusion + {decoder_name}": summarize_runs(runs)}
    counts = {"clips": len(clips), **({"multimodality texts": len(mm_clips)} if cfg.multimodality else {})}
    return _table("t2m", dataset, profile, cfg, counts, T2M_METRICS if cfg.multimodality else T2M_METRICS[:-1], rows,
                  device)


def _method_rows(methods: Sequence[str], T_s: int) -> dict[str, dict[str, Any]]:
    """Row label -> evaluate_methods options for each method name."""
    from motionlab.multimotion import DEFAULT_TRANSITION

    labels = {"tps": f"TPS (T_s = {T_s})", "independent": "Independent (tokens concatenated)",
              "separate": "Separate (motions concatenated)", "slerp": f"SLERP ({DEFAULT_TRANSITION} frames)",
              "handshake": f"Handshake ({DEFAULT_TRANSITION} frames)"}  # fmt: skip
    return {labels[m]: {"method": m, **({"T_s": T_s} if m == "tps" else {})} for m in methods}


@dataclass
class _Counting:
    """A multi-motion generator that ticks a progress bar after every ``generate`` call."""

    generator: Any
    bar: Any
    done: int = 0

    def generate(self, *args, **kwargs):
        self.done += 1
        _phase(f"multi-motion generation {self.done} of {self.bar.total}")
        out = self.generator.generate(*args, **kwargs)
        self.bar.update()
        return out


def evaluate_multi(dataset, config: MultiMotionConfig | None = None, profile: str | None = None, *,
                   device: str | None = None, progress: bool = False) -> EvaluationTable:  # fmt: skip
    """M2D2M's multi-motion table on ``config.split``: the two ground-truth rows and one row per method.

    Instances come from :func:`~motionlab.multimotion.build_multi_action_testset` (seeded with ``seed``);
    FIDs compare with the split's real single-action clips and real windows cut from them
    (:func:`~motionlab.multimotion.build_reference`, ``rng=seed``); repeat r generates with seed ``seed + r``.
    "Ground Truth (Concat)" is one deterministic Jerk value.
    """
    from motionlab.multimotion import (
        MultiMotionGenerator,
        build_multi_action_testset,
        build_reference,
        evaluate_methods,
        single_action_pool,
    )

    cfg = _config(config, MultiMotionConfig)
    profile = get_profile(profile)
    _check_dataset(dataset)
    pool = single_action_pool(dataset, cfg.split)
    if len(pool) < 2:
        raise ValueError(f"the {cfg.split} split has {len(pool)} single-action clips; the reference needs 2")
    instances = build_multi_action_testset(dataset, cfg.actions, seed=cfg.seed, n_instances=cfg.instances,
                                           split=cfg.split)  # fmt: skip
    if len(instances) * (cfg.actions - 1) < 2:
        raise ValueError(f"{len(instances)} instance(s) of {cfg.actions} actions give fewer than 2 transitions; "
                         "ask for more instances")  # fmt: skip
    _phase(f"multi: {len(instances)} instances of {cfg.actions} actions; loading (or training) the diffusion model "
           "and the evaluator")  # fmt: skip
    pipe, evaluator, decoder, decoder_name = _pipeline_and_decoder(dataset, cfg, profile, device, progress)
    T = int(pipe.transitions.T)
    T_s = round(0.9 * T) if cfg.T_s is None else cfg.T_s
    if T_s > T:
        raise ValueError(f"T_s must be in [0, T={T}], got {T_s}")
    reference = build_reference(evaluator, [p.clip for p in pool], rng=cfg.seed)
    methods = _method_rows(cfg.methods, T_s)
    with _bar(cfg.repeats * len(methods), "multi-motion generations", progress) as bar:
        generator = _Counting(MultiMotionGenerator.from_pipeline(pipe, decoder=decoder), bar)
        summary = evaluate_methods(generator, instances, evaluator, reference, methods=methods, repeats=cfg.repeats,
                                   seed=cfg.seed, **_sampling(cfg))  # fmt: skip
    concat = "Ground Truth (Concat)"
    rows = {name: {m: Estimate(mean, half, 1 if name == concat else cfg.repeats) for m, (mean, half) in row.items()}
            for name, row in summary.items()}  # fmt: skip
    counts = {"instances": len(instances), "actions each": cfg.actions, "single-action clips": len(pool)}
    notes = [f"Decoder: {decoder_name}. Jerk is Eq. 10 at the transitions: closer to Ground Truth (Single) is better."]
    return _table("multi", dataset, profile, cfg, counts, MULTI_METRICS, rows, device, deterministic=(concat,),
                  notes=notes)  # fmt: skip


EVALUATORS = {"reconstruction": evaluate_reconstruction, "t2m": evaluate_t2m, "multi": evaluate_multi}

__all__ = [
    "DEFAULT_REPEATS",
    "EVALUATORS",
    "EvaluationTable",
    "MultiMotionConfig",
    "ReconstructionConfig",
    "TASKS",
    "TextToMotionConfig",
    "check_json_path",
    "default_repeats",
    "evaluate_multi",
    "evaluate_reconstruction",
    "evaluate_t2m",
    "repeat_seed",
    "write_json",
]
