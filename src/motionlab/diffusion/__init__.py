"""Discrete diffusion over motion tokens (VQ-Diffusion mask-and-replace, M2D2M dynamic transitions).

Read in this order: :mod:`.schedule` (α, β, γ), :mod:`.transitions` (the matrices Q_t, Q̄_t),
:mod:`.posterior` (q(x_t|x_0), q(x_{t-1}|x_t,x_0), p_θ(x_{t-1}|x_t)), :mod:`.loss`, :mod:`.transformer`
(the network), :mod:`.sampling`. Schedules and posteriors know nothing about the network. :mod:`.diagnostics`
measures a trained model (entropy of p_θ(x_0|x_t) under guidance, token statistics, forward-process distances).
"""

from .diagnostics import (
    EntropyCurve,
    TokenRecorder,
    adjacent_repeat_rate,
    code_entropy,
    code_histogram,
    dynamic_uniform_tv,
    forward_tv,
    histogram_tv,
    token_rows,
    x0_entropy,
)
from .loss import AUX_WEIGHT, DiffusionLoss, diffusion_loss, sample_timesteps, vb_terms
from .pipeline import (
    TextToMotion,
    evaluate_fixed_motions,
    evaluate_ground_truth,
    evaluate_text_to_motion,
    generation_lengths,
    multimodality_score,
    text_to_motion_for_dataset,
)
from .posterior import (
    LOG_FLOOR,
    gumbel_sample,
    log_p_posterior,
    log_q_posterior,
    log_q_xt_given_x0,
    q_sample,
    safe_log,
)
from .sampling import classifier_free_guidance, denoise_step, sample, timestep_grid, truncate
from .schedule import (
    DEFAULT_SCHEDULE,
    DEFAULT_T,
    SCHEDULES,
    Schedule,
    get_schedule,
    linear_schedule,
    vqdiffusion_code_schedule,
    vqdiffusion_paper_schedule,
)
from .training import (
    PAPER_ETA,
    DiffusionTrainingConfig,
    TextToMotionNetworks,
    TokenBatches,
    WordEncoderConfig,
    diffusion_training_config,
    make_transitions,
    tokenize_clips,
    train_text_to_motion,
)
from .transformer import (
    DenoisingTransformer,
    TransformerConfig,
    relative_position_bucket,
    segment_cross_mask,
    transformer_config,
)
from .transitions import (
    DISTANCES,
    Transitions,
    build_transitions,
    codebook_distance,
    dynamic_matrix,
    uniform_matrix,
)

__all__ = [
    "AUX_WEIGHT",
    "DEFAULT_SCHEDULE",
    "DEFAULT_T",
    "DISTANCES",
    "LOG_FLOOR",
    "SCHEDULES",
    "DenoisingTransformer",
    "DiffusionLoss",
    "Schedule",
    "TransformerConfig",
    "Transitions",
    "build_transitions",
    "classifier_free_guidance",
    "codebook_distance",
    "denoise_step",
    "diffusion_loss",
    "dynamic_matrix",
    "get_schedule",
    "gumbel_sample",
    "linear_schedule",
    "log_p_posterior",
    "log_q_posterior",
    "log_q_xt_given_x0",
    "q_sample",
    "relative_position_bucket",
    "safe_log",
    "sample",
    "sample_timesteps",
    "segment_cross_mask",
    "timestep_grid",
    "transformer_config",
    "truncate",
    "uniform_matrix",
    "vb_terms",
    "vqdiffusion_code_schedule",
    "vqdiffusion_paper_schedule",
    # the text-to-motion pipeline (training.py, pipeline.py)
    "PAPER_ETA",
    "DiffusionTrainingConfig",
    "TextToMotion",
    "TextToMotionNetworks",
    "TokenBatches",
    "WordEncoderConfig",
    "diffusion_training_config",
    "evaluate_fixed_motions",
    "evaluate_ground_truth",
    "evaluate_text_to_motion",
    "generation_lengths",
    "make_transitions",
    "multimodality_score",
    "text_to_motion_for_dataset",
    "tokenize_clips",
    "train_text_to_motion",
    # measurements of a trained model (diagnostics.py)
    "EntropyCurve",
    "TokenRecorder",
    "adjacent_repeat_rate",
    "code_entropy",
    "code_histogram",
    "dynamic_uniform_tv",
    "forward_tv",
    "histogram_tv",
    "token_rows",
    "x0_entropy",
]
