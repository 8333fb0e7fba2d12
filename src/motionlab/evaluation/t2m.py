"""The text-to-motion protocol (M2D2M Table 3): R-precision, FID, MM-Dist, Diversity, MultiModality."""

from __future__ import annotations

import time
from dataclasses import dataclass

from motionlab.estimate import summarize_runs
from motionlab.profiles import get_profile

from .common import (
    _bar,
    _check_common,
    _check_flow_options,
    _check_int,
    _check_sampling,
    _config,
    _duration,
    _phase,
    _pipeline_and_decoder,
    _sampling,
    _split_clips,
    _table,
    repeat_seed,
)
from .table import R_PRECISION_BATCH, T2M_METRICS, EvaluationTable


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
            raise ValueError(
                f"decoder must be 'vq' or 'discord' (the diffusion model samples VQ tokens), got {self.decoder!r}"
            )
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, R_PRECISION_BATCH, f" (R-precision ranks batches of {R_PRECISION_BATCH} clips)")
        _check_sampling(self)
        _check_int("mm_texts", self.mm_texts, 2)
        _check_int("mm_repeats", self.mm_repeats, 10, " (10 pairs are drawn among them)")


def evaluate_t2m(
    dataset,
    config: TextToMotionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
) -> EvaluationTable:
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
    bar = _bar(
        cfg.repeats * (len(clips) + (mm_motions if cfg.multimodality else 0)),
        "t2m generations",
        progress,
        unit="motion",
    )
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
            _phase(
                f"MultiModality: {cfg.repeats} × {mm_motions} motions ({len(mm_clips)} texts × {cfg.mm_repeats}), "
                f"about {_duration(cfg.repeats * mm_motions * per_motion)} at the "
                f"{per_motion:.2f} s per motion measured so far"
            )
            for r, run in enumerate(runs):
                _phase(f"MultiModality repeat {r + 1} of {cfg.repeats}")
                run["multimodality"] = multimodality_score(
                    pipe,
                    evaluator,
                    mm_clips,
                    n_repeats=cfg.mm_repeats,
                    seed=repeat_seed(cfg.seed, r, 1),
                    decoder=decoder,
                    **sampling,
                )
                bar.update(mm_motions)
    rows = {"Ground Truth": summarize_runs(truth), f"Discrete diffusion + {decoder_name}": summarize_runs(runs)}
    counts = {"clips": len(clips), **({"multimodality texts": len(mm_clips)} if cfg.multimodality else {})}
    return _table(
        "t2m", dataset, profile, cfg, counts, T2M_METRICS if cfg.multimodality else T2M_METRICS[:-1], rows, device
    )
