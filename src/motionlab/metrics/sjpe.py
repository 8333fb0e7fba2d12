"""sJPE, DisCoRD's symmetric Jerk Percentage Error, exactly as its public evaluation computes it.

For one clip, select a few end-effector joints, take the jerk of each (plain third difference times
fps^3, see :mod:`motionlab.metrics.jerk`) and its L2 norm over xyz, ``J[t, j]`` with ``t = 0 .. T-4``.
Then, per element (``variant="element"``, the one with the epsilon, likely the paper's)::

    noise  = sum_{t,j} max(0, Jp - Jg) / (|Jp| + |Jg| + 1e-6) / (T - 3)
    static = sum_{t,j} max(0, Jg - Jp) / (|Jp| + |Jg| + 1e-6) / (T - 3)
    sJPE   = noise + static

The sum runs over time *and joints* but is divided only by the number of jerk frames ``T - 3``: a clip
scores between 0 and the number of selected joints (4 for t2m, 2 for KIT), not between 0 and 1.
"Noise" is jerk the prediction has and the ground truth lacks (frame-wise jitter); "Static" is jerk the
prediction misses (under-reconstructed, too-smooth motion). Both elements of a pair that are zero add 0.

``variant="ratio"`` is the evaluation's second print-out, a ratio of sums without epsilon::

    noise = sum max(0, Jp - Jg) / sum (Jp + Jg),   static likewise,  in [0, 1]; NaN if both sums are 0.

Settings per skeleton: t2m uses joints 10, 11 (feet) and 20, 21 (wrists) at 20 fps in metres; KIT uses
joints 7 and 10 (the wrist ends of the arms) at 12.5 fps, with positions given in millimetres and divided
by 1000. The dataset score is the mean of the per-clip scores.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from ..representation import get_skeleton
from ._checks import check_joints
from .jerk import finite_difference_jerk, squared_length
from .joints import ClipJoints

SJPE_JOINTS = {"t2m": (10, 11, 20, 21), "kit": (7, 10)}
VARIANTS = ("element", "ratio")
EPS = 1e-6


@dataclass(frozen=True)
class SJPESetting:
    """Which joints, at which frame rate, scaled to metres by which factor."""

    joints: tuple[int, ...]
    fps: float
    to_metres: float
    n_joints: int  # joints of the full skeleton the input must have


def sjpe_setting(skeleton: str = "t2m") -> SJPESetting:
    if skeleton not in SJPE_JOINTS:
        raise ValueError(f"skeleton must be one of {tuple(SJPE_JOINTS)}, got {skeleton!r}")
    sk = get_skeleton(skeleton)
    return SJPESetting(SJPE_JOINTS[skeleton], float(sk.fps), sk.meters_per_unit, sk.n_joints)


@dataclass
class SJPEResult:
    """Per-clip sJPE values ``(N,)`` and their dataset means."""

    noise_per_clip: np.ndarray
    static_per_clip: np.ndarray
    jerk_pred_per_clip: np.ndarray  # mean jerk magnitude (m/s^3) over time and selected joints
    jerk_gt_per_clip: np.ndarray

    @property
    def sjpe_per_clip(self) -> np.ndarray:
        return self.noise_per_clip + self.static_per_clip

    @property
    def noise(self) -> float:
        return float(np.mean(self.noise_per_clip))

    @property
    def static(self) -> float:
        return float(np.mean(self.static_per_clip))

    @property
    def sjpe(self) -> float:
        return float(np.mean(self.sjpe_per_clip))

    def as_dict(self) -> dict[str, float]:
        """Dataset means (NaN clips of the ratio variant propagate, as in the reference's sum)."""
        return {"sjpe": self.sjpe, "noise": self.noise, "static": self.static}


def _jerk_magnitudes(packed: np.ndarray, lengths: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """``|jerk|`` of packed clips ``(F, n_sel, 3)`` (clip after clip, ``lengths`` frames each):
    ``(sum_i (T_i - 3), n_sel)`` and each row's clip id.

    The packed array is differenced once; rows whose 4-frame stencil crosses from one clip into the next
    are dropped, so nothing of a neighbour (or of padding) leaks into a clip's score.
    """
    jerk = np.sqrt(squared_length(finite_difference_jerk(packed, fps, axis=0)))  # (F - 3, n_sel)
    starts = np.cumsum(lengths) - lengths
    n_rows = lengths - 3
    clip_id = np.repeat(np.arange(len(lengths)), n_rows)
    offset_in_clip = np.arange(n_rows.sum()) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows)
    rows = np.repeat(starts, n_rows) + offset_in_clip
    return jerk[rows], clip_id


def _row_sums(values: np.ndarray) -> np.ndarray:
    """``values.sum(axis=1)`` of ``(R, n)`` for a handful of columns, added in the same order, without numpy's
    slow reduction over a short axis."""
    out = values[:, 0].copy()
    for k in range(1, values.shape[1]):
        out += values[:, k]
    return out


def sjpe_elements(jerk_pred: np.ndarray, jerk_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sJPE's two halves, element by element: ``(noise, static)`` for jerk magnitudes of any (equal) shape.

    A clip's Noise sJPE is the sum of ``noise`` over its jerk frames and joints divided by the number of jerk
    frames ``T − 3``; Static sJPE likewise. Each element lies in ``[0, 1)``, and at most one of the two is non-zero.
    """
    total = jerk_pred + jerk_true + EPS  # EPS keeps 0 / 0 at 0 where neither has jerk
    noise = np.maximum(jerk_pred - jerk_true, 0.0) / total  # jerk the prediction adds: jitter
    static = np.maximum(jerk_true - jerk_pred, 0.0) / total  # jerk the prediction misses: over-smoothing
    return noise, static


def _score(jp: np.ndarray, jg: np.ndarray, clip_id: np.ndarray, n_clips: int, variant: str):
    """Per-clip (noise, static) from jerk magnitudes ``(R, n)`` (non-negative) grouped by ``clip_id``."""

    def per_clip(values: np.ndarray) -> np.ndarray:  # (R, n) -> (n_clips,), summed over joints and time
        return np.bincount(clip_id, weights=_row_sums(values), minlength=n_clips)

    if variant == "element":
        noise, static = sjpe_elements(jp, jg)  # (R, n) each
        n_frames = np.bincount(clip_id, minlength=n_clips)  # T_i - 3
        return per_clip(noise) / n_frames, per_clip(static) / n_frames
    over = np.maximum(jp - jg, 0.0)  # (R, n): jerk the prediction adds
    under = np.maximum(jg - jp, 0.0)  # (R, n): jerk the prediction misses
    total = per_clip(jp + jg)
    with np.errstate(divide="ignore", invalid="ignore"):
        return per_clip(over) / total, per_clip(under) / total


def _numpy(x) -> np.ndarray:
    return x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else np.asarray(x)


def _clip_joints(clips, lengths, name: str, setting: SJPESetting) -> ClipJoints:
    """``clips`` -- a :class:`ClipJoints`, a list of ``(T_i, J, 3)``, or a padded ``(N, T, J, 3)`` array with
    ``lengths`` -- validated and packed. Padding is never read, not even to check it is finite."""
    if isinstance(clips, ClipJoints):
        if lengths is not None:
            raise ValueError(f"lengths is not used with a ClipJoints {name}: it carries its own")
        joints = clips
    else:
        padded = isinstance(clips, (np.ndarray, torch.Tensor)) and clips.ndim == 4
        if padded and lengths is not None:
            if len(lengths) != clips.shape[0]:
                raise ValueError(f"lengths has {len(lengths)} entries but {name} holds {clips.shape[0]} clips")
            if any(int(n) > clips.shape[1] for n in lengths):
                raise ValueError(f"a length exceeds the padded time axis ({clips.shape[1]}) of {name}")
        elif lengths is not None:
            raise ValueError(f"lengths is only used with a padded (N, T, J, 3) array for {name}")
        if not padded:
            clips = list(clips)
            if len(clips) == 0:
                raise ValueError(f"{name} is empty")
            for i, clip in enumerate(clips):
                shape = np.shape(clip)
                if len(shape) != 3 or shape[1:] != (setting.n_joints, 3):
                    raise ValueError(f"{name}[{i}] must have shape (T, {setting.n_joints}, 3), got {shape}")
                if shape[0] < 4:
                    raise ValueError(f"{name}[{i}] needs at least 4 frames (a third difference), got {shape[0]}")
        try:
            joints = ClipJoints.from_joints(clips, lengths)
        except ValueError as err:
            raise ValueError(f"{name}: {err}") from None
    if joints.n_joints != setting.n_joints:
        raise ValueError(f"{name} must have shape (T, {setting.n_joints}, 3), got {joints.n_joints} joints")
    short = np.flatnonzero(joints.lengths < 4)
    if len(short):
        raise ValueError(
            f"{name}[{short[0]}] needs at least 4 frames (a third difference), got {joints.lengths[short[0]]}"
        )
    return joints


def _select(positions: np.ndarray, setting: SJPESetting) -> np.ndarray:
    """The selected joints of packed positions ``(F, J, 3)``, in metres: ``(F, n_sel, 3)``."""
    columns = (3 * np.array(setting.joints)[:, None] + np.arange(3)).ravel()  # x, y, z of each selected joint
    selected = positions.reshape(len(positions), -1)[:, columns].reshape(-1, len(setting.joints), 3)
    return selected * setting.to_metres if setting.to_metres != 1.0 else selected


_BLOCK_FRAMES = 16384  # clips are scored a block of about this many frames at a time: the temporaries stay in cache


def _blocks(lengths: np.ndarray) -> list[tuple[int, int]]:
    """Consecutive clip ranges ``[a, b)`` of about ``_BLOCK_FRAMES`` frames each (at least one clip)."""
    ends = np.cumsum(lengths)
    out, a = [], 0
    while a < len(lengths):
        start = ends[a] - lengths[a]
        b = max(a + 1, int(np.searchsorted(ends, start + _BLOCK_FRAMES, side="right")))
        out.append((a, b))
        a = b
    return out


def sjpe_dataset(
    pred_clips, gt_clips, skeleton: str = "t2m", variant: str = "element", lengths: Sequence[int] | None = None
) -> SJPEResult:
    """sJPE over many clips of possibly different lengths.

    ``pred_clips``/``gt_clips``: lists of ``(T_i, J, 3)`` joint positions (all joints of the skeleton;
    metres for t2m, millimetres for KIT), padded ``(N, T, J, 3)`` arrays with ``lengths`` -- frames
    past ``lengths[i]`` are never read -- or :class:`ClipJoints` (recovered once, shared with other metrics;
    the fastest). Pair ``i`` must have equal lengths.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    return sjpe_variants(pred_clips, gt_clips, skeleton, (variant,), lengths)[variant]


def sjpe_variants(
    pred_clips,
    gt_clips,
    skeleton: str = "t2m",
    variants: Sequence[str] = VARIANTS,
    lengths: Sequence[int] | None = None,
) -> dict[str, SJPEResult]:
    """:func:`sjpe_dataset` for several ``variants`` at once: the jerks are computed once and scored per variant."""
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise ValueError(f"variants must be among {VARIANTS}, got {unknown}")
    setting = sjpe_setting(skeleton)
    pred = _clip_joints(pred_clips, lengths, "pred_clips", setting)
    gt = _clip_joints(gt_clips, lengths, "gt_clips", setting)
    if len(pred) != len(gt):
        raise ValueError(f"pred_clips has {len(pred)} clips but gt_clips has {len(gt)}")
    differ = np.flatnonzero(pred.lengths != gt.lengths)
    if len(differ):
        i = int(differ[0])
        raise ValueError(f"clip {i}: prediction has {pred.lengths[i]} frames but ground truth has {gt.lengths[i]}")
    # Clips are independent: score them a block at a time (whole clips per block, so every value is the
    # same as in one pass), which keeps the jerk arrays of a block in cache.
    parts: dict[str, list] = {v: [] for v in variants}
    means: list[tuple[np.ndarray, np.ndarray]] = []
    starts = pred.starts
    for a, b in _blocks(pred.lengths):
        rows = slice(int(starts[a]), int(starts[b - 1] + pred.lengths[b - 1]))
        n = pred.lengths[a:b]
        jp, clip_id = _jerk_magnitudes(_select(pred.positions[rows], setting), n, setting.fps)
        jg, _ = _jerk_magnitudes(_select(gt.positions[rows], setting), n, setting.fps)
        n_cells = np.bincount(clip_id, minlength=b - a) * len(setting.joints)
        means.append(
            (
                np.bincount(clip_id, weights=_row_sums(jp), minlength=b - a) / n_cells,
                np.bincount(clip_id, weights=_row_sums(jg), minlength=b - a) / n_cells,
            )
        )
        for v in variants:
            parts[v].append(_score(jp, jg, clip_id, b - a, v))
    mean_p, mean_g = (np.concatenate(m) for m in zip(*means))
    return {v: SJPEResult(*(np.concatenate(x) for x in zip(*parts[v])), mean_p, mean_g) for v in variants}


def sjpe_jerk_magnitudes(clips, skeleton: str = "t2m") -> np.ndarray:
    """Every jerk magnitude sJPE compares, ``(sum_i (T_i - 3), n_selected)`` in m/s³, for a list of ``(T_i, J, 3)``
    joint clips (all joints; metres for t2m, millimetres for KIT) or a :class:`ClipJoints`. Its percentiles say
    how much fine, fast motion a dataset has: the yardstick an sJPE is relative to."""
    setting = sjpe_setting(skeleton)
    joints = _clip_joints(clips if isinstance(clips, ClipJoints) else list(clips), None, "clips", setting)
    return _jerk_magnitudes(_select(joints.positions, setting), joints.lengths, setting.fps)[0]


def noise_sjpe_by_phase(pred_clips, gt_clips, period: int, skeleton: str = "t2m") -> np.ndarray:
    """Noise sJPE (element variant) split by where each jerk stencil sits within a token: ``(period,)``.

    A jerk row ``t`` reads frames ``t .. t+3``; its *phase* is ``(t + 2) mod period``, so phase 0 holds the
    stencils centred on a token boundary (frames ``qn - 1 | qn``) for tokens of ``period`` frames that start at
    frame 0. Each entry is that phase's share of every clip's Noise sJPE, averaged over clips, so the entries
    sum to :func:`sjpe_dataset`'s ``noise``. A decoder whose added jerk ignores the tokens puts ``1/period`` of
    it in each phase; one that leaks the token grid (a blocky condition) piles it into phase 0.
    Clips are lists of ``(T_i, J, 3)`` joints (all joints) or :class:`ClipJoints`, pair ``i`` of equal length.
    """
    if isinstance(period, bool) or not isinstance(period, int) or period < 1:
        raise ValueError(f"period must be a positive int (frames per token), got {period!r}")
    setting = sjpe_setting(skeleton)
    pred = _clip_joints(pred_clips, None, "pred_clips", setting)
    gt = _clip_joints(gt_clips, None, "gt_clips", setting)
    if len(pred) != len(gt) or (pred.lengths != gt.lengths).any():
        raise ValueError("pred_clips and gt_clips must hold the same number of clips, pair by pair of equal length")
    jp, clip_id = _jerk_magnitudes(_select(pred.positions, setting), pred.lengths, setting.fps)
    jg, _ = _jerk_magnitudes(_select(gt.positions, setting), gt.lengths, setting.fps)
    rows_per_clip = pred.lengths - 3
    row_in_clip = np.arange(len(clip_id)) - np.repeat(np.cumsum(rows_per_clip) - rows_per_clip, rows_per_clip)
    phase = (row_in_clip + 2) % period
    noise = _row_sums(sjpe_elements(jp, jg)[0])  # (R,): summed over the selected joints
    n_clips = len(pred)
    out = np.zeros(period)
    for p in range(period):
        per_clip = np.bincount(clip_id, weights=noise * (phase == p), minlength=n_clips) / rows_per_clip
        out[p] = per_clip.mean()
    return out


def sjpe(pred_joints, gt_joints, skeleton: str = "t2m", variant: str = "element") -> dict[str, float]:
    """sJPE of ONE clip: ``{"sjpe", "noise", "static"}`` with ``sjpe = noise + static``.

    ``pred_joints``/``gt_joints``: ``(T, 22, 3)`` metres for ``"t2m"`` or ``(T, 21, 3)`` millimetres for
    ``"kit"``, all joints; the function selects the joints and the frame rate itself. ``T >= 4``.
    For ``variant="element"`` the value lies in ``[0, n_selected_joints]``.
    """
    setting = sjpe_setting(skeleton)
    pred = check_joints(pred_joints, "pred_joints", setting.n_joints)
    gt = check_joints(gt_joints, "gt_joints", setting.n_joints)
    if pred.shape != gt.shape:
        raise ValueError(f"pred_joints {pred.shape} and gt_joints {gt.shape} must have the same shape")
    return sjpe_dataset([pred], [gt], skeleton, variant).as_dict()


def sjpe_from_features(
    pred_feats,
    gt_feats,
    lengths: Sequence[int] | None = None,
    skeleton: str = "t2m",
    variant: str = "element",
) -> SJPEResult:
    """sJPE from raw (de-normalised) HumanML3D features, as DisCoRD's evaluation does it.

    ``pred_feats``/``gt_feats``: ``(T, D)`` or ``(N, T, D)`` with ``D = 263`` (t2m) or ``251`` (KIT), or
    lists of ``(T_i, D)``. Each clip is cropped to its length (``lengths``, for arrays), then its joints are
    recovered on its real frames only (:meth:`ClipJoints.from_features`; the padding is never read). To score
    both variants, or MPJPE too, recover the joints once with :class:`ClipJoints` and call :func:`sjpe_variants`.
    """
    setting = sjpe_setting(skeleton)
    joints = []
    for name, feats in (("pred_feats", pred_feats), ("gt_feats", gt_feats)):
        n = None
        if isinstance(feats, (list, tuple)):
            if lengths is not None:
                raise ValueError("lengths is only used with array inputs; crop list items yourself")
        else:
            feats = _numpy(feats)
            feats = feats[None] if feats.ndim == 2 else feats
            if feats.ndim != 3:
                raise ValueError(f"{name} must have shape (T, D) or (N, T, D), got {feats.shape}")
            n = [feats.shape[1]] * feats.shape[0] if lengths is None else [int(m) for m in lengths]
            if len(n) != feats.shape[0] or any(m > feats.shape[1] for m in n):
                raise ValueError(f"lengths {n} do not fit {name} of shape {feats.shape}")
        try:
            clips = ClipJoints.from_features(feats, n)
        except ValueError as err:
            raise ValueError(f"{name}: {err}") from None
        if clips.n_joints != setting.n_joints:
            raise ValueError(f"{name} has {clips.n_joints}-joint features, not the {setting.n_joints} of {skeleton}")
        joints.append(clips)
    return sjpe_dataset(joints[0], joints[1], skeleton, variant)


# ---------------------------------------------------------------------------------------------------------
# Reporting: what sJPE's halves (and FID) see of a controlled perturbation (chapter 06, DisCoRD Fig. 4)
