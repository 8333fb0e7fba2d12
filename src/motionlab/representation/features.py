"""Joint positions <-> the HumanML3D feature vector (263 dims for t2m, 251 for KIT-ML).

Per frame t (T poses give T-1 feature rows; the last pose only contributes velocities):

====================  =========  ====================================================================
group                 t2m dims   content
====================  =========  ====================================================================
root_rot_vel          0          half-angle increment of the root's Y rotation from t to t+1
root_lin_vel          1:3        root displacement (x, z) t -> t+1, in the facing frame of t+1
root_height           3          root y (m)
ric                   4:67       21 joints relative to the root in x/z (y absolute), facing +Z
rot                   67:193     21 local joint rotations, 6D (first two matrix columns)
local_vel             193:259    22 joints' displacement t -> t+1, in the facing frame of t
foot_contact          259:263    left ankle, left foot, right ankle, right foot in {0, 1}
====================  =========  ====================================================================

:func:`joints_to_features` follows the public HumanML3D processing step by step (retarget to the target
skeleton, floor at y = 0, root at the origin in frame 0, face +Z in frame 0); :func:`recover_from_ric`
and :func:`recover_from_rot` invert it, and :func:`recover_packed_from_ric` does the former for a whole
clip set at once, on real frames only (what the metrics use, via ``motionlab.metrics.ClipJoints``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from .kinematics import _fk_matrices, facing_direction, forward_kinematics, inverse_kinematics, measured_offsets
from .quaternion import (
    _cont6d_to_matrix,
    _qinv,
    _qrot,
    like_input,
    qbetween,
    qinv,
    qmul,
    qrot,
    quat_to_cont6d,
    quat_to_matrix,
    to_torch,
)
from .skeleton import Skeleton, get_skeleton, skeleton_for_feature_dim, skeleton_for_joint_count

FEATURE_GROUPS = ("root_rot_vel", "root_lin_vel", "root_height", "ric", "rot", "local_vel", "foot_contact")


def feature_slices(skeleton: str | Skeleton = "t2m") -> dict[str, slice]:
    """Where each feature group lives in the vector, e.g. ``feature_slices()["ric"] == slice(4, 67)``."""
    j = get_skeleton(skeleton).n_joints
    sizes = (1, 2, 1, 3 * (j - 1), 6 * (j - 1), 3 * j, 4)
    out, start = {}, 0
    for name, size in zip(FEATURE_GROUPS, sizes):
        out[name] = slice(start, start + size)
        start += size
    return out


def _check_joints(joints, sk: Skeleton, name: str = "joints") -> np.ndarray:
    arr = joints.detach().cpu().double().numpy() if isinstance(joints, torch.Tensor) else np.asarray(joints)
    if arr.ndim != 3 or arr.shape[1:] != (sk.n_joints, 3):
        raise ValueError(f"{name} must have shape (T, {sk.n_joints}, 3) for skeleton {sk.name!r}, got {arr.shape}")
    if arr.shape[0] < 2:
        raise ValueError(f"{name} needs at least 2 frames to produce features, got {arr.shape[0]}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or inf values")
    return arr.astype(np.float64)


def _check_features(features, n_joints: int | None = None) -> tuple[torch.Tensor, bool, Skeleton]:
    t, was_numpy = to_torch(features)
    if t.dim() < 2:
        raise ValueError(f"features must have shape (..., T, D), got {tuple(t.shape)}")
    sk = skeleton_for_feature_dim(t.shape[-1])
    if n_joints is not None and n_joints != sk.n_joints:
        raise ValueError(
            f"features of dimension {t.shape[-1]} belong to {sk.name} ({sk.n_joints} joints), not {n_joints}"
        )
    if not torch.isfinite(t).all():
        raise ValueError("features contain NaN or inf values")
    return t, was_numpy, sk


@dataclass
class ProcessedMotion:
    """Everything the HumanML3D processing produces for one clip."""

    features: np.ndarray  # (T-1, D)
    joints: np.ndarray  # (T, J, 3): retargeted, on the floor, root at origin, facing +Z in frame 0
    local_quats: np.ndarray  # (T, J, 4): the inverse-kinematics rotations behind the rot features


def retarget(joints: np.ndarray, skeleton: str | Skeleton = "t2m") -> np.ndarray:
    """Put a motion ``(T, J, 3)`` onto the skeleton's target bone lengths (HumanML3D's ``uniform_skeleton``).

    The root trajectory is scaled by the ratio of leg lengths; every pose is re-posed by inverse then
    forward kinematics with the target offsets.
    """
    sk = get_skeleton(skeleton)
    joints = np.asarray(joints, dtype=np.float64)
    src_lengths = np.linalg.norm(measured_offsets(joints[0], sk), axis=-1)
    a, b = sk.leg_joints
    scale = (sk.bone_lengths[a] + sk.bone_lengths[b]) / (src_lengths[a] + src_lengths[b])
    quats = inverse_kinematics(joints, sk, smooth_forward=False)
    return forward_kinematics(quats, joints[:, 0] * scale, sk)


def process_joints(
    joints, skeleton: str | Skeleton = "t2m", retarget_to_target: bool = True, feet_threshold: float | None = None
) -> ProcessedMotion:
    """Canonicalise a motion and compute its features, as the public HumanML3D processing does."""
    sk = get_skeleton(skeleton)
    positions = _check_joints(joints, sk)
    if retarget_to_target:
        positions = retarget(positions, sk)

    positions = positions - np.array([0.0, positions[..., 1].min(), 0.0])  # floor at y = 0
    positions = positions - positions[0, 0] * np.array([1.0, 0.0, 1.0])  # root xz at the origin
    forward0 = facing_direction(positions[:1], sk.face_joints)
    forward0 = forward0 / np.linalg.norm(forward0, axis=-1, keepdims=True)
    face_z = qbetween(forward0, np.array([[0.0, 0.0, 1.0]]))
    positions = qrot(np.broadcast_to(face_z, positions.shape[:-1] + (4,)), positions)

    threshold = sk.contact_threshold if feet_threshold is None else feet_threshold
    step = np.sum((positions[1:] - positions[:-1]) ** 2, axis=-1)  # (T-1, J) squared displacement
    feet_l = (step[:, list(sk.feet_left)] < threshold).astype(np.float64)
    feet_r = (step[:, list(sk.feet_right)] < threshold).astype(np.float64)

    quats = inverse_kinematics(positions, sk, smooth_forward=True, identity_first_root=True)
    cont6d = quat_to_cont6d(quats)  # (T, J, 6)
    r_rot = quats[:, 0]
    root_step = qrot(r_rot[1:], positions[1:, 0] - positions[:-1, 0])
    r_vel = qmul(r_rot[1:], qinv(r_rot[:-1]))

    ric = positions.copy()
    ric[..., 0] -= positions[:, :1, 0]
    ric[..., 2] -= positions[:, :1, 2]
    ric = qrot(np.repeat(r_rot[:, None], sk.n_joints, axis=1), ric)

    local_vel = qrot(np.repeat(r_rot[:-1, None], sk.n_joints, axis=1), positions[1:] - positions[:-1])
    n = len(positions) - 1
    features = np.concatenate(
        [
            np.arcsin(np.clip(r_vel[:, 2:3], -1.0, 1.0)),
            root_step[:, [0, 2]],
            ric[:-1, 0, 1:2],
            ric[:-1, 1:].reshape(n, -1),
            cont6d[:-1, 1:].reshape(n, -1),
            local_vel.reshape(n, -1),
            feet_l,
            feet_r,
        ],
        axis=-1,
    )
    return ProcessedMotion(features=features, joints=positions, local_quats=quats)


def joints_to_features(joints, skeleton: str | Skeleton = "t2m", retarget_to_target: bool = True):
    """HumanML3D features ``(T-1, D)`` of joint positions ``(T, J, 3)``.

    NumPy in, NumPy out (float64); a torch tensor gives a tensor of its dtype. Set
    ``retarget_to_target=False`` to keep the input's own bone lengths.
    """
    was_torch = isinstance(joints, torch.Tensor)
    feats = process_joints(joints, skeleton, retarget_to_target).features
    if was_torch:
        return torch.as_tensor(feats, dtype=joints.dtype, device=joints.device)
    return feats


def _recover_root(data: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    # data (..., T, D) -> root rotation quats (..., T, 4), root positions (..., T, 3)
    rot_vel = data[..., 0]
    angle = torch.zeros_like(rot_vel)
    angle[..., 1:] = torch.cumsum(rot_vel[..., :-1], dim=-1)  # half-angles: q = (cos a, 0, sin a, 0)
    quat = torch.zeros(data.shape[:-1] + (4,), dtype=data.dtype, device=data.device)
    quat[..., 0] = torch.cos(angle)
    quat[..., 2] = torch.sin(angle)

    pos = torch.zeros(data.shape[:-1] + (3,), dtype=data.dtype, device=data.device)
    pos[..., 1:, 0] = data[..., :-1, 1]
    pos[..., 1:, 2] = data[..., :-1, 2]
    pos = torch.cumsum(_qrot(_qinv(quat), pos), dim=-2)
    pos[..., 1] = data[..., 3]
    return quat, pos


def recover_root(features):
    """Root rotation quaternions ``(..., T, 4)`` and positions ``(..., T, 3)`` integrated from features."""
    data, was_numpy, _ = _check_features(features)
    quat, pos = _recover_root(data)
    return like_input(quat, was_numpy), like_input(pos, was_numpy)


def recover_from_ric(features, n_joints: int | None = None):
    """Joint positions ``(..., T, J, 3)`` from features ``(..., T, D)`` via the root-relative positions.

    ``n_joints`` (22 or 21) is checked against the feature dimension when given.
    """
    data, was_numpy, sk = _check_features(features, n_joints)
    j = sk.n_joints
    quat, root = _recover_root(data)
    ric = data[..., 4 : 4 + 3 * (j - 1)].reshape(data.shape[:-1] + (j - 1, 3))
    ric = _qrot(_qinv(quat)[..., None, :].expand(ric.shape[:-1] + (4,)), ric)
    ric = ric + torch.stack((root[..., 0], torch.zeros_like(root[..., 0]), root[..., 2]), dim=-1)[..., None, :]
    return like_input(torch.cat((root[..., None, :], ric), dim=-2), was_numpy)


# --- many clips at once, on their real frames only ------------------------------------------------------

_BLOCK_FRAMES = 2048  # clips are recovered a block of about this many frames at a time: temporaries stay in cache


def _clip_source(features, lengths) -> tuple[Callable[[int, int, int], np.ndarray], np.ndarray, int]:
    """``rows(a, b, k)``: the first ``k`` feature columns of the real frames of clips ``a .. b-1``, clip after
    clip; the lengths ``(N,)``; the feature dimension. ``features``: a list of ``(T_i, D)``, or ``(N, T, D)``
    with ``lengths`` (the padding is never read)."""

    def as_numpy(x) -> np.ndarray:
        return x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else np.asarray(x)

    if isinstance(features, (list, tuple)):
        if lengths is not None:
            raise ValueError("lengths is only used with a padded (N, T, D) array; crop list items yourself")
        if not features:
            raise ValueError("features is an empty list")
        clips = [as_numpy(f) for f in features]
        for i, c in enumerate(clips):
            if c.ndim != 2 or c.shape[-1] != clips[0].shape[-1] or len(c) == 0:
                raise ValueError(f"features[{i}] must have shape (T >= 1, {clips[0].shape[-1]}), got {c.shape}")
        n = np.array([len(c) for c in clips], dtype=np.int64)
        return (lambda a, b, k: np.concatenate([c[:, :k] for c in clips[a:b]])), n, clips[0].shape[-1]
    padded = as_numpy(features)
    if padded.ndim != 3:
        raise ValueError(
            f"features must be a list of (T_i, D) arrays or a padded (N, T, D) array, got shape {padded.shape}"
        )
    n = np.full(len(padded), padded.shape[1], np.int64) if lengths is None else np.asarray(lengths, np.int64)
    if n.shape != (len(padded),) or (n < 1).any() or (n > padded.shape[1]).any():
        raise ValueError(f"lengths must be {len(padded)} values in [1, {padded.shape[1]}], got {n.tolist()}")
    real = np.arange(padded.shape[1]) < n[:, None]  # (N, T)
    return (lambda a, b, k: padded[a:b, :, :k][real[a:b]]), n, padded.shape[-1]


def _rotate_y(c, uy, x, z):
    """x and z of ``v = (x, y, z)`` rotated by the unit quaternion ``(c, 0, uy, 0)`` (y does not change).

    ``_qrot``'s ``v + 2 (w (u x v) + u x (u x v))`` with the zero terms of ``u = (0, uy, 0)`` left out and the
    rest in the same order, so it gives ``_qrot``'s result to the bit; no broadcast quaternion tensors.
    """
    a = uy * z  # (u x v)_x
    b = -uy * x  # (u x v)_z
    return x + 2.0 * (c * a + uy * b), z + 2.0 * (c * b - uy * a)


def _recover_block(rows: np.ndarray, n: np.ndarray, out: np.ndarray) -> None:
    """:func:`recover_from_ric` of packed clips: feature rows ``(F, 4 + 3 (J-1))`` of clips of ``n`` frames
    into ``out`` ``(F, J, 3)``. Root rotation and position are per-clip running sums on an ``(N, max T)``
    grid (zero past each clip's end); the root-relative joints are then rotated as flat arrays."""
    frames, j = len(rows), out.shape[1]
    clip = np.repeat(np.arange(len(n)), n)  # (F,) the clip of each frame
    t = np.arange(frames) - np.repeat(np.cumsum(n) - n, n)  # (F,) the frame within its clip
    root_in = rows[:, :4].astype(np.float64)  # (F, 4): rotation increment, x/z step, height
    grid = np.zeros((len(n), int(n.max())))  # (N, max T)
    grid[clip, t] = root_in[:, 0]
    angle = np.zeros_like(grid)
    angle[:, 1:] = np.cumsum(grid[:, :-1], axis=1)  # the half-angle sums the previous frames' increments
    angle = angle[clip, t]
    c, uy = np.cos(angle), -np.sin(angle)  # (F,) each: the inverse rotation (cos, 0, -sin, 0)
    # Root position: the previous frame's (x, z) step turned into the world frame, summed per clip.
    first = t == 0
    prev_x, prev_z = (np.where(first, 0.0, np.roll(root_in[:, k], 1)) for k in (1, 2))
    for axis, step in zip((0, 2), _rotate_y(c, uy, prev_x, prev_z)):
        grid[clip, t] = step
        out[:, 0, axis] = np.cumsum(grid, axis=1)[clip, t]
    out[:, 0, 1] = root_in[:, 3]
    ric = rows[:, 4:].reshape(frames, j - 1, 3)  # (F, J-1, 3): facing +Z, x/z relative to the root
    x, z = _rotate_y(c[:, None], uy[:, None], ric[:, :, 0], ric[:, :, 2])
    out[:, 1:, 0] = x + out[:, :1, 0]
    out[:, 1:, 1] = ric[:, :, 1]
    out[:, 1:, 2] = z + out[:, :1, 2]


def recover_packed_from_ric(features, lengths=None, n_joints: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`recover_from_ric` of many clips at once, on their real frames only, in float64.

    ``features``: a list of ``(T_i, D)`` arrays (NumPy or torch), or a padded ``(N, T, D)`` array with
    ``lengths`` (frames past ``lengths[i]`` are never read, not even checked for NaN). Returns the joint
    positions of every real frame, clip after clip, ``(sum_i T_i, J, 3)`` float64 C-contiguous, and the
    lengths ``(N,)``: ``positions[start_i : start_i + T_i]`` equals ``recover_from_ric(clip_i)`` in float64.

    Clips are recovered a block of whole clips (about ``_BLOCK_FRAMES`` frames) at a time, so every
    temporary stays in cache and the output is written in one pass; no padded frame is touched and no
    quaternion product runs on broadcast tensors.
    """
    rows_of, n, dim = _clip_source(features, lengths)
    sk = skeleton_for_feature_dim(int(dim))
    if n_joints is not None and n_joints != sk.n_joints:
        raise ValueError(f"features of dimension {dim} belong to {sk.name} ({sk.n_joints} joints), not {n_joints}")
    j = sk.n_joints
    ends = np.cumsum(n)
    out = np.empty((int(ends[-1]), j, 3))  # (F, J, 3)
    a = 0
    while a < len(n):
        start = int(ends[a] - n[a])
        b = max(a + 1, int(np.searchsorted(ends, start + _BLOCK_FRAMES, side="right")))  # whole clips
        rows = rows_of(a, b, 4 + 3 * (j - 1))  # (F_block, 4 + 3 (J-1))
        if not np.isfinite(rows).all():
            bad = a + int(np.searchsorted(np.cumsum(n[a:b]), np.argmin(np.isfinite(rows).all(axis=1)), "right"))
            raise ValueError(f"features of clip {bad} contain NaN or inf values")
        _recover_block(rows, n[a:b], out[start : int(ends[b - 1])])
        a = b
    return out, n


def recover_from_rot(features, skeleton: str | Skeleton | None = None):
    """Joint positions ``(..., T, J, 3)`` by forward kinematics of the 6D rotations on the target skeleton."""
    data, was_numpy, sk = _check_features(features)
    sk = get_skeleton(skeleton) if skeleton is not None else sk
    j = sk.n_joints
    quat, root = _recover_root(data)
    s = feature_slices(sk)["rot"]
    local = _cont6d_to_matrix(data[..., s].reshape(data.shape[:-1] + (j - 1, 6)))
    root_m = quat_to_matrix(quat)[..., None, :, :]
    rotations = torch.cat((root_m, local), dim=-3)
    offsets = torch.as_tensor(sk.offsets, dtype=data.dtype, device=data.device)
    return like_input(_fk_matrices(rotations, root, offsets, sk.chains), was_numpy)


def infer_skeleton(array) -> Skeleton:
    """Guess the skeleton of joints ``(..., J, 3)`` or features ``(..., D)``."""
    shape = tuple(array.shape)
    if len(shape) >= 2 and shape[-1] == 3:
        return skeleton_for_joint_count(shape[-2])
    return skeleton_for_feature_dim(shape[-1])
