"""M2D2M's multi-motion table (Tables 1, 5, 6): per-action and transition metrics of TPS and the baselines."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from motionlab.estimate import Estimate
from motionlab.profiles import get_profile

from .common import (
    _bar,
    _check_common,
    _check_dataset,
    _check_flow_options,
    _check_int,
    _check_sampling,
    _config,
    _phase,
    _pipeline_and_decoder,
    _sampling,
    _table,
)
from .table import MULTI_METRICS, EvaluationTable


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
                raise ValueError(
                    f"{self.instances} instance(s) of {self.actions} actions give fewer than the 2 "
                    "transitions the transition metrics need"
                )
        if self.T_s is not None:
            _check_int("T_s", self.T_s, 0)


def _method_rows(methods: Sequence[str], T_s: int) -> dict[str, dict[str, Any]]:
    """Row label -> evaluate_methods options for each method name."""
    from motionlab.multimotion import DEFAULT_TRANSITION

    labels = {
        "tps": f"TPS (T_s = {T_s})",
        "independent": "Independent (tokens concatenated)",
        "separate": "Separate (motions concatenated)",
        "slerp": f"SLERP ({DEFAULT_TRANSITION} frames)",
        "handshake": f"Handshake ({DEFAULT_TRANSITION} frames)",
    }
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


def evaluate_multi(
    dataset,
    config: MultiMotionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
) -> EvaluationTable:
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
    instances = build_multi_action_testset(
        dataset, cfg.actions, seed=cfg.seed, n_instances=cfg.instances, split=cfg.split
    )
    if len(instances) * (cfg.actions - 1) < 2:
        raise ValueError(
            f"{len(instances)} instance(s) of {cfg.actions} actions give fewer than 2 transitions; "
            "ask for more instances"
        )
    _phase(
        f"multi: {len(instances)} instances of {cfg.actions} actions; loading (or training) the diffusion model "
        "and the evaluator"
    )
    pipe, evaluator, decoder, decoder_name = _pipeline_and_decoder(dataset, cfg, profile, device, progress)
    T = int(pipe.transitions.T)
    T_s = round(0.9 * T) if cfg.T_s is None else cfg.T_s
    if T_s > T:
        raise ValueError(f"T_s must be in [0, T={T}], got {T_s}")
    reference = build_reference(evaluator, [p.clip for p in pool], rng=cfg.seed)
    methods = _method_rows(cfg.methods, T_s)
    with _bar(cfg.repeats * len(methods), "multi-motion generations", progress) as bar:
        generator = _Counting(MultiMotionGenerator.from_pipeline(pipe, decoder=decoder), bar)
        summary = evaluate_methods(
            generator,
            instances,
            evaluator,
            reference,
            methods=methods,
            repeats=cfg.repeats,
            seed=cfg.seed,
            **_sampling(cfg),
        )
    concat = "Ground Truth (Concat)"
    rows = {
        name: {m: Estimate(mean, half, 1 if name == concat else cfg.repeats) for m, (mean, half) in row.items()}
        for name, row in summary.items()
    }
    counts = {"instances": len(instances), "actions each": cfg.actions, "single-action clips": len(pool)}
    notes = [f"Decoder: {decoder_name}. Jerk is Eq. 10 at the transitions: closer to Ground Truth (Single) is better."]
    return _table(
        "multi", dataset, profile, cfg, counts, MULTI_METRICS, rows, device, deterministic=(concat,), notes=notes
    )
