"""Motion representation: skeletons, rotations, kinematics, HumanML3D features and normalisation."""

from .features import (
    FEATURE_GROUPS,
    ProcessedMotion,
    feature_slices,
    infer_skeleton,
    joints_to_features,
    process_joints,
    recover_from_ric,
    recover_from_rot,
    recover_root,
    retarget,
)
from .kinematics import forward_kinematics, forward_kinematics_cont6d, inverse_kinematics, measured_offsets
from .normalization import Normalizer, group_std
from .quaternion import (
    axis_angle_to_quat,
    cont6d_to_matrix,
    cont6d_to_quat,
    euler_to_quat,
    matrix_to_cont6d,
    matrix_to_quat,
    qbetween,
    qinv,
    qmul,
    qnormalize,
    qrot,
    quat_to_cont6d,
    quat_to_matrix,
    slerp,
)
from .skeleton import KIT, SKELETONS, T2M, Skeleton, get_skeleton, skeleton_for_feature_dim, skeleton_for_joint_count

__all__ = [
    "FEATURE_GROUPS", "KIT", "SKELETONS", "T2M", "Normalizer", "ProcessedMotion", "Skeleton",
    "axis_angle_to_quat", "cont6d_to_matrix", "cont6d_to_quat", "euler_to_quat", "feature_slices",
    "forward_kinematics", "forward_kinematics_cont6d", "get_skeleton", "group_std", "infer_skeleton",
    "inverse_kinematics", "joints_to_features", "matrix_to_cont6d", "matrix_to_quat", "measured_offsets",
    "process_joints", "qbetween", "qinv", "qmul", "qnormalize", "qrot", "quat_to_cont6d", "quat_to_matrix",
    "recover_from_ric", "recover_from_rot", "recover_root", "retarget", "skeleton_for_feature_dim",
    "skeleton_for_joint_count", "slerp",
]  # fmt: skip
