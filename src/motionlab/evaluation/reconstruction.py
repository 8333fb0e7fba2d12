"""DisCoRD Table 1: test clips → tokens → decoded by the feed-forward decoder and by DisCoRD, scored."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motionlab.estimate import summarize_runs
from motionlab.profiles import get_profile

from .common import (
    FLOW_OPTIONS,
    FLOW_SAMPLING_OPTIONS,
    FLOW_TRAINING_OPTIONS,
    _bar,
    _check_common,
    _check_flow_options,
    _config,
    _flow_label,
    _flow_options_label,
    _once,
    _phase,
    _split_clips,
    _table,
    repeat_seed,
)
from .table import RECONSTRUCTION_METRICS, EvaluationTable


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
            raise ValueError(
                f"decoder={self.decoder!r} is that tokenizer's own decoder; tokenizer= chooses the "
                "tokens of decoder='discord' only"
            )
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, 2, " (FID needs two clips)")

    @property
    def tokenizer_kind(self) -> str:
        return self.decoder if self.decoder != "discord" else (self.tokenizer or "rvq")


# ----------------------------------------------------------------------------------------------- the tasks


def evaluate_reconstruction(
    dataset,
    config: ReconstructionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
) -> EvaluationTable:
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
    _phase(
        f"reconstruction: {len(clips)} {cfg.split} clips; loading (or training) the {kind} tokenizer and the evaluator"
    )
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
        flow = train_or_load_discord(dataset, tokenizer, profile, config=flow_config, device=device, progress=progress)
        sampling = {k: v for k, v in chosen.items() if k in FLOW_SAMPLING_OPTIONS}
        flow = flow.with_sampling(**sampling) if sampling else flow
        seeded = not flow.deterministic  # at temperature 0 every seed decodes the same motion
        repeats = cfg.repeats if seeded else 1
        runs = []
        with _bar(repeats, "DisCoRD repeats", progress) as bar:
            for r in range(repeats):
                _phase(f"DisCoRD repeat {r + 1} of {repeats}")
                recon = decode_clips(
                    normalized, tokenizer, flow, steps=cfg.steps, solver=cfg.solver, seed=repeat_seed(cfg.seed, r)
                )
                runs.append(score(recon))
                bar.update()
        flow_row = f"{name} tokens + DisCoRD ({_flow_label(flow, cfg.steps, cfg.solver)}{_flow_options_label(flow)})"
        rows[flow_row] = summarize_runs(runs) if seeded else _once(runs[0])
        if seeded:
            notes.append(f"DisCoRD: {cfg.repeats} sampling seeds.")
        else:
            notes.append("DisCoRD at temperature 0 decodes every seed to the same motion: one run, no interval.")
            deterministic.append(flow_row)
    return _table(
        "reconstruction",
        dataset,
        profile,
        cfg,
        {"clips": len(clips)},
        RECONSTRUCTION_METRICS,
        rows,
        device,
        deterministic=tuple(deterministic),
        notes=[" ".join(notes)],
    )
