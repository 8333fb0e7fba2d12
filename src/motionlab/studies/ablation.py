"""Chapter 04's projection ablation (DisCoRD Table 6, small): decoders that differ only in the condition projection,
measured on one fixed set of inputs with fixed seeds.

    windows of the train / val clips --tokenizer--> codes --decoder.loss, 8 draws of (x0, t) each--> FM loss per window
    held-out clips (whole tokens) --tokens--> decoded from seeded noise --> feature MSE, MPJPE (mm) per clip

Every decoder sees the same windows, the same noise and time draws and the same decode seeds, so two rows of the
table pair up sample by sample: :meth:`~motionlab.evaluation.EvaluationTable.paired` gives the interval of their
difference without the noise the rows share (:func:`paired_differences` tabulates it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch

from motionlab.estimate import Estimate, mean_ci
from motionlab.evaluation import EvaluationTable
from motionlab.flow.reconstruction import decode_clips, joints_of
from motionlab.flow.training import code_vectors
from motionlab.metrics import mpjpe
from motionlab.profiles import get_profile
from motionlab.train import WindowDataset

# What each row measures: flow-matching loss on train / held-out windows, then feature MSE (normalised units) and
# MPJPE (mm) of decoded held-out clips. These are the chapter's recorded measure names.
ABLATION_METRICS = ("train_fm", "heldout_fm", "heldout_mse", "heldout_mpjpe")
CLIP_METRICS = ("heldout_mse", "heldout_mpjpe")
LOSS_DRAWS = 8  # (x0, t) draws per window: one draw of a window's loss is mostly the noise of that draw
FEED_FORWARD = "feed-forward"  # the row of the tokenizer's own decoder (clip metrics only)
# Seed offsets of the fixed inputs: the same windows (+10) and noise (+11) for every decoder and both splits.
WINDOW_SEED, NOISE_SEED = 10, 11


def held_out_clips(dataset: Any, n_clips: int, q: int) -> list[np.ndarray]:
    """The first ``n_clips`` normalised validation clips, each cropped to whole tokens of ``q`` frames (what a
    decoder reconstructs, so the ground truth to compare with)."""
    for name, value in (("n_clips", n_clips), ("q", q)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{name} must be a positive int, got {value!r}")
    return [clip[: len(clip) // q * q] for clip in dataset.normalized("val")[:n_clips]]


def window_losses(
    decoder: Any,
    tokenizer: Any,
    clips: Sequence[np.ndarray],
    n_windows: int,
    *,
    draws: int = LOSS_DRAWS,
    seed: int = 0,
) -> np.ndarray:
    """The flow-matching loss of ``n_windows`` windows of ``clips``, each averaged over ``draws`` draws of
    ``(x0, t)``: ``(n_windows,)``.

    The windows (generator ``seed + 10``) and the draws (``seed + 11``) do not depend on the decoder, so the
    losses of two decoders pair up window by window.
    """
    if n_windows < 1 or draws < 1:
        raise ValueError(f"n_windows and draws must be >= 1, got {n_windows} and {draws}")
    motion = WindowDataset(clips, decoder.config.window).sample(
        n_windows, torch.Generator().manual_seed(seed + WINDOW_SEED)
    )  # (n, W, D)
    codes = code_vectors(tokenizer, motion)  # (n, W/q, d)
    noise = torch.Generator().manual_seed(seed + NOISE_SEED)
    device = next(decoder.parameters()).device
    with torch.no_grad():
        # one window at a time, repeated `draws` times: the loss's mean over the batch is that window's mean
        return np.array(
            [
                decoder.loss(
                    motion[i : i + 1].expand(draws, -1, -1).to(device),
                    codes[i : i + 1].expand(draws, -1, -1).to(device),
                    noise,
                ).item()
                for i in range(len(motion))
            ]
        )


def clip_errors(decoded: Sequence[np.ndarray], clips: Sequence[np.ndarray], normalizer: Any) -> dict[str, np.ndarray]:
    """Per-clip errors of decoded clips against their ground truth (both normalised, equal lengths):
    ``heldout_mse``, the feature MSE in normalised units, and ``heldout_mpjpe``, the MPJPE in mm of the joints
    recovered from the de-normalised features."""
    if len(decoded) != len(clips):
        raise ValueError(f"{len(decoded)} decoded clips for {len(clips)} ground-truth clips")
    for i, (r, c) in enumerate(zip(decoded, clips, strict=True)):
        if np.shape(r) != np.shape(c):
            raise ValueError(f"clip {i}: decoded {np.shape(r)} but ground truth {np.shape(c)}")
    pred = joints_of([normalizer.denormalize(r) for r in decoded])
    truth = joints_of([normalizer.denormalize(c) for c in clips])
    return {
        "heldout_mse": np.array([np.mean((r - c) ** 2) for r, c in zip(decoded, clips, strict=True)]),
        "heldout_mpjpe": np.array([1000 * mpjpe(p, g) for p, g in zip(pred, truth, strict=True)]),
    }


def projection_ablation(
    decoders: Mapping[str, Any],
    tokenizer: Any,
    dataset: Any,
    *,
    windows: int,
    clips: int,
    seed: int = 0,
    profile: str | None = None,
) -> EvaluationTable:
    """One row per decoder (``{name: decoder}``) and a :data:`FEED_FORWARD` row for the tokenizer's own decoder:
    :data:`ABLATION_METRICS`, each the mean ± 95% interval over ``windows`` windows or ``clips`` held-out clips.

    Each decoder decodes the held-out clips with decode seed ``seed`` (the same noise for all), and the table keeps
    every row's per-window and per-clip values (:attr:`~motionlab.evaluation.EvaluationTable.samples`), so
    ``table.paired("stacked", "repeat", "heldout_mse")`` is the paired difference.
    """
    if not decoders:
        raise ValueError("decoders is empty")
    configs = [d.config for d in decoders.values()]
    if len({(c.window, c.q) for c in configs}) != 1:
        raise ValueError("the decoders must share one window and token size to be measured on the same inputs")
    held_out = held_out_clips(dataset, clips, configs[0].q)
    train_clips, val_clips = dataset.normalized("train"), dataset.normalized("val")
    samples: dict[str, dict[str, list[float]]] = {}
    for name, decoder in decoders.items():
        errors = clip_errors(decode_clips(held_out, tokenizer, decoder, seed=seed), held_out, dataset.normalizer)
        samples[name] = {
            "train_fm": window_losses(decoder, tokenizer, train_clips, windows, seed=seed).tolist(),
            "heldout_fm": window_losses(decoder, tokenizer, val_clips, windows, seed=seed).tolist(),
            **{k: v.tolist() for k, v in errors.items()},
        }
    feed_forward = clip_errors(decode_clips(held_out, tokenizer), held_out, dataset.normalizer)
    samples[FEED_FORWARD] = {k: v.tolist() for k, v in feed_forward.items()}
    rows = {
        name: {m: mean_ci(values, unit="mm" if m == "heldout_mpjpe" else None) for m, values in cells.items()}
        for name, cells in samples.items()
    }
    base = configs[0]
    decoding = f"{base.sample_steps} {base.solver} steps"
    notes = [
        f"decoders: {base.train_steps} steps, width {base.width}, {len(held_out)} held-out clips, {decoding}",
        f"± over {windows} windows ({LOSS_DRAWS} draws of (x0, t) each) for the flow-matching losses, over "
        f"{len(held_out)} held-out clips for the decoded MSE and MPJPE; the same windows, draws and decode noise "
        f"for every decoder. {FEED_FORWARD}: the tokenizer's own decoder.",
    ]
    from motionlab.precision import network_precision

    device = next(next(iter(decoders.values())).parameters()).device
    return EvaluationTable(
        task="projection ablation",
        profile=get_profile(profile),
        data=dataset.key,
        split="val",
        repeats=1,
        seed=seed,
        config={"windows": windows, "clips": clips, "draws": LOSS_DRAWS, "train_steps": base.train_steps},
        counts={"windows": windows, "clips": len(held_out)},
        metrics=ABLATION_METRICS,
        rows=rows,
        notes=notes,
        precision=network_precision(device),
        samples=samples,
    )


def projection_claim_cells(labels: Mapping[str, str]) -> dict[str, tuple[str, str]]:
    """Which cells of the ablation table the claims read: ``{"heldout_mse_repeat_linear": ("repeat", "heldout_mse"),
    ...}``, one per decoder row and metric, named ``<metric>_<label>`` with ``labels`` mapping a row to its claim name
    (``{"stacked": "stacked", "repeat": "repeat_linear", "transposed": "transposed"}``, chapter 04's)."""
    return {f"{metric}_{label}": (row, metric) for row, label in labels.items() for metric in ABLATION_METRICS}


def paired_differences(
    table: EvaluationTable, row: str, others: Sequence[str], metrics: Sequence[str] | None = None
) -> EvaluationTable:
    """``row − other`` for each of ``others``, paired sample by sample (:meth:`EvaluationTable.paired`), as a
    table with one row per difference; negative means ``row`` is lower."""
    metrics = tuple(table.metrics if metrics is None else metrics)
    rows: dict[str, dict[str, Estimate]] = {
        f"{row} − {other}": {m: table.paired(row, other, m) for m in metrics} for other in others
    }
    note = f"paired differences (same windows, same clips, same noise): {row} minus each alternative"
    return EvaluationTable(
        task=f"{table.task}, paired",
        profile=table.profile,
        data=table.data,
        split=table.split,
        repeats=table.repeats,
        seed=table.seed,
        config=dict(table.config),
        counts=dict(table.counts),
        metrics=metrics,
        rows=rows,
        notes=[note],
        precision=table.precision,
    )


__all__ = [
    "ABLATION_METRICS",
    "CLIP_METRICS",
    "FEED_FORWARD",
    "LOSS_DRAWS",
    "clip_errors",
    "held_out_clips",
    "paired_differences",
    "projection_ablation",
    "projection_claim_cells",
    "window_losses",
]
