"""Chapter 05's reconstruction study: the clips behind Table 1 as joints, the typical clip a figure shows, and what
decoding a whole test split costs.

The decoding and the costs are :mod:`motionlab.flow.reconstruction`'s
(:func:`~motionlab.flow.reconstruction.decode_clips`, :func:`~motionlab.flow.reconstruction.decode_cost`); Table 1
itself is :func:`motionlab.evaluation.evaluate_reconstruction`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from motionlab.flow.reconstruction import DecodeCost, decode_clips, joints_of
from motionlab.metrics import sjpe_dataset
from motionlab.viz.tables import Table


def _split_crops(dataset: Any, q: int, split: str, limit: int | None, clips: Sequence[int] | None) -> list[np.ndarray]:
    """The raw features of the first ``limit`` clips of ``split`` (then only the indices ``clips``), whole tokens."""
    chosen = list(dataset.split(split))[:limit]
    if clips is not None:
        chosen = [chosen[int(i)] for i in clips]
    if not chosen:
        raise ValueError(f"no clips chosen from the {split} split")
    return [c.features[: len(c.features) // q * q] for c in chosen]


def ground_truth_joints(
    dataset: Any, tokenizer: Any, *, split: str = "test", limit: int | None = None, clips: Sequence[int] | None = None
) -> list[np.ndarray]:
    """Joints ``(T_i, J, 3)`` of the ground truth that :func:`reconstructed_joints` compares with: the first ``limit``
    clips of ``split`` (or the indices ``clips`` among them), cropped to the tokenizer's whole tokens."""
    return joints_of(_split_crops(dataset, int(tokenizer.downsample), split, limit, clips))


def reconstructed_joints(
    dataset: Any,
    tokenizer: Any,
    decoder: Any = None,
    *,
    split: str = "test",
    limit: int | None = None,
    clips: Sequence[int] | None = None,
    steps: int | None = None,
    solver: str | None = None,
    seed: int = 0,
) -> list[np.ndarray]:
    """The same clips as :func:`ground_truth_joints`, through the tokens and back (:func:`decode_clips`, the
    feed-forward decoder if ``decoder`` is None), de-normalised, as joints ``(T_i, J, 3)``.

    With ``seed=repeat_seed(seed, 0)`` and the same ``limit`` these are the motions behind the first repeat of
    :func:`motionlab.evaluation.evaluate_reconstruction`'s DisCoRD row (a batch's noise depends on which clips share it,
    so ``clips`` decodes other noise than the whole split)."""
    normalizer = dataset.normalizer
    crops = _split_crops(dataset, int(tokenizer.downsample), split, limit, clips)
    normalized = [normalizer.normalize(c) for c in crops]
    recon = decode_clips(normalized, tokenizer, decoder, steps=steps, solver=solver, seed=seed)
    return joints_of([normalizer.denormalize(r) for r in recon])


def median_example(
    joints_a: Sequence[np.ndarray], joints_b: Sequence[np.ndarray], gt: Sequence[np.ndarray], min_frames: int = 100
) -> int:
    """The clip a figure shows, chosen by a rule rather than by eye: among clips of at least ``min_frames`` frames
    (all clips if none is that long), the one whose sJPE gain ``sJPE(a) − sJPE(b)`` is the median, a typical clip
    rather than the best one. The arguments are joints ``(T_i, J, 3)``, clip by clip."""
    if not (len(joints_a) == len(joints_b) == len(gt)) or not len(gt):
        raise ValueError(f"need as many clips of each, got {len(joints_a)}, {len(joints_b)} and {len(gt)}")
    gain = sjpe_dataset(list(joints_a), list(gt)).sjpe_per_clip - sjpe_dataset(list(joints_b), list(gt)).sjpe_per_clip
    long_enough = np.flatnonzero([len(g) >= min_frames for g in gt])
    candidates = long_enough if long_enough.size else np.arange(len(gt))
    return int(candidates[np.argsort(gain[candidates], kind="stable")[len(candidates) // 2]])


def cost_table(cost: DecodeCost, clips: int, discord_decodes: int, gpu_tflops: float = 50.0) -> Table:
    """``cost`` (:func:`~motionlab.flow.reconstruction.decode_cost`) per decoder: GFLOP per clip, its ratio to the
    feed-forward decoder, the CPU-hours of ``clips`` clips decoded ``discord_decodes`` times (once for the deterministic
    feed-forward decoder) at this machine's rate, and the GPU minutes at a sustained ``gpu_tflops`` (an assumption, not
    a measurement)."""

    def row(gflop: float, decodes: int) -> dict[str, float]:
        total = clips * decodes * gflop
        return {
            "GFLOP per clip": gflop,
            "× feed-forward": gflop / cost.feed_forward_gflop,
            "CPU-hours here": total / cost.gflop_per_cpu_second / 3600,
            f"GPU minutes at {gpu_tflops:g} TFLOP/s": total / (gpu_tflops * 1e3) / 60,
        }

    rows = {"feed-forward decoder (one run)": row(cost.feed_forward_gflop, 1)}
    if cost.discord_gflop is not None:
        rows[f"DisCoRD, {cost.discord_calls} network calls ({discord_decodes} runs)"] = row(
            cost.discord_gflop, discord_decodes
        )
    note = (
        f"{clips:,} clips of {cost.frames} frames; CPU time at the {cost.gflop_per_cpu_second:.0f} GFLOP per "
        "CPU-second one network call ran at on this machine, in its precision."
    )
    return Table("decoder", rows, notes=(note,), formats={"× feed-forward": ".0f"})


__all__ = ["cost_table", "ground_truth_joints", "median_example", "reconstructed_joints"]
