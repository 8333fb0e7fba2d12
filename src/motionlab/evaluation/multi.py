"""M2D2M's multi-motion tables (Tables 1, 5, 6 and the T_s sweep): per-action and transition metrics of TPS and the
baselines, for one text-to-motion model and one token decoder."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from motionlab.profiles import get_profile

from .common import (
    _bar,
    _check_common,
    _check_dataset,
    _check_flow_options,
    _check_int,
    _check_sampling,
    _config,
    _flow_label,
    _FlowSteps,
    _phase,
    _sampling,
    _table,
    command_line,
)
from .table import MULTI_METRICS, EvaluationTable

# A method spec is a method name with per-row options: "tps", "tps:T_s=50", "tps:joint_text=all",
# "handshake:transition=40" (several options: "tps:T_s=50:joint_text=all").
METHOD_OPTIONS = {
    "tps": ("T_s", "joint_text"),
    "independent": (),
    "separate": (),
    "slerp": ("transition",),
    "handshake": ("transition",),
}
# M2D2M Tables 1, 5 and 6 on one model: concatenation both ways, TPS at T_s = 0.9 T with either joint condition, the
# T_s sweep (T_s = T is "independent"), and the two older joining methods at the paper's 40-frame transition.
PAPER_METHODS = (
    "independent",
    "separate",
    "tps",
    "tps:joint_text=all",
    "tps:T_s=50",
    "tps:T_s=0",
    "handshake:transition=40",
    "slerp:transition=40",
)
PAPER_MODEL = "t2m/multi-eta0.25"  # M2D2M's multi-motion model: dynamic β(t, d) at η = 0.25
SEGMENT_JERK = "segment_jerk"  # the column of the Jerk inside the actions


def parse_method(spec: str) -> tuple[str, dict[str, Any]]:
    """``"tps:T_s=50:joint_text=all"`` -> ``("tps", {"T_s": 50, "joint_text": "all"})``, each option checked."""
    from motionlab.multimotion import JOINT_TEXTS

    if not isinstance(spec, str) or not spec:
        raise ValueError(f"a method must be a non-empty string like 'tps' or 'tps:T_s=50', got {spec!r}")
    name, *parts = spec.split(":")
    if name not in METHOD_OPTIONS:
        raise ValueError(f"unknown method(s) [{name!r}]; choose from {', '.join(METHOD_OPTIONS)}")
    options: dict[str, Any] = {}
    for part in parts:
        key, sep, value = part.partition("=")
        if not sep or key not in METHOD_OPTIONS[name]:
            allowed = ", ".join(f"{k}=..." for k in METHOD_OPTIONS[name]) or "none"
            raise ValueError(f"method {spec!r}: {part!r} is not an option of {name} (options: {allowed})")
        if key in options:
            raise ValueError(f"method {spec!r} sets {key} twice")
        if key == "joint_text":
            if value not in JOINT_TEXTS:
                raise ValueError(f"method {spec!r}: joint_text must be one of {JOINT_TEXTS}, got {value!r}")
            options[key] = value
            continue
        try:
            number = int(value)
        except ValueError:
            raise ValueError(f"method {spec!r}: {key} must be an int, got {value!r}") from None
        if key == "T_s":
            _check_int(f"method {spec!r}: T_s", number, 0)
        elif number <= 0 or number % 8:  # half of the window on each side of a boundary, in whole 4-frame tokens
            raise ValueError(f"method {spec!r}: transition must be a positive multiple of 8 frames, got {number}")
        options[key] = number
    return name, options


_LABELS = {
    "independent": "Independent (tokens concatenated)",
    "separate": "Separate (motions concatenated)",
    "slerp": "SLERP",
    "handshake": "Handshake",
}


def method_rows(methods: Sequence[str], T_s: int) -> dict[str, dict[str, Any]]:
    """Row label -> :func:`~motionlab.multimotion.evaluate_methods` options for each method spec; ``T_s`` is TPS's
    switch step where a spec gives none. Labels: ``TPS (T_s = 90)``, ``TPS (T_s = 90, compound condition)``,
    ``Independent (tokens concatenated)``, ``Separate (motions concatenated)``, ``SLERP (40 frames)``, ..."""
    from motionlab.multimotion import DEFAULT_TRANSITION

    rows: dict[str, dict[str, Any]] = {}
    for spec in methods:
        name, options = parse_method(spec)
        if name == "tps":
            options = {"T_s": T_s, **options}
            compound = ", compound condition" if options.get("joint_text") == "all" else ""
            label = f"TPS (T_s = {options['T_s']}{compound})"
        elif name in ("slerp", "handshake"):
            label = f"{_LABELS[name]} ({options.get('transition', DEFAULT_TRANSITION)} frames)"
        else:
            label = _LABELS[name]
        if label in rows:
            raise ValueError(f"methods {list(methods)} give the row {label!r} twice")
        rows[label] = {"method": name, **options}
    return rows


@dataclass(frozen=True)
class MultiMotionConfig:
    """M2D2M's multi-motion table: ``methods`` (specs of :data:`METHOD_OPTIONS`, e.g. ``"tps:T_s=50"``) of the
    text-to-motion ``model`` (a :func:`motionlab.models.load` name) decoded by ``decoder`` (``vq`` or ``discord``,
    whose ODE ``steps``/``solver`` None keeps its config's), on ``instances`` seeded instances of ``actions``
    single-action captions (None: as many as the split's pool covers once). ``T_s`` is TPS's switch step where a
    spec gives none (None: 0.9·T); ``segment_jerk`` adds the Jerk inside the actions; ``num_steps``/``guidance_scale``
    go to the sampler (None: all T steps, M2D2M's multi-motion s = 2), and so does ``guidance_on`` (``"x0"``:
    guidance on p_θ(x_0 | x_t), VQ-Diffusion's code; ``"posterior"``: on p_θ(x_{t-1} | x_t), Eq. 9)."""

    methods: tuple[str, ...] = ("tps", "independent")
    model: str = "t2m/dynamic"
    decoder: str = "vq"
    steps: int | None = None
    solver: str | None = None
    instances: int | None = None
    actions: int = 4
    T_s: int | None = None
    segment_jerk: bool = False
    num_steps: int | None = None
    guidance_scale: float | None = None
    guidance_on: str = "x0"
    split: str = "test"
    repeats: int = 1
    seed: int = 0

    def __post_init__(self):
        methods = (self.methods,) if isinstance(self.methods, str) else tuple(self.methods)
        object.__setattr__(self, "methods", methods)
        if not methods or len(set(methods)) != len(methods):
            raise ValueError(f"methods must be a non-empty list without repeats, got {list(methods)}")
        unknown = [m.split(":")[0] for m in methods if not isinstance(m, str) or m.split(":")[0] not in METHOD_OPTIONS]
        if unknown:
            raise ValueError(f"unknown method(s) {unknown}; choose from {', '.join(METHOD_OPTIONS)}")
        for spec in methods:
            parse_method(spec)
        if not isinstance(self.model, str) or not self.model.startswith("t2m/"):
            raise ValueError(
                f"model must name a text-to-motion model of motionlab.models, e.g. t2m/uniform; got {self.model!r}"
            )
        if self.decoder not in ("vq", "discord"):
            raise ValueError(f"decoder must be 'vq' or 'discord', got {self.decoder!r}")
        if not isinstance(self.segment_jerk, bool):
            raise ValueError(f"segment_jerk must be True or False, got {self.segment_jerk!r}")
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, 0)
        _check_sampling(self)
        _check_int("actions", self.actions, 2, " (a multi-motion has at least one transition)")
        if self.instances is not None:
            _check_int("instances", self.instances, 1)
            if self.instances * (self.actions - 1) < 2:
                raise ValueError(
                    f"{self.instances} instance(s) of {self.actions} actions give fewer than the 2 "
                    "transitions the transition metrics need"
                )
        if self.T_s is not None:
            _check_int("T_s", self.T_s, 0)

    def command_line(self, profile: str | None = None) -> str:
        """The ``motionlab evaluate multi`` command that computes this table (see :func:`command_line`)."""
        return command_line(self, "multi", profile)


def paper_config(sizes, seed: int = 0, **changes: Any) -> MultiMotionConfig:
    """M2D2M Tables 1, 5 and 6 (:data:`PAPER_METHODS` of :data:`PAPER_MODEL`, with the Jerk inside the actions) at
    ``sizes`` (a :class:`motionlab.sizes.TPSSizes`: instances, repeats, sampling steps); ``changes`` set other
    fields, e.g. ``model="t2m/uniform"``. Chapter 09's config."""
    options = dict(
        methods=PAPER_METHODS,
        model=PAPER_MODEL,
        segment_jerk=True,
        instances=sizes.instances,
        repeats=sizes.repeats,
        num_steps=sizes.num_steps,
        seed=seed,
    )
    return MultiMotionConfig(**{**options, **changes})


# chapter 09's claim numbers (``tps/<key>``): the metric of each method spec of PAPER_METHODS, or of a reference row
_CLAIM_METHODS = {
    "jerk_tps": ("tps", "jerk"),
    "jerk_independent": ("independent", "jerk"),
    "jerk_separate": ("separate", "jerk"),
    "jerk_handshake": ("handshake:transition=40", "jerk"),
    "jerk_slerp": ("slerp:transition=40", "jerk"),
    "segment_jerk_tps": ("tps", SEGMENT_JERK),
    "fid_separate": ("separate", "fid"),
    "fid_ts100": ("independent", "fid"),  # T_s = T: no joint step, each action alone
    "fid_ts90": ("tps", "fid"),
    "fid_ts50": ("tps:T_s=50", "fid"),
    "fid_handshake": ("handshake:transition=40", "fid"),
    "fid_slerp": ("slerp:transition=40", "fid"),
    "r_top3_tps": ("tps", "r_top3"),
    "r_top3_independent": ("independent", "r_top3"),
    "r_top3_tps_compound": ("tps:joint_text=all", "r_top3"),
    "fid_tps_compound": ("tps:joint_text=all", "fid"),
    "jerk_tps_compound": ("tps:joint_text=all", "jerk"),
}


def claim_cells(table: EvaluationTable, T_s: int = 90) -> dict[str, tuple[str, str]]:
    """Which cell of a multi-motion table each of chapter 09's claim numbers is: ``{key: (row, metric)}`` for the
    ``tps/<key>`` results the claims table judges (the ground-truth Jerks and every method of :data:`PAPER_METHODS`
    whose row the table has). ``T_s`` is TPS's switch step where a spec gives none (the tables' 0.9·T of T = 100).
    """
    from motionlab.multimotion import GROUND_TRUTH_CONCAT, GROUND_TRUTH_SINGLE

    cells = {
        "jerk_gt_single": (GROUND_TRUTH_SINGLE, "jerk"),
        "jerk_gt_concat": (GROUND_TRUTH_CONCAT, "jerk"),
        "jerk_concat_minus_inside": (GROUND_TRUTH_CONCAT, "cut_minus_inside"),
    }
    for key, (spec, metric) in _CLAIM_METHODS.items():
        (label,) = method_rows((spec,), T_s)
        cells[key] = (label, metric)
    return {key: (row, m) for key, (row, m) in cells.items() if m in table.rows.get(row, {})}


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


def _models(dataset, cfg: MultiMotionConfig, profile: str, device, progress: bool):
    """The text-to-motion pipeline ``cfg.model``, the evaluator, and the DisCoRD decoder of its VQ tokens (or None)."""
    from motionlab import models
    from motionlab.metrics.evaluator_training import load_or_train_evaluator

    pipe = models.load(cfg.model, dataset, profile, device=device)
    evaluator = load_or_train_evaluator(dataset, profile, device=device, progress=progress)
    if cfg.decoder != "discord":
        return pipe, evaluator, None, "VQ decoder"
    flow = models.load("discord/vq", dataset, profile, device=device)  # the decoder of the pipeline's VQ tokens
    return (
        pipe,
        evaluator,
        _FlowSteps(flow, cfg.steps, cfg.solver),
        f"DisCoRD ({_flow_label(flow, cfg.steps, cfg.solver)})",
    )


def evaluate_multi(
    dataset,
    config: MultiMotionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
    generated: dict | None = None,
    tokens: dict | None = None,
) -> EvaluationTable:
    """M2D2M's multi-motion table on ``config.split``: the two ground-truth rows and one row per method.

    Instances come from :func:`~motionlab.multimotion.build_multi_action_testset` (seeded with ``seed``; the
    generated rows use the first ``instances``); FIDs compare with the split's real single-action clips and real
    windows cut from them (:func:`~motionlab.multimotion.build_reference`, ``rng=seed``); repeat r generates with
    seed ``seed + r``. The ground-truth Jerks are measured on every instance the pool covers
    (:func:`~motionlab.multimotion.ground_truth_jerks`, ``rng=seed``), with intervals over windows and cuts; Ground
    Truth (Concat) also has the cell ``cut_minus_inside`` (each cut − the Jerk inside the two clips it joins).

    :attr:`EvaluationTable.samples` holds per row and metric the values behind each estimate (per repeat; per
    boundary for a method's ``jerk``), so that ``table.paired("TPS (T_s = 90)", "Independent (tokens
    concatenated)", "jerk")`` is the paired difference per boundary. ``generated`` (a dict) receives the motions,
    ``{row: [motions of repeat 0, 1, ...]}``, for figures.
    """
    from motionlab.multimotion import (
        GROUND_TRUTH_CONCAT,
        MultiMotionGenerator,
        build_multi_action_testset,
        build_reference,
        evaluate_methods,
        ground_truth_jerks,
        single_action_pool,
    )
    from motionlab.multimotion.evaluation import _finite_estimate

    cfg = _config(config, MultiMotionConfig)
    profile = get_profile(profile)
    _check_dataset(dataset)
    for name, value in (("generated", generated), ("tokens", tokens)):
        if value is not None and not isinstance(value, dict):
            raise ValueError(f"{name} must be a dict (filled by the evaluation) or None, got {type(value).__name__}")
    pool = single_action_pool(dataset, cfg.split)
    if len(pool) < 2:
        raise ValueError(f"the {cfg.split} split has {len(pool)} single-action clips; the reference needs 2")
    # The instances are drawn one after another from one seeded generator: the first k of a longer draw are the k.
    every = max(len(pool) // cfg.actions, cfg.instances or 0)
    everything = build_multi_action_testset(dataset, cfg.actions, seed=cfg.seed, n_instances=every, split=cfg.split)
    instances = everything[: cfg.instances]
    if len(instances) * (cfg.actions - 1) < 2:
        raise ValueError(
            f"{len(instances)} instance(s) of {cfg.actions} actions give fewer than 2 transitions; "
            "ask for more instances"
        )
    _phase(
        f"multi: {len(instances)} instances of {cfg.actions} actions; loading (or training) {cfg.model} "
        "and the evaluator"
    )
    pipe, evaluator, decoder, decoder_name = _models(dataset, cfg, profile, device, progress)
    T = int(pipe.transitions.T)
    T_s = round(0.9 * T) if cfg.T_s is None else cfg.T_s
    methods = method_rows(cfg.methods, T_s)
    too_late = [label for label, spec in methods.items() if spec.get("T_s", 0) > T]
    if too_late:
        raise ValueError(f"T_s must be in [0, T={T}]; {too_late} switch later")
    reference = build_reference(evaluator, [p.clip for p in pool], rng=cfg.seed)
    # Real data costs nothing to score: the ground-truth Jerks use every instance, not the generated subset.
    ground_truth = ground_truth_jerks(everything, reference.window, rng=cfg.seed)
    samples: dict = {}
    with _bar(cfg.repeats * len(methods), "multi-motion generations", progress) as bar:
        drawn = {} if tokens is None else tokens.setdefault((cfg.model, dataset.key, cfg.split, str(device)), {})
        generator = _Counting(MultiMotionGenerator.from_pipeline(pipe, decoder=decoder, token_cache=drawn), bar)
        rows = evaluate_methods(
            generator,
            instances,
            evaluator,
            reference,
            methods=methods,
            repeats=cfg.repeats,
            seed=cfg.seed,
            generated=generated,
            ground_truth=ground_truth,
            with_segment_jerk=cfg.segment_jerk,
            samples=samples,
            **_sampling(cfg),
        )
    cut_minus_inside = _finite_estimate(ground_truth.cut_minus_inside)
    rows[GROUND_TRUTH_CONCAT]["cut_minus_inside"] = cut_minus_inside
    counts = {
        "instances": len(instances),
        "actions each": cfg.actions,
        "single-action clips": len(pool),
        "instances for the ground-truth Jerk": len(everything),
    }
    notes = [
        f"Model: {cfg.model}. Decoder: {decoder_name}. Jerk is Eq. 10 at the transitions: closer to Ground Truth "
        "(Single) is better." + (" Guidance on p_θ(x_{t-1} | x_t) (Eq. 9)." if cfg.guidance_on == "posterior" else ""),
        f"Ground-truth Jerks on all {len(everything)} instances: {ground_truth.single.size} windows inside real clips "
        f"(Single), {ground_truth.concat.size} cuts between them (Concat); each cut − the Jerk inside the two clips it "
        f"joins: {cut_minus_inside} (cut_minus_inside).",
    ]
    if cfg.segment_jerk:
        notes.append("segment_jerk: Eq. 10 on one random window inside each action, away from the transitions.")
    metrics = (*MULTI_METRICS, SEGMENT_JERK) if cfg.segment_jerk else MULTI_METRICS
    return _table("multi", dataset, profile, cfg, counts, metrics, rows, device, notes=notes, samples=samples)
