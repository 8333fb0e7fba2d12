"""The reconstruction setting of DisCoRD's Table 1: ground truth → tokens → decoded motion → compared with it.

    GT clip (T, D) normalised --crop to whole tokens, tokenizer.encode--> ids (T/q, R)
        --decoder--> recon (T, D)   feed-forward: tokenizer.decode(ids); DisCoRD: ODE from seeded noise
    both de-normalised --recover_from_ric--> joints --> MPJPE (mm), sJPE (Noise + Static); embeddings --> FID

The tokens are the same for both decoders, so every difference in the scores is the decoder's.
Clips of equal (cropped) length are decoded together in one batch: both decoders are convolutional, so a
clip is never padded and its result does not depend on which other clips share its batch's length,
except for the noise a DisCoRD batch draws (batch ``k`` uses ``seed + k``: a seed fixes every decode).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import torch

from motionlab.metrics import ClipJoints, fid, mpjpe_per_clip, sjpe_variants
from motionlab.representation import get_skeleton

SKELETON_OF_DIM = {263: "t2m", 251: "kit"}


def _check_clips(clips: Sequence[Any], feature_dim: int, q: int, name: str = "clips") -> list[np.ndarray]:
    if isinstance(clips, np.ndarray) and clips.ndim == 2:
        raise ValueError(f"{name} must be a list of (T, D) arrays, not one (T, D) clip")
    if len(clips) == 0:
        raise ValueError(f"{name} is empty")
    out = []
    for i, clip in enumerate(clips):
        a = np.asarray(clip.detach().cpu() if isinstance(clip, torch.Tensor) else clip, dtype=np.float32)
        if a.ndim != 2 or a.shape[1] != feature_dim or a.shape[0] < q:
            raise ValueError(f"{name}[{i}] must have shape (T >= {q}, {feature_dim}), got {a.shape}")
        out.append(a[: a.shape[0] // q * q])  # whole tokens only
    return out


def length_batches(lengths: Sequence[int], batch_size: int) -> list[np.ndarray]:
    """Indices grouped by equal length, in order of length, each group cut into batches of ``batch_size``."""
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    lengths = np.asarray(lengths)
    batches = []
    for value in np.unique(lengths):
        idx = np.flatnonzero(lengths == value)
        batches.extend(idx[s : s + batch_size] for s in range(0, len(idx), batch_size))
    return batches


@torch.no_grad()
def decode_clips(
    clips: Sequence[np.ndarray],
    tokenizer: Any,
    decoder: Any = None,
    *,
    steps: int | None = None,
    solver: str | None = None,
    seed: int = 0,
    batch_size: int = 64,
    pad_to: int | None = None,
) -> list[np.ndarray]:
    """Reconstruct normalised clips ``(T_i, D)`` through the tokenizer's tokens; returns ``(T_i', D)`` arrays.

    ``T_i'`` is ``T_i`` floored to whole tokens (the ground truth to compare with is ``clip[:T_i']``).
    ``decoder=None`` uses the tokenizer's feed-forward decoder; a :class:`~motionlab.flow.DisCoRDDecoder`
    decodes the same ids with ``steps`` intervals of ``solver`` (its config's defaults if ``None``).
    ``pad_to`` (e.g. the official evaluation's 196) appends zero frames (the normalised mean pose) to every clip
    before it is tokenised, as the released evaluation scripts do, and crops the decoded motion back to ``T_i'``.
    """
    q = int(tokenizer.downsample)
    crops = _check_clips(clips, int(tokenizer.feature_dim), q)
    lengths = [len(c) for c in crops]
    if pad_to is not None:
        if pad_to % q or pad_to < max(lengths):
            raise ValueError(f"pad_to={pad_to} must be a multiple of {q} and at least the longest clip, {max(lengths)}")
        crops = [np.concatenate([c, np.zeros((pad_to - len(c), c.shape[1]), c.dtype)]) for c in crops]
    out: list[np.ndarray | None] = [None] * len(crops)
    for k, idx in enumerate(length_batches([len(c) for c in crops], batch_size)):
        motion = torch.as_tensor(np.stack([crops[i] for i in idx]))  # (B, T, D)
        ids = tokenizer.encode(motion)  # (B, T/q[, R])
        if decoder is None:
            recon = tokenizer.decode(ids)
        else:
            recon = decoder.decode(ids, tokenizer=tokenizer, steps=steps, solver=solver, seed=seed + k)
        recon = recon.float().cpu().numpy()  # (B, T, D)
        for j, i in enumerate(idx):
            out[i] = recon[j, : lengths[i]]
    return out  # type: ignore[return-value]


# ----------------------------------------------------------------------------- scores


@dataclass(frozen=True)
class ReconstructionScores:
    """Table 1's columns for one decoder: FID, MPJPE (mm) and sJPE with its two parts."""

    fid: float
    mpjpe_mm: float
    sjpe: float  # the element variant (per-element ε, in [0, 4] for t2m): motionlab's headline
    noise_sjpe: float
    static_sjpe: float
    sjpe_ratio: float  # the ratio-of-sums variant, in [0, 1]: the scale of the paper's tables
    noise_sjpe_ratio: float
    static_sjpe_ratio: float
    joint_jerk: float  # mean jerk magnitude of the sJPE joints (m/s³), to set beside the ground truth's
    # Each clip's value of the metrics that are means over clips (sJPE and its parts) or over frames (MPJPE, weighted
    # by the clips' lengths), in clip order: what a paired bootstrap over the test clips resamples.
    per_clip: dict[str, np.ndarray] = field(default_factory=dict, compare=False, repr=False)

    def as_dict(self) -> dict[str, float]:
        """The table's columns (the per-clip values left out)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "per_clip"}


def joints_of(features: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Raw (de-normalised) features ``(T, D)`` → joint positions ``(T, J, 3)`` in the skeleton's unit."""
    return _clip_joints(features).clips()


def _clip_joints(features: Sequence[np.ndarray]) -> ClipJoints:
    dim = int(np.asarray(features[0]).shape[-1])
    if dim not in SKELETON_OF_DIM:
        raise ValueError(f"features must have {sorted(SKELETON_OF_DIM)} dims (t2m / kit), got {dim}")
    return ClipJoints.from_features(list(features))


def _check_reconstruction_scores_inputs(pred_features: Sequence[np.ndarray], gt_features: Sequence[np.ndarray]) -> None:
    """Reject unequal or empty clip lists and prediction / ground-truth pairs of different shapes."""
    if len(pred_features) != len(gt_features) or len(pred_features) == 0:
        raise ValueError(f"need equal, non-zero numbers of clips, got {len(pred_features)} and {len(gt_features)}")
    for i, (p, g) in enumerate(zip(pred_features, gt_features)):
        if np.shape(p) != np.shape(g):
            raise ValueError(f"clip {i}: prediction {np.shape(p)} and ground truth {np.shape(g)} differ in shape")


def reconstruction_scores(
    pred_features: Sequence[np.ndarray],
    gt_features: Sequence[np.ndarray],
    embed: Callable[[list[np.ndarray]], np.ndarray] | None = None,
    gt_embeddings: np.ndarray | None = None,
    gt_joints: ClipJoints | None = None,
    pred_joints: ClipJoints | None = None,
) -> ReconstructionScores:
    """Score reconstructions against their ground truth; both are lists of raw ``(T_i, D)`` features.

    ``embed`` (e.g. an evaluator's ``embed_motions``) maps raw clips to ``(N, d)`` embeddings for FID;
    pass ``gt_embeddings`` to reuse the ground truth's, and ``gt_joints`` (``ClipJoints.from_features(gt)``)
    and ``pred_joints`` (likewise) to reuse joints already recovered. Without ``embed`` the FID is NaN. MPJPE pools
    every pose (pelvis-aligned, millimetres); sJPE is the mean over clips, in both of the public code's variants
    (element, and ratio: the paper's [0, 1] scale). Joints are recovered once per clip set, on real frames only.
    """
    _check_reconstruction_scores_inputs(pred_features, gt_features)
    skeleton = SKELETON_OF_DIM.get(int(np.shape(gt_features[0])[-1]), "t2m")
    pred_joints = _clip_joints(pred_features) if pred_joints is None else pred_joints
    gt_joints = _clip_joints(gt_features) if gt_joints is None else gt_joints
    if not np.array_equal(gt_joints.lengths, pred_joints.lengths):
        raise ValueError("gt_joints and pred_joints are not the joints of the clips: their clip lengths differ")
    to_mm = 1000.0 * get_skeleton(skeleton).meters_per_unit
    scored = sjpe_variants(pred_joints, gt_joints, skeleton)  # jerks computed once, both variants scored
    jerk, ratio = scored["element"], scored["ratio"]
    if embed is None:
        distance = float("nan")
    else:
        reference = gt_embeddings if gt_embeddings is not None else embed(list(gt_features))
        distance = fid(reference, embed(list(pred_features)))
    mean_jerk = float(np.mean(jerk.jerk_pred_per_clip))
    mpjpe_clips = to_mm * mpjpe_per_clip(pred_joints, gt_joints)  # (N,), pooled over poses below
    per_clip = {
        "mpjpe_mm": mpjpe_clips,
        "sjpe": jerk.sjpe_per_clip,
        "noise_sjpe": jerk.noise_per_clip,
        "static_sjpe": jerk.static_per_clip,
    }
    return ReconstructionScores(
        distance,
        float(np.average(mpjpe_clips, weights=gt_joints.lengths)),
        jerk.sjpe,
        jerk.noise,
        jerk.static,
        ratio.sjpe,
        ratio.noise,
        ratio.static,
        mean_jerk,
        per_clip,
    )


# ----------------------------------------------------------------------------- one split, as joints


# ----------------------------------------------------------------------------- timing


def timing_batch(clips: Sequence[np.ndarray], tokenizer: Any, size: int = 32) -> torch.Tensor:
    """Table E's timing input: the token ids ``(B, N[, R])`` of the ``size`` longest normalised clips (all of them if
    fewer), each cropped to the shortest of those, in whole tokens, so that they form one batch."""
    q = int(tokenizer.downsample)
    crops = _check_clips(clips, int(tokenizer.feature_dim), q)
    if size < 1:
        raise ValueError(f"size must be >= 1, got {size}")
    longest = np.argsort([len(c) for c in crops], kind="stable")[-size:]
    frames = min(len(crops[i]) for i in longest)
    with torch.no_grad():
        return tokenizer.encode(torch.as_tensor(np.stack([crops[i][:frames] for i in longest])))


def time_calls(fn: Callable[[], Any], repeats: int = 5, warmup: int = 1) -> np.ndarray:
    """Wall-clock seconds of ``repeats`` calls of ``fn()`` after ``warmup`` untimed calls: ``(repeats,)``."""
    if repeats < 1 or warmup < 0:
        raise ValueError(f"need repeats >= 1 and warmup >= 0, got {repeats}, {warmup}")
    for _ in range(warmup):
        fn()
    seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        seconds.append(time.perf_counter() - start)
    return np.array(seconds)


def count_flops(fn: Callable[[], Any]) -> int:
    """Floating-point operations of one call of ``fn()`` (matrix products and convolutions, as PyTorch's
    ``FlopCounterMode`` counts them; element-wise work is left out). Time on a busy CPU follows this number; on a
    GPU, small decoders are bound by kernel-launch latency instead, so two decoders with very different FLOPs can
    take about the same time there."""
    from torch.utils.flop_counter import FlopCounterMode

    counter = FlopCounterMode(display=False)
    with counter, torch.no_grad():
        fn()
    return int(counter.get_total_flops())


@dataclass(frozen=True)
class DecodeCost:
    """What decoding one clip of ``frames`` frames costs, counted: the feed-forward decoder's FLOPs, one DisCoRD
    network call's and the calls a decode makes, and the rate (GFLOP per CPU-second, all threads together) that one
    such call ran at on this machine."""

    frames: int
    feed_forward_gflop: float
    discord_call_gflop: float | None
    discord_calls: int | None
    gflop_per_cpu_second: float

    @property
    def discord_gflop(self) -> float | None:
        """One whole DisCoRD decode: a network call's FLOPs times the calls (the condition projection counted with
        each call, a slight over-count)."""
        return None if self.discord_call_gflop is None else self.discord_call_gflop * self.discord_calls

    def total_gflop(self, clips: int, discord_decodes: int = 1) -> float:
        """The feed-forward decode of ``clips`` clips plus ``discord_decodes`` DisCoRD decodes of each."""
        return clips * (self.feed_forward_gflop + discord_decodes * (self.discord_gflop or 0.0))

    def cpu_hours(self, clips: int, discord_decodes: int = 1) -> float:
        """:meth:`total_gflop` at this machine's measured rate."""
        return self.total_gflop(clips, discord_decodes) / self.gflop_per_cpu_second / 3600


@torch.no_grad()
def decode_cost(tokenizer: Any, decoder: Any = None, frames: int = 196, steps=None, solver=None) -> DecodeCost:
    """Count the FLOPs (:func:`count_flops`) of decoding one ``frames``-frame clip with ``tokenizer``'s feed-forward
    decoder and with ``decoder`` (a DisCoRD decoder: one network call, times the calls of ``steps`` intervals of
    ``solver``, its config's by default), and time one call's CPU seconds here (after one untimed)."""
    from motionlab.flow.rectified_flow import n_evaluations

    q = int(tokenizer.downsample)
    if frames < q or frames % q:
        raise ValueError(f"frames must be a positive multiple of {q}, got {frames}")
    device = next(tokenizer.parameters()).device
    ids = tokenizer.encode(torch.zeros(1, frames, int(tokenizer.feature_dim), device=device))  # (1, N[, R])
    call = lambda: tokenizer.decode(ids)  # noqa: E731
    feed_forward = call_flops = count_flops(call)
    per_call = calls = None
    if decoder is not None:
        config = decoder.config
        calls = n_evaluations(
            config.sample_steps if steps is None else steps, config.solver if solver is None else solver
        )
        call = lambda: decoder.decode(ids, tokenizer=tokenizer, steps=1, solver="euler", seed=0)  # noqa: E731
        per_call = call_flops = count_flops(call)
    call()  # warm
    start = time.process_time()
    call()
    seconds = max(time.process_time() - start, 1e-6)
    return DecodeCost(
        frames, feed_forward / 1e9, None if per_call is None else per_call / 1e9, calls, call_flops / 1e9 / seconds
    )


__all__ = [
    "DecodeCost",
    "decode_cost",
    "ReconstructionScores",
    "count_flops",
    "decode_clips",
    "joints_of",
    "length_batches",
    "reconstruction_scores",
    "time_calls",
    "timing_batch",
]
