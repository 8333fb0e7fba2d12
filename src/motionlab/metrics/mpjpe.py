"""MPJPE: mean per-joint position error after aligning both skeletons at the pelvis."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ._checks import as_float_array


def mpjpe(pred_joints, gt_joints) -> float:
    """``mean_{t,j} || (P[t,j] - P[t,0]) - (G[t,j] - G[t,0]) ||_2`` in the input's unit.

    ``pred_joints``/``gt_joints``: arrays ``(..., J, 3)`` of the same shape (one clip ``(T, J, 3)`` or a
    batch), or equal-length lists of clips whose poses are pooled (every pose weighs the same, as in
    DisCoRD's "MAE"). Joint 0 is the pelvis: subtracting it removes the global trajectory.
    """
    pred, gt = _pool(pred_joints, "pred_joints"), _pool(gt_joints, "gt_joints")
    if pred.shape != gt.shape:
        raise ValueError(f"pred_joints {pred.shape} and gt_joints {gt.shape} must have the same shape")
    if pred.ndim < 2 or pred.shape[-1] != 3:
        raise ValueError(f"joints must have shape (..., J, 3), got {pred.shape}")
    pred = pred - pred[..., :1, :]
    gt = gt - gt[..., :1, :]
    return float(np.linalg.norm(pred - gt, axis=-1).mean())


def _pool(x, name: str) -> np.ndarray:
    if isinstance(x, Sequence) and not isinstance(x, np.ndarray) and len(x) and np.ndim(x[0]) == 3:
        return np.concatenate([as_float_array(c, f"{name}[{i}]") for i, c in enumerate(x)], axis=0)
    return as_float_array(x, name)
