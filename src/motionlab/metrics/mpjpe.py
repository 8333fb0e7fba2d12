"""MPJPE: mean per-joint position error after aligning both skeletons at the pelvis."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ._checks import as_float_array
from .jerk import squared_length
from .joints import ClipJoints


def mpjpe(pred_joints, gt_joints) -> float:
    """``mean_{t,j} || (P[t,j] - P[t,0]) - (G[t,j] - G[t,0]) ||_2`` in the input's unit.

    ``pred_joints``/``gt_joints``: arrays ``(..., J, 3)`` of the same shape (one clip ``(T, J, 3)`` or a
    batch), equal-length lists of clips whose poses are pooled (every pose weighs the same, as in
    DisCoRD's "MAE"), or two :class:`ClipJoints` of the same clips (pooled likewise, without a copy).
    Joint 0 is the pelvis: subtracting it removes the global trajectory.
    """
    per_pose, n_joints = _pose_errors(pred_joints, gt_joints)
    return float(per_pose.sum() / (per_pose.size * n_joints))


def mpjpe_per_clip(pred_joints: ClipJoints, gt_joints: ClipJoints) -> np.ndarray:
    """MPJPE of each clip ``(N,)``; weighted by ``lengths`` their mean is :func:`mpjpe` of the pooled poses."""
    if not (isinstance(pred_joints, ClipJoints) and isinstance(gt_joints, ClipJoints)):
        raise ValueError("mpjpe_per_clip needs two ClipJoints (ClipJoints.from_features or .from_joints)")
    if not np.array_equal(pred_joints.lengths, gt_joints.lengths):
        raise ValueError("pred_joints and gt_joints must hold the same clips: their clip lengths differ")
    per_pose, n_joints = _pose_errors(pred_joints, gt_joints)
    return np.add.reduceat(per_pose, pred_joints.starts) / (pred_joints.lengths * n_joints)


def _pose_errors(pred_joints, gt_joints) -> tuple[np.ndarray, int]:
    """Each pose's summed pelvis-aligned joint error ``(P,)`` and the number of joints."""
    pred, gt = _pool(pred_joints, "pred_joints"), _pool(gt_joints, "gt_joints")
    if pred.shape != gt.shape:
        raise ValueError(f"pred_joints {pred.shape} and gt_joints {gt.shape} must have the same shape")
    if pred.ndim < 2 or pred.shape[-1] != 3:
        raise ValueError(f"joints must have shape (..., J, 3), got {pred.shape}")
    pred, gt = pred.reshape(-1, *pred.shape[-2:]), gt.reshape(-1, *gt.shape[-2:])  # (P, J, 3): poses
    out = np.empty(len(pred))
    for s in range(0, len(pred), _BLOCK_POSES):  # a cache-sized block at a time: one pass over memory
        error = pred[s : s + _BLOCK_POSES] - gt[s : s + _BLOCK_POSES]  # (B, J, 3)
        error -= error[:, :1]  # aligning both pelvises = subtracting the pelvis's error
        out[s : s + len(error)] = np.sqrt(squared_length(error)).sum(axis=1)
    return out, pred.shape[1]


_BLOCK_POSES = 2048


def _pool(x, name: str) -> np.ndarray:
    if isinstance(x, ClipJoints):
        return x.positions  # finite float64 by construction
    if isinstance(x, Sequence) and not isinstance(x, np.ndarray) and len(x) and np.ndim(x[0]) == 3:
        return np.concatenate([as_float_array(c, f"{name}[{i}]") for i, c in enumerate(x)], axis=0)
    return as_float_array(x, name)
