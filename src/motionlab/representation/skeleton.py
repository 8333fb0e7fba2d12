"""The two skeletons of text-to-motion data: HumanML3D's ``t2m`` (22 SMPL joints) and KIT-ML's ``kit`` (21).

A skeleton here is pure data: joint names, parents, the kinematic chains HumanML3D walks for inverse and
forward kinematics, unit "raw offset" directions, and the bone lengths of the target skeleton every clip
is retargeted to. Offsets (``raw_offsets * bone_lengths``) are what forward kinematics needs.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


@dataclass(frozen=True)
class Skeleton:
    """A kinematic tree plus the dataset conventions that go with it."""

    name: str
    joint_names: tuple[str, ...]
    chains: tuple[tuple[int, ...], ...]
    raw_offsets: np.ndarray = field(repr=False)  # (J, 3) unit bone directions in the rest pose
    bone_lengths: np.ndarray = field(repr=False)  # (J,) length of the bone ending at each joint
    fps: float
    unit: str  # "m" or "mm": the unit joint positions are stored in
    face_joints: tuple[int, int, int, int]  # right hip, left hip, right shoulder, left shoulder
    feet_left: tuple[int, int]
    feet_right: tuple[int, int]
    contact_threshold: float  # squared per-frame displacement below which a foot is in contact
    leg_joints: tuple[int, int]  # the two bones whose lengths set the retargeting scale

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def parents(self) -> tuple[int, ...]:
        parents = [-1] * self.n_joints
        for chain in self.chains:
            for parent, child in zip(chain[:-1], chain[1:]):
                parents[child] = parent
        return tuple(parents)

    @property
    def offsets(self) -> np.ndarray:
        """Bone vectors ``(J, 3)`` of the target skeleton in its rest pose (zero for the root)."""
        return self.raw_offsets * self.bone_lengths[:, None]

    @property
    def feature_dim(self) -> int:
        """Size of the HumanML3D feature vector: 4 root + 3(J-1) ric + 6(J-1) rot + 3J vel + 4 contacts."""
        j = self.n_joints
        return 4 + 3 * (j - 1) + 6 * (j - 1) + 3 * j + 4

    @property
    def meters_per_unit(self) -> float:
        return 1e-3 if self.unit == "mm" else 1.0

    def index(self, name: str) -> int:
        """Joint index by name."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise ValueError(f"{self.name} has no joint {name!r}; joints: {', '.join(self.joint_names)}") from None

    def with_bone_lengths(self, lengths) -> Skeleton:
        """A copy with other bone lengths (e.g. measured from a dataset's own target clip)."""
        lengths = np.asarray(lengths, dtype=np.float64)
        if lengths.shape != (self.n_joints,):
            raise ValueError(f"bone lengths must have shape ({self.n_joints},), got {lengths.shape}")
        return replace(self, bone_lengths=lengths)


_T2M_NAMES = (
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
)

_T2M_RAW_OFFSETS = np.array(
    [
        [0, 0, 0],
        [1, 0, 0],
        [-1, 0, 0],
        [0, 1, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, 1, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, 1, 0],
        [0, 0, 1],
        [0, 0, 1],
        [0, 1, 0],
        [1, 0, 0],
        [-1, 0, 0],
        [0, 0, 1],
        [0, -1, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, -1, 0],
    ],
    dtype=np.float64,
)

# Bone lengths (m) of HumanML3D's target skeleton (clip 000021), as every retargeted clip carries them.
_T2M_BONE_LENGTHS = np.array(
    [
        0.0,
        0.1031,
        0.1099,
        0.1316,
        0.3936,
        0.3902,
        0.1432,
        0.4324,
        0.4256,
        0.0574,
        0.1434,
        0.1494,
        0.2194,
        0.1375,
        0.1434,
        0.1030,
        0.1316,
        0.1230,
        0.2568,
        0.2631,
        0.2660,
        0.2699,
    ],
)

T2M = Skeleton(
    name="t2m",
    joint_names=_T2M_NAMES,
    chains=((0, 2, 5, 8, 11), (0, 1, 4, 7, 10), (0, 3, 6, 9, 12, 15), (9, 14, 17, 19, 21), (9, 13, 16, 18, 20)),
    raw_offsets=_T2M_RAW_OFFSETS,
    bone_lengths=_T2M_BONE_LENGTHS,
    fps=20.0,
    unit="m",
    face_joints=(2, 1, 17, 16),
    feet_left=(7, 10),
    feet_right=(8, 11),
    contact_threshold=0.002,
    leg_joints=(5, 8),
)

_KIT_NAMES = (
    "root",
    "spine",
    "chest",
    "neck",
    "head",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_hip",
    "right_knee",
    "right_ankle",
    "right_heel",
    "right_toe",
    "left_hip",
    "left_knee",
    "left_ankle",
    "left_heel",
    "left_toe",
)

_KIT_RAW_OFFSETS = np.array(
    [
        [0, 0, 0],
        [0, 1, 0],
        [0, 1, 0],
        [0, 1, 0],
        [0, 1, 0],
        [1, 0, 0],
        [0, -1, 0],
        [0, -1, 0],
        [-1, 0, 0],
        [0, -1, 0],
        [0, -1, 0],
        [1, 0, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, 0, 1],
        [0, 0, 1],
        [-1, 0, 0],
        [0, -1, 0],
        [0, -1, 0],
        [0, 0, 1],
        [0, 0, 1],
    ],
    dtype=np.float64,
)

# Nominal adult proportions in mm. KIT-ML retargets to its clip 03950, which is not shipped here; a user
# with the dataset can measure it and call ``KIT.with_bone_lengths``.
_KIT_BONE_LENGTHS = np.array(
    [0, 100, 200, 180, 150, 180, 280, 260, 180, 280, 260, 90, 420, 400, 60, 120, 90, 420, 400, 60, 120],
    dtype=np.float64,
)

KIT = Skeleton(
    name="kit",
    joint_names=_KIT_NAMES,
    chains=((0, 11, 12, 13, 14, 15), (0, 16, 17, 18, 19, 20), (0, 1, 2, 3, 4), (3, 5, 6, 7), (3, 8, 9, 10)),
    raw_offsets=_KIT_RAW_OFFSETS,
    bone_lengths=_KIT_BONE_LENGTHS,
    fps=12.5,
    unit="mm",
    face_joints=(11, 16, 5, 8),
    feet_left=(19, 20),
    feet_right=(14, 15),
    contact_threshold=0.05,
    leg_joints=(17, 18),
)

SKELETONS = {"t2m": T2M, "humanml3d": T2M, "kit": KIT, "kit-ml": KIT}


def get_skeleton(skeleton: str | Skeleton) -> Skeleton:
    """Resolve ``"t2m"``/``"humanml3d"``/``"kit"``/``"kit-ml"`` (or a ``Skeleton``) to a ``Skeleton``."""
    if isinstance(skeleton, Skeleton):
        return skeleton
    key = str(skeleton).lower()
    if key not in SKELETONS:
        raise ValueError(f"unknown skeleton {skeleton!r}; expected one of {sorted(SKELETONS)}")
    return SKELETONS[key]


def skeleton_for_joint_count(n_joints: int) -> Skeleton:
    """The skeleton with ``n_joints`` joints (22 -> t2m, 21 -> kit)."""
    for sk in (T2M, KIT):
        if sk.n_joints == n_joints:
            return sk
    raise ValueError(f"no skeleton has {n_joints} joints (t2m has 22, kit has 21)")


def skeleton_for_feature_dim(dim: int) -> Skeleton:
    """The skeleton whose HumanML3D feature vector has ``dim`` entries (263 -> t2m, 251 -> kit)."""
    for sk in (T2M, KIT):
        if sk.feature_dim == dim:
            return sk
    raise ValueError(f"feature dimension {dim} matches no skeleton (t2m: 263, kit: 251)")
