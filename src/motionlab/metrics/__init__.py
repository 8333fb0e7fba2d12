"""Metrics: the joints of a clip set, recovered once (ClipJoints); jerk, sJPE and LDLJ; MPJPE; FID, Diversity,
MultiModality; R-precision and MM-Dist; the text-motion evaluator that embeds texts and motions; and the
mean +- 95% CI reporting protocol."""

from .distribution import diversity, fid, frechet_distance, gaussian_stats, multimodality
from .evaluator import (
    OFFICIAL_PARTS,
    ContrastiveLosses,
    EvaluatorConfig,
    MotionEncoderBiGRUCo,
    MovementConvEncoder,
    TextEncoderBiGRUCo,
    TextMotionEvaluator,
    contrastive_loss,
    init_weights,
)
from .jerk import (
    boundaries_from_lengths,
    clip_log_jerk,
    dimensionless_jerk,
    finite_difference_jerk,
    ldlj_from_log_jerk,
    log_dimensionless_jerk,
    log_jerk,
    log_jerk_batch,
    transition_log_jerk,
    transition_windows,
)
from .joints import ClipJoints
from .mpjpe import mpjpe
from .official import OfficialEvaluator, load_official_evaluator, official_paths
from .protocol import Estimate, mean_ci, summarize_runs
from .retrieval import RetrievalScores, euclidean_distance_matrix, mm_dist, r_precision, retrieval_metrics
from .sjpe import (
    SJPE_JOINTS,
    SJPEResult,
    noise_sjpe_by_phase,
    sjpe,
    sjpe_dataset,
    sjpe_from_features,
    sjpe_jerk_magnitudes,
    sjpe_setting,
    sjpe_variants,
)
from .words import (
    POS_CATEGORIES,
    VIP_WORDS,
    CaptionVocabulary,
    EncodedCaptions,
    LearnedWordEmbedding,
    WordVectorizer,
    pad_caption,
    pos_category,
)

__all__ = [
    "OFFICIAL_PARTS", "POS_CATEGORIES", "SJPE_JOINTS", "VIP_WORDS", "CaptionVocabulary", "ClipJoints",
    "ContrastiveLosses", "clip_log_jerk",
    "EncodedCaptions", "Estimate", "EvaluatorConfig", "LearnedWordEmbedding", "MotionEncoderBiGRUCo",
    "MovementConvEncoder", "OfficialEvaluator", "RetrievalScores", "SJPEResult", "TextEncoderBiGRUCo",
    "TextMotionEvaluator", "WordVectorizer", "boundaries_from_lengths", "contrastive_loss",
    "dimensionless_jerk", "diversity", "euclidean_distance_matrix", "fid", "finite_difference_jerk",
    "frechet_distance", "gaussian_stats", "init_weights", "ldlj_from_log_jerk", "load_official_evaluator",
    "log_dimensionless_jerk", "log_jerk", "log_jerk_batch", "mean_ci", "mm_dist", "mpjpe", "multimodality",
    "noise_sjpe_by_phase", "official_paths", "pad_caption", "pos_category", "r_precision", "retrieval_metrics", "sjpe",
    "sjpe_dataset", "sjpe_from_features", "sjpe_jerk_magnitudes", "sjpe_setting", "sjpe_variants", "summarize_runs",
    "transition_log_jerk", "transition_windows",
]  # fmt: skip
