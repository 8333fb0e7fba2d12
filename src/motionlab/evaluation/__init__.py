"""The papers' evaluation tables, computed end to end from a dataset and the book's cached models.

Three tasks, one function each; every one returns an :class:`EvaluationTable` (rows × metrics, each cell a
:class:`~motionlab.metrics.Estimate`: mean, 95 % half-width from Student's t with n − 1 degrees of freedom,
n runs):

==================  =========================================================================================
task                what is measured
==================  =========================================================================================
``reconstruction``  DisCoRD Table 1: test clips → tokens → decoded; FID, MPJPE (mm), sJPE, Noise/Static sJPE
                    (:mod:`motionlab.flow.reconstruction`). The tokenizer's feed-forward decoder is one
                    deterministic run; the DisCoRD decoder repeats over sampling seeds.
``t2m``             the text-to-motion protocol (both papers' main tables): R-precision top 1–3, FID,
                    MM-Dist, Diversity (+ MultiModality) of the diffusion model, and the real motions as
                    "Ground Truth" (:func:`motionlab.diffusion.pipeline.evaluate_text_to_motion`).
``multi``           M2D2M's multi-motion table: per-action and transition metrics of TPS and the baselines
                    on multi-action instances (:func:`motionlab.multimotion.evaluate_methods`).
==================  =========================================================================================

Models come from the cache, trained on first use exactly as ``motionlab train`` does, so the numbers are
those of the chapters' models. Every random draw is seeded from ``config.seed``: the same seed gives the
same table. :func:`write_json` stores a table atomically (a temporary file, then ``os.replace``).
"""

from __future__ import annotations

from .common import (
    CLI_OPTIONS,
    FLOW_OPTIONS,
    FLOW_SAMPLING_OPTIONS,
    FLOW_TRAINING_OPTIONS,
    Option,
    available_memory,
    command_line,
    config_from_options,
    default_repeats,
    estimated_memory,
    log,
    repeat_seed,
)
from .multi import MultiMotionConfig, evaluate_multi
from .multi import claim_cells as multi_claim_cells
from .reconstruction import ReconstructionConfig, evaluate_reconstruction
from .reconstruction import claim_cells as reconstruction_claim_cells
from .reconstruction import clip_cells as reconstruction_clip_cells
from .t2m import TextToMotionConfig, evaluate_t2m
from .table import (
    METRIC_LABELS,
    MULTI_METRICS,
    RECONSTRUCTION_METRICS,
    SPLITS,
    T2M_METRICS,
    TASKS,
    EvaluationTable,
    check_json_path,
    metric_label,
    write_json,
)

EVALUATORS = {"reconstruction": evaluate_reconstruction, "t2m": evaluate_t2m, "multi": evaluate_multi}
CONFIGS = {"reconstruction": ReconstructionConfig, "t2m": TextToMotionConfig, "multi": MultiMotionConfig}

__all__ = [
    "multi_claim_cells",
    "reconstruction_claim_cells",
    "reconstruction_clip_cells",
    "CLI_OPTIONS",
    "CONFIGS",
    "EVALUATORS",
    "FLOW_OPTIONS",
    "FLOW_SAMPLING_OPTIONS",
    "FLOW_TRAINING_OPTIONS",
    "METRIC_LABELS",
    "MULTI_METRICS",
    "RECONSTRUCTION_METRICS",
    "SPLITS",
    "T2M_METRICS",
    "TASKS",
    "EvaluationTable",
    "MultiMotionConfig",
    "ReconstructionConfig",
    "TextToMotionConfig",
    "Option",
    "available_memory",
    "command_line",
    "config_from_options",
    "check_json_path",
    "metric_label",
    "default_repeats",
    "estimated_memory",
    "log",
    "evaluate_multi",
    "evaluate_reconstruction",
    "evaluate_t2m",
    "repeat_seed",
    "write_json",
]
