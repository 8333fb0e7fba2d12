"""Forward and inverse kinematics in HumanML3D's convention.

HumanML3D walks each kinematic chain starting from the *root* rotation, even for chains that start at
another joint (the arms hang off spine3 but their first local rotation is relative to the root). A joint's
local rotation is the rotation of the bone that *ends* at that joint, taking the skeleton's unit raw offset
onto the observed bone direction. These conventions are a contract with every model trained on the
features, so they are kept exactly.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d

from .quaternion import (
    _cont6d_to_matrix,
    _qbetween,
    _qinv,
    _qmul,
    _quat_to_matrix,
    like_input,
    to_torch,
)
from .skeleton import Skeleton, get_skeleton


def _fk_matrices(rotations: torch.Tensor, root_pos: torch.Tensor, offsets: torch.Tensor, chains) -> torch.Tensor:
    # rotations (..., J, 3, 3) local; root_pos (..., 3); offsets (J, 3) -> joints (..., J, 3)
    joints = [None] * rotations.shape[-3]
    joints[0] = root_pos
    for chain in chains:
        R = rotations[..., 0, :, :]
        for parent, child in zip(chain[:-1], chain[1:]):
            R = R @ rotations[..., child, :, :]
            joints[child] = (R @ offsets[child].to(R.dtype)[:, None])[..., 0] + joints[parent]
    return torch.stack(joints, dim=-2)


def forward_kinematics(local_quats, root_pos, skeleton: str | Skeleton = "t2m", offsets=None):
    """Joint positions ``(..., J, 3)`` from local rotations ``(..., J, 4)`` and root positions ``(..., 3)``.

    ``offsets`` (``(J, 3)``) defaults to the skeleton's target offsets. NumPy in, NumPy out.
    """
    sk = get_skeleton(skeleton)
    q, was_numpy = to_torch(local_quats)
    root, _ = to_torch(root_pos)
    off, _ = to_torch(sk.offsets if offsets is None else offsets)
    root = root.to(q.dtype)
    return like_input(_fk_matrices(_quat_to_matrix(q), root, off.to(q.dtype), sk.chains), was_numpy)


def forward_kinematics_cont6d(local_6d, root_pos, skeleton: str | Skeleton = "t2m", offsets=None):
    """Like :func:`forward_kinematics` with 6D local rotations ``(..., J, 6)``."""
    sk = get_skeleton(skeleton)
    r6, was_numpy = to_torch(local_6d)
    root, _ = to_torch(root_pos)
    off, _ = to_torch(sk.offsets if offsets is None else offsets)
    return like_input(_fk_matrices(_cont6d_to_matrix(r6), root.to(r6.dtype), off.to(r6.dtype), sk.chains), was_numpy)


def measured_offsets(frame_joints: np.ndarray, skeleton: str | Skeleton = "t2m") -> np.ndarray:
    """Bone vectors ``(J, 3)`` along the raw directions with the lengths measured in one pose ``(J, 3)``."""
    sk = get_skeleton(skeleton)
    frame_joints = np.asarray(frame_joints, dtype=np.float64)
    lengths = np.zeros(sk.n_joints)
    for j, p in enumerate(sk.parents):
        if p >= 0:
            lengths[j] = np.linalg.norm(frame_joints[j] - frame_joints[p])
    return sk.raw_offsets * lengths[:, None]


def facing_direction(joints: np.ndarray, face_joints, hip_order_quirk: bool = False) -> np.ndarray:
    """Unit horizontal forward direction ``(T, 3)`` of poses ``(T, J, 3)`` from hips and shoulders.

    ``face_joints`` = (right hip, left hip, right shoulder, left shoulder). The across vector is
    right-minus-left for hips plus shoulders; forward = up x across. HumanML3D's inverse kinematics
    unpacks the hips in the opposite order (``hip_order_quirk=True``), which flips the hip vector; the
    result still faces the right way because shoulders are wider than hips, and the features depend on it.
    """
    r_hip, l_hip, r_sdr, l_sdr = face_joints
    if hip_order_quirk:
        r_hip, l_hip = l_hip, r_hip
    across = (joints[:, r_hip] - joints[:, l_hip]) + (joints[:, r_sdr] - joints[:, l_sdr])
    across = across / np.linalg.norm(across, axis=-1, keepdims=True)
    forward = np.cross(np.array([[0.0, 1.0, 0.0]]), across, axis=-1)
    return forward


def inverse_kinematics(
    joints, skeleton: str | Skeleton = "t2m", smooth_forward: bool = False, identity_first_root: bool = False
):
    """Local joint rotations ``(T, J, 4)`` that reproduce ``joints`` ``(T, J, 3)`` on the skeleton.

    The root rotation turns the (optionally Gaussian-smoothed, sigma = 20 frames) facing direction onto
    +Z. Bone twist is unobservable from positions, so each local rotation is the shortest arc.
    ``identity_first_root`` pins frame 0's root rotation to the identity, as the processing that produced
    the released HumanML3D features did (frame 0 already faces +Z there; the smoothed estimate may not).
    """
    sk = get_skeleton(skeleton)
    jt, was_numpy = to_torch(joints)
    j = jt.detach().cpu().double().numpy()
    forward = facing_direction(j, sk.face_joints, hip_order_quirk=True)
    if smooth_forward:
        forward = gaussian_filter1d(forward, 20, axis=0, mode="nearest")
    forward = forward / np.linalg.norm(forward, axis=-1, keepdims=True)

    jt64 = torch.from_numpy(j)
    root_quat = _qbetween(torch.from_numpy(forward), torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64))
    if identity_first_root:
        root_quat[0] = torch.tensor([1.0, 0.0, 0.0, 0.0], dtype=torch.float64)
    quats = torch.zeros(j.shape[:-1] + (4,), dtype=torch.float64)
    quats[:, 0] = root_quat
    raw = torch.from_numpy(sk.raw_offsets)
    for chain in sk.chains:
        R = root_quat
        for parent, child in zip(chain[:-1], chain[1:]):
            bone = jt64[:, child] - jt64[:, parent]
            world = _qbetween(raw[child].expand_as(bone), bone)
            local = _qmul(_qinv(R), world)
            quats[:, child] = local
            R = _qmul(R, local)
    out = quats if was_numpy else quats.to(dtype=jt.dtype, device=jt.device)
    return like_input(out, was_numpy)
