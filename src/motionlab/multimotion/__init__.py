"""Multi-motion generation (M2D2M): Two-Phase Sampling, baselines, the multi-action test set, transition metrics.

Read in this order: :mod:`.tps` (Algorithm 1 on a tiny layout of segments), :mod:`.stitch` (joining decoded
segments in feature space), :mod:`.baselines` (independent, SLERP, handshake), :mod:`.generate` (texts in,
motions out, for a trained ``TextToMotion``), :mod:`.testset` and :mod:`.evaluation`.
"""

from .baselines import DEFAULT_TRANSITION, handshake_sample, handshake_windows, independent_sample, shortened_lengths
from .evaluation import (
    METRICS,
    GroundTruthJerks,
    MultiMotionReference,
    build_reference,
    evaluate_ground_truth_single,
    evaluate_methods,
    evaluate_multimotion,
    format_table,
    ground_truth_concat_jerk,
    ground_truth_jerks,
    real_windows,
    segment_jerk,
    summarize,
    transition_feature_windows,
    transition_jerk,
    transition_profile,
)
from .generate import METHODS, MULTI_MOTION_ETA, MULTI_MOTION_GUIDANCE, MultiMotion, MultiMotionGenerator
from .stitch import blend_segments, blend_weights, concatenate_segments, split_segments, transition_rows
from .testset import MIN_ACTION_FRAMES, MultiActionInstance, PoolClip, build_multi_action_testset, single_action_pool
from .tps import (
    JOINT_TEXTS,
    MAX_ACTIONS,
    JointCondition,
    MultiMotionTokens,
    SegmentLayout,
    joint_condition,
    phase_grid,
    segment_layout,
    text_tensors,
    two_phase_sample,
)

__all__ = [
    "DEFAULT_TRANSITION", "JOINT_TEXTS", "JointCondition", "MAX_ACTIONS", "METHODS", "METRICS", "MIN_ACTION_FRAMES",
    "MULTI_MOTION_ETA",
    "MULTI_MOTION_GUIDANCE",
    "MultiActionInstance", "MultiMotion", "MultiMotionGenerator", "MultiMotionReference", "MultiMotionTokens",
    "PoolClip", "SegmentLayout", "blend_segments", "blend_weights", "build_multi_action_testset",
    "build_reference", "concatenate_segments", "evaluate_ground_truth_single", "evaluate_methods",
    "evaluate_multimotion", "format_table", "GroundTruthJerks", "ground_truth_concat_jerk", "ground_truth_jerks",
    "handshake_sample", "handshake_windows",
    "independent_sample", "joint_condition", "phase_grid", "real_windows", "segment_jerk", "segment_layout",
    "shortened_lengths", "single_action_pool", "split_segments", "summarize", "text_tensors",
    "transition_feature_windows", "transition_jerk", "transition_profile", "transition_rows",
    "two_phase_sample",
]  # fmt: skip
