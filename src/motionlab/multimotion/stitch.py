"""Putting decoded segments together in feature space: plain concatenation and a SLERP/linear blend.

**Why concatenating feature rows continues the trajectory.** A HumanML3D feature row stores the root's
*velocities* (yaw rate, planar displacement in its own facing frame) and everything else relative to the
root and facing +Z. Every decoded segment therefore starts "at the origin facing +Z" only in the sense
that :func:`~motionlab.representation.recover_from_ric` integrates from there; concatenate the rows and
the integration simply carries on: the second segment is the first's end pose frame's rigid continuation,
rotated about Y by the accumulated yaw and shifted by the accumulated displacement. Nothing jumps; the
only change at the boundary is in the *pose* (this is what TPS and the baselines try to smooth).

**The blend** (the SLERP baseline of M2D2M Table 6, after TEACH): between the last row ``a`` of segment i and
the first row ``b`` of segment i+1, ``W`` new rows at weights ``s_k = (k+1)/(W+1)``, k = 0…W−1, per group:

==================================  =========================================================
root yaw rate, planar velocity, y   linear in s (velocities blend, so the integrated root path
                                    stays continuous and turns smoothly)
ric (joint positions, root frame)   linear in s
rot (local joint rotations, 6D)     slerp of the unit quaternions, back to 6D
local_vel (joint velocities)        linear in s
foot_contact                        ``a``'s for s < 1/2, ``b``'s from 1/2 on
==================================  =========================================================

The segment rows themselves are untouched, so ``a, row_0, …, row_{W−1}, b`` is evenly spaced in s.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from motionlab.representation import cont6d_to_quat, feature_slices, quat_to_cont6d, skeleton_for_feature_dim, slerp


def _as_segments(features_list: Sequence, name: str = "features_list") -> list[np.ndarray]:
    if isinstance(features_list, np.ndarray) or len(features_list) == 0:
        raise ValueError(f"{name} must be a non-empty list of (T_i, D) feature arrays")
    out = [np.asarray(f.detach().cpu() if torch.is_tensor(f) else f, dtype=np.float32) for f in features_list]
    for i, f in enumerate(out):
        if f.ndim != 2 or f.shape[0] < 1 or f.shape[1] != out[0].shape[1]:
            raise ValueError(f"{name}[{i}] must be (T_i >= 1, D={out[0].shape[-1]}), got {f.shape}")
    return out


def concatenate_segments(features_list: Sequence) -> tuple[np.ndarray, list[int]]:
    """Rows of every segment back to back -> features (Σ T_i, D) and the boundaries (first frame of each
    segment but the first). The root trajectory continues across boundaries (see the module docstring)."""
    segments = _as_segments(features_list)
    return np.concatenate(segments, axis=0), np.cumsum([len(s) for s in segments])[:-1].tolist()


def split_segments(features: np.ndarray, boundaries: Sequence[int]) -> list[np.ndarray]:
    """The inverse: a (T, D) motion cut at ``boundaries`` (strictly increasing, inside (0, T))."""
    b = [int(x) for x in boundaries]
    if any(not 0 < x < len(features) for x in b) or any(x >= y for x, y in zip(b, b[1:], strict=False)):
        raise ValueError(f"boundaries must increase strictly inside (0, {len(features)}), got {b}")
    return np.split(np.asarray(features), b, axis=0)


def blend_weights(window: int) -> np.ndarray:
    """The ``window`` interpolation weights ``(k+1)/(window+1)``, strictly inside (0, 1)."""
    return np.arange(1, window + 1, dtype=np.float64) / (window + 1)


def transition_rows(a: np.ndarray, b: np.ndarray, window: int) -> np.ndarray:
    """``window`` feature rows from row ``a`` to row ``b`` (both (D,)): linear, rotations slerped -> (W, D)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"a and b must be feature rows of the same shape (D,), got {a.shape} and {b.shape}")
    sk = skeleton_for_feature_dim(a.shape[0])
    s = blend_weights(window)[:, None]  # (W, 1)
    rows = (1.0 - s) * a + s * b  # (W, D): every linear group at once
    rot = feature_slices(sk)["rot"]
    qa = cont6d_to_quat(a[rot].reshape(-1, 6))  # (J-1, 4)
    qb = cont6d_to_quat(b[rot].reshape(-1, 6))
    tile = lambda x: np.repeat(x[None], window, axis=0)  # noqa: E731  (J-1, 4) -> (W, J-1, 4)
    q = slerp(tile(qa), tile(qb), np.repeat(s, qa.shape[0], axis=1))  # (W, J-1, 4)
    rows[:, rot] = quat_to_cont6d(q).reshape(window, -1)
    contact = feature_slices(sk)["foot_contact"]
    rows[:, contact] = np.where(s < 0.5, a[contact], b[contact])
    return rows.astype(np.float32)


def blend_segments(features_list: Sequence, window: int = 40) -> tuple[np.ndarray, list[int]]:
    """Segments joined by ``window`` blended rows each -> features and boundaries (the middle of each blend).

    With segments shortened by ``window / 2`` frames at every inner end (see
    :func:`motionlab.multimotion.baselines.shortened_lengths`), the result has the original total length and
    boundaries, and the 40-frame transition window around each boundary is exactly the blend.
    """
    segments = _as_segments(features_list)
    if not isinstance(window, int) or window < 2 or window % 2:
        raise ValueError(f"window must be an even int >= 2 (frames), got {window!r}")
    pieces, boundaries, frame = [segments[0]], [], len(segments[0])
    for prev, nxt in zip(segments, segments[1:], strict=False):
        pieces += [transition_rows(prev[-1], nxt[0], window), nxt]
        boundaries.append(frame + window // 2)
        frame += window + len(nxt)
    return np.concatenate(pieces, axis=0), boundaries
