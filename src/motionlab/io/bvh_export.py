"""Joint positions (or HumanML3D features) on the t2m skeleton -> a BVH file.

Rotations come from :func:`motionlab.representation.inverse_kinematics`, which follows HumanML3D's
convention: the quaternion stored at joint ``c`` turns the bone that *ends* at ``c``, and every chain
restarts from the root rotation (the arms too, although they hang off ``spine3``). Along a chain the world
rotation of each bone is therefore::

    W(bone -> c_k) = Q_root * q_c1 * q_c2 * ... * q_ck        # chain (start, c1, ..., ck, ...)

(:func:`bone_world_rotations` solves the bones with the body turned to face +Z and then turns them by the
body's heading, so that a whole-body turn shows up in the root channels only.)

BVH has the opposite habit: a joint's rotation moves its *children*, relative to its BVH parent's frame.
So BVH joint ``j`` carries the world rotation of the bone leaving ``j``, and its channels hold the local
part ``L_j = W_parent(j)^T W_j``. A joint with several children (``pelvis``: both hips and the spine;
``spine3``: neck and both collars) cannot carry several rotations, so each of its outgoing bones starts at a
zero-length helper joint ``<joint>_to_<child>`` (the way CMU's ``LHipJoint`` works). The rest:

* ``pelvis`` is the ROOT with 6 channels: position, then the body's heading ``Q_root^-1`` (about Y);
* ``spine3`` keeps the frame of the bone that reaches it (its channels are zero);
* the five end joints (feet, head, wrists) keep the frame of their bone and end in an ``End Site`` half a
  bone further along it, so viewers draw toes, a head and hands;
* OFFSETs are the t2m target bone vectors (``T2M.offsets``: raw direction x target length), in ``unit``.

**The helper joints**, for a retargeting tool (Blender, MotionBuilder, Rokoko, ...): the file has the 22 t2m
joints under their t2m names plus six helpers (:func:`helper_joints`)::

    pelvis_to_left_hip, pelvis_to_right_hip, pelvis_to_spine1          # children of pelvis
    spine3_to_neck, spine3_to_left_collar, spine3_to_right_collar      # children of spine3

Each sits at its parent's position (OFFSET 0 0 0: it draws no bone of its own) and carries the rotation of the
bone from that parent to the t2m joint below it (``pelvis_to_left_hip``: pelvis -> left_hip), which the parent,
having several bones to turn, cannot carry. A retargeting map names the 22 t2m joints and leaves the helpers
out. A tool that matches bones by their world orientation needs nothing more; one that copies local rotations
bone by bone must first fold each helper's rotation into the joint below it (the joint's world rotation is
helper's times its own), as baking the imported skeleton's world transforms does.
``motionlab convert`` and ``motionlab data from-bvh`` recognise the rig by these names (``--mapping auto``).

Rotation channels are ``rotation_order`` (default ``"ZYX"``, written ``Zrotation Yrotation Xrotation``),
intrinsic Euler angles in degrees; positions are in ``unit`` (default metres, Y-up, HumanML3D's axes).
Because BVH offsets are fixed, a motion whose bone lengths differ from the target's comes back with the
target lengths and its bone directions.

**Which is the motion?** A motion decoded from features (every generated one) need not keep its bones
rigid: a forearm may measure 0.12 m in one frame and 0.28 m in another. The features, and the joint positions
recovered from them (``.npy``, ``.html``), are the motion as generated and as the metrics score it; the BVH
is its rigid-skeleton version (the same bone directions on the target bone lengths). :func:`save_bvh` warns
(:class:`~motionlab.io.common.MotionWarning`) when a bone's length varies by more than
:data:`STRETCH_WARNING` metres, naming the bone, its range and how far the BVH's joints end up from the
motion's.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..representation import T2M, Skeleton, inverse_kinematics, qinv, qmul, qrot, quat_to_matrix
from .bvh import Bvh, BvhJoint, write_bvh
from .common import as_joints, bone_stretch, warn

UNITS = {"m": 1.0, "cm": 100.0, "mm": 1000.0}  # file units per metre
END_SITE_FRACTION = 0.5  # an end joint's End Site sits this fraction of its bone beyond it
STRETCH_WARNING = 0.02  # metres: a bone whose length varies more than this within a motion is reported


@dataclass(frozen=True)
class RigNode:
    """A BVH joint of the exported rig and where its world rotation comes from."""

    joint: BvhJoint
    frame_of: int  # -1: the root rotation; k >= 1: the world rotation of the bone ending at t2m joint k


def _children(skeleton: Skeleton) -> dict[int, list[int]]:
    kids: dict[int, list[int]] = {j: [] for j in range(skeleton.n_joints)}
    for j, p in enumerate(skeleton.parents):
        if p >= 0:
            kids[p].append(j)
    return kids


def t2m_bvh_rig(skeleton: Skeleton = T2M, unit: str = "m", rotation_order: str = "ZYX") -> list[RigNode]:
    """The exported hierarchy in depth-first order (see the module docstring for the rules)."""
    if unit not in UNITS:
        raise ValueError(f"unit must be one of {sorted(UNITS)}, got {unit!r}")
    order = _check_order(rotation_order)
    rot = tuple(f"{a}rotation" for a in order)
    offsets = skeleton.offsets * UNITS[unit]  # (J, 3)
    names = skeleton.joint_names
    kids = _children(skeleton)
    nodes: list[RigNode] = []

    def add(j: int, bvh_parent: int) -> None:
        index = len(nodes)
        if j == 0:
            position = ("Xposition", "Yposition", "Zposition")
            joint, frame_of = BvhJoint(names[0], -1, (0.0, 0.0, 0.0), position + rot), -1  # the heading
        else:
            frame_of = kids[j][0] if len(kids[j]) == 1 else j  # the bone leaving j, else the one reaching j
            joint = BvhJoint(names[j], bvh_parent, tuple(map(float, offsets[j])), rot)
        nodes.append(RigNode(joint, frame_of))
        if not kids[j]:
            tip = tuple(map(float, END_SITE_FRACTION * offsets[j]))
            nodes.append(RigNode(BvhJoint(f"{names[j]}_end", index, tip, (), end_site=True), j))
        elif len(kids[j]) == 1:
            add(kids[j][0], index)
        else:
            for c in kids[j]:
                nodes.append(RigNode(BvhJoint(f"{names[j]}_to_{names[c]}", index, (0.0, 0.0, 0.0), rot), c))
                add(c, len(nodes) - 1)

    add(0, -1)
    return nodes


def helper_joints(skeleton: Skeleton = T2M) -> tuple[str, ...]:
    """The zero-length joints the exported rig adds (``<joint>_to_<child>``, one per bone leaving a joint with
    several children), in file order."""
    names = set(skeleton.joint_names)
    return tuple(n.joint.name for n in t2m_bvh_rig(skeleton) if n.joint.name not in names and not n.joint.end_site)


def _check_order(rotation_order: str) -> str:
    order = str(rotation_order).upper()
    if sorted(order) != ["X", "Y", "Z"]:
        raise ValueError(f"rotation_order must be a permutation of 'XYZ', got {rotation_order!r}")
    return order


def bone_world_rotations(joints: np.ndarray, skeleton: Skeleton = T2M) -> tuple[np.ndarray, np.ndarray]:
    """The body's heading ``(T, 3, 3)`` and the world rotation of every bone ``(T, J, 3, 3)`` (index = end joint).

    HumanML3D's root quaternion ``Q_root`` turns the facing direction onto +Z, so the heading is its inverse
    ``B = Q_root^-1``. The bones are solved in the heading frame, with the joints turned to face +Z (where
    ``inverse_kinematics`` gives an identity root), walking the chains as forward kinematics does::

        W(bone -> c_k) = B * q'_c1 * ... * q'_ck        # q' = inverse_kinematics(Q_root * joints)

    so a whole-body turn changes the root channels only. ``bones[:, 0]`` is the identity (unused).
    """
    q_root = inverse_kinematics(joints, skeleton)[:, 0]  # (T, 4)
    centred = joints - joints[:, :1]
    facing_z = qrot(np.broadcast_to(q_root[:, None], centred.shape[:-1] + (4,)), centred)  # (T, J, 3)
    local = inverse_kinematics(facing_z, skeleton)  # (T, J, 4), local[:, 0] = identity
    heading = qinv(q_root)
    world = np.zeros_like(local)
    world[:, 0] = (1.0, 0.0, 0.0, 0.0)
    for chain in skeleton.chains:
        r = qmul(heading, local[:, 0])  # local[:, 0] is the identity up to rounding; keep the product exact
        for c in chain[1:]:
            r = qmul(r, local[:, c])
            world[:, c] = r
    return quat_to_matrix(heading), quat_to_matrix(world)


def matrices_to_euler(matrices: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles in degrees ``(..., 3)`` with ``R = R_order[0] @ R_order[1] @ R_order[2]``."""
    flat = matrices.reshape(-1, 3, 3)
    with warnings.catch_warnings():  # at gimbal lock scipy still returns angles that rebuild the matrix
        warnings.simplefilter("ignore", UserWarning)
        angles = Rotation.from_matrix(flat).as_euler(order.upper(), degrees=True)  # upper case = intrinsic
    return angles.reshape(matrices.shape[:-2] + (3,))


def motion_to_bvh(motion, fps: float = 20.0, unit: str = "m", rotation_order: str = "ZYX") -> Bvh:
    """A :class:`Bvh` of t2m joints ``(T, 22, 3)`` (metres, Y-up) or HumanML3D features ``(T, 263)``."""
    joints, sk = as_joints(motion, name="motion")
    if sk.name != "t2m":
        raise ValueError(f"BVH export supports the t2m skeleton (22 joints / 263 features), got {sk.name}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps}")
    bones = np.linalg.norm(joints[:, 1:] - joints[:, list(sk.parents[1:])], axis=-1)  # (T, J-1)
    if bones.min() < 1e-6:
        t, b = np.unravel_index(np.argmin(bones), bones.shape)
        raise ValueError(f"motion: joint {sk.joint_names[b + 1]} coincides with its parent in frame {t}")
    nodes = t2m_bvh_rig(sk, unit, rotation_order)
    root_rot, bone_rot = bone_world_rotations(joints, sk)  # (T, 3, 3), (T, J, 3, 3)

    world = [root_rot if n.frame_of < 0 else bone_rot[:, n.frame_of] for n in nodes]
    columns = [joints[:, 0] * UNITS[unit]]  # root position channels
    for k, node in enumerate(nodes):
        if node.joint.end_site:
            continue
        parent = node.joint.parent
        local = world[k] if parent < 0 else np.swapaxes(world[parent], -1, -2) @ world[k]  # W_parent^T W_k
        columns.append(matrices_to_euler(local, rotation_order))
    frames = np.concatenate(columns, axis=-1)  # (T, C)
    return Bvh(tuple(n.joint for n in nodes), frames, 1.0 / fps)


def save_bvh(motion, path: str | os.PathLike, fps: float = 20.0, unit: str = "m", rotation_order: str = "ZYX") -> Path:
    """Write a t2m motion (joints ``(T, 22, 3)`` or features ``(T, 263)``) as a BVH file, atomically."""
    path = Path(path)
    if path.suffix.lower() != ".bvh":
        raise ValueError(f"path must end in .bvh, got {str(path)!r}")
    bvh = motion_to_bvh(motion, fps, unit, rotation_order)
    joints, sk = as_joints(motion, name="motion")
    stretch, bone, lo, hi = bone_stretch(joints, sk)
    if stretch > STRETCH_WARNING:
        gap = rigid_deviation(bvh, joints, unit)
        warn(
            f"{path.name}: the motion's bones stretch ({bone} {lo:.2f}-{hi:.2f} m); the BVH keeps fixed bone "
            f"lengths, so its joints are up to {100 * gap:.0f} cm from the motion's (.npy/.html hold the motion "
            "as generated)"
        )
    return write_bvh(bvh, path)


def rigid_deviation(bvh: Bvh, joints: np.ndarray, unit: str = "m") -> float:
    """Largest distance (metres) between a joint of ``joints`` ``(T, 22, 3)`` and the same joint of ``bvh``'s
    forward kinematics: what the fixed bone lengths of the BVH change."""
    from .bvh import bvh_positions

    names = list(bvh.names)
    columns = [names.index(n) for n in T2M.joint_names]
    rigid = bvh_positions(bvh)[:, columns] / UNITS[unit]  # (T, 22, 3) metres
    return float(np.linalg.norm(rigid - joints, axis=-1).max())
