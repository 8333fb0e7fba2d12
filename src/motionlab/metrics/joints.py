"""The joint positions of a whole clip set, recovered once and shared by every metric that needs joints.

A :class:`ClipJoints` holds every *real* frame of every clip, one clip after another, in one contiguous
``(F, J, 3)`` float64 array (``F = sum of the lengths``): no padded frames are recovered, checked or stored,
and metrics run over the whole set with a few array operations instead of a loop over clips. sJPE (both
variants, :func:`~motionlab.metrics.sjpe_variants`), MPJPE (``mpjpe(a.positions, b.positions)``), Eq. 10 and
LDLJ (:func:`~motionlab.metrics.clip_log_jerk`) all accept it.

>>> joints = ClipJoints.from_features(raw_features)            # doctest: +SKIP
>>> joints.clip(3).shape                                         # doctest: +SKIP
(117, 22, 3)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from ..representation import skeleton_for_joint_count
from ..representation.features import recover_packed_from_ric


@dataclass(frozen=True, eq=False)
class ClipJoints:
    """Joint positions of ``N`` clips, packed: clip ``i`` is ``positions[starts[i] : starts[i] + lengths[i]]``."""

    positions: np.ndarray  # (F, J, 3) float64, C-contiguous, finite
    lengths: np.ndarray  # (N,) int64, each >= 1

    def __post_init__(self):
        object.__setattr__(self, "lengths", np.asarray(self.lengths, dtype=np.int64))
        p = self.positions
        if not isinstance(p, np.ndarray) or p.ndim != 3 or p.shape[-1] != 3 or p.dtype != np.float64:
            raise ValueError(
                f"positions must be a float64 (F, J, 3) array, got {getattr(p, 'dtype', type(p))} {np.shape(p)}"
            )
        if self.lengths.ndim != 1 or (self.lengths < 1).any() or self.lengths.sum() != len(p):
            raise ValueError(f"lengths must be positive and sum to the {len(p)} frames of positions")

    @classmethod
    def from_features(cls, features, lengths: Sequence[int] | None = None) -> ClipJoints:
        """Recover joints from raw (de-normalised) HumanML3D features: a list of ``(T_i, D)``, or a padded
        ``(N, T, D)`` array with ``lengths`` (padding is never read). See
        :func:`~motionlab.representation.features.recover_packed_from_ric`."""
        positions, n = recover_packed_from_ric(features, lengths)
        return cls(positions, n)

    @classmethod
    def from_joints(cls, clips, lengths: Sequence[int] | None = None) -> ClipJoints:
        """Pack joint positions: a list of ``(T_i, J, 3)``, or a padded ``(N, T, J, 3)`` array with ``lengths``.
        Rejects NaN/inf in the real frames; the padding is never read."""

        def as_numpy(x) -> np.ndarray:
            return x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else np.asarray(x)

        if isinstance(clips, (list, tuple)):
            if lengths is not None:
                raise ValueError("lengths is only used with a padded (N, T, J, 3) array; crop list items yourself")
            arrays = [as_numpy(c) for c in clips]
            if not arrays:
                raise ValueError("clips is an empty list")
            for i, a in enumerate(arrays):
                if a.ndim != 3 or a.shape[1:] != arrays[0].shape[1:] or a.shape[-1] != 3 or len(a) == 0:
                    raise ValueError(f"clips[{i}] must have shape (T >= 1, J, 3) like clips[0], got {a.shape}")
            n = np.array([len(a) for a in arrays], np.int64)
            positions = np.concatenate(arrays, axis=0).astype(np.float64, copy=False)
        else:
            padded = as_numpy(clips)
            if padded.ndim != 4 or padded.shape[-1] != 3:
                raise ValueError(
                    f"clips must be a list of (T_i, J, 3) or a padded (N, T, J, 3) array, got shape {padded.shape}"
                )
            n = np.full(len(padded), padded.shape[1], np.int64) if lengths is None else np.asarray(lengths, np.int64)
            if n.shape != (len(padded),) or (n < 1).any() or (n > padded.shape[1]).any():
                raise ValueError(f"lengths must be {len(padded)} values in [1, {padded.shape[1]}], got {n.tolist()}")
            positions = padded[np.arange(padded.shape[1]) < n[:, None]].astype(np.float64)
        if not np.isfinite(positions).all():
            bad = int(np.searchsorted(np.cumsum(n), np.argmin(np.isfinite(positions).all(axis=(1, 2))), "right"))
            raise ValueError(f"clip {bad} contains NaN or inf values")
        return cls(np.ascontiguousarray(positions), n)

    def __len__(self) -> int:
        return len(self.lengths)

    @property
    def n_joints(self) -> int:
        return self.positions.shape[1]

    @property
    def skeleton(self) -> str:
        """``"t2m"`` (22 joints) or ``"kit"`` (21)."""
        return skeleton_for_joint_count(self.n_joints).name

    @property
    def starts(self) -> np.ndarray:
        """``(N,)`` first row of each clip in :attr:`positions`."""
        return np.cumsum(self.lengths) - self.lengths

    def clip(self, i: int) -> np.ndarray:
        """Clip ``i``'s joints ``(T_i, J, 3)`` (a view)."""
        start = int(self.starts[i])
        return self.positions[start : start + int(self.lengths[i])]

    def clips(self) -> list[np.ndarray]:
        """Every clip as a ``(T_i, J, 3)`` view."""
        return np.split(self.positions, np.cumsum(self.lengths)[:-1])

    def root_travel(self) -> np.ndarray:
        """``(N,)`` each clip's net travel on the ground, in metres: how far the root (joint 0) ends from where it
        starts, up (y) left out. A walk across a room travels metres; a wave in place, centimetres."""
        from ..representation import get_skeleton

        first = self.positions[self.starts, 0]
        last = self.positions[self.starts + self.lengths - 1, 0]
        ground = (last - first)[:, [0, 2]]  # x and z: HumanML3D's y is up
        return np.linalg.norm(ground, axis=-1) * get_skeleton(self.skeleton).meters_per_unit

    def windows(self, starts: Sequence[int], window: int) -> np.ndarray:
        """``(N, window, J, 3)``: frames ``starts[i] .. starts[i] + window - 1`` of every clip ``i`` (a copy)."""
        first = np.asarray(starts, np.int64)
        if first.shape != (len(self),) or (first < 0).any() or (first + window > self.lengths).any():
            raise ValueError(f"every window [start, start + {window}) must lie inside its clip")
        return self.positions[(self.starts + first)[:, None] + np.arange(window)]


def same_clips(pred: ClipJoints, gt: ClipJoints) -> None:
    """Raise unless two clip sets pair up: same number of clips, same lengths, same skeleton."""
    if len(pred) != len(gt):
        raise ValueError(f"the prediction has {len(pred)} clips but the ground truth has {len(gt)}")
    if pred.n_joints != gt.n_joints:
        raise ValueError(f"the prediction has {pred.n_joints} joints but the ground truth has {gt.n_joints}")
    differ = np.flatnonzero(pred.lengths != gt.lengths)
    if len(differ):
        i = int(differ[0])
        raise ValueError(f"clip {i}: prediction has {pred.lengths[i]} frames but ground truth has {gt.lengths[i]}")
