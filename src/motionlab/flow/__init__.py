"""DisCoRD's rectified-flow decoder: the flow objective and samplers, the condition projection, the U-Net.

Read in this order: ``rectified_flow`` (no networks), ``condition``, ``unet1d``, ``discord``, ``config``.
"""

from motionlab.flow.condition import CONDITION_PROJECTIONS, make_condition_projection
from motionlab.flow.config import DisCoRDConfig, discord_config
from motionlab.flow.discord import DisCoRDDecoder, discord_loss_fn
from motionlab.flow.rectified_flow import (
    SOLVERS,
    ODESolver,
    discord_default_grid,
    discord_default_solver,
    flow_matching_loss,
    interpolate,
    n_evaluations,
    sample,
    sample_noise,
    time_grid,
)
from motionlab.flow.training import discord_training_log, train_discord, train_or_load_discord
from motionlab.flow.unet1d import UNet1D, UNetConfig

__all__ = [
    "CONDITION_PROJECTIONS",
    "SOLVERS",
    "DisCoRDConfig",
    "DisCoRDDecoder",
    "ODESolver",
    "UNet1D",
    "UNetConfig",
    "discord_config",
    "discord_default_grid",
    "discord_default_solver",
    "discord_loss_fn",
    "flow_matching_loss",
    "interpolate",
    "make_condition_projection",
    "n_evaluations",
    "sample",
    "sample_noise",
    "time_grid",
    "discord_training_log",
    "train_discord",
    "train_or_load_discord",
]
