"""The training utilities every model of the book shares: one loop, checkpoints, caching, data windows."""

from .cache import (
    DamagedArtefactError,
    artefact_dir,
    config_hash,
    is_trained,
    load_result,
    load_trained,
    train_or_load,
    training_sittings,
)
from .checkpoint import latest_checkpoint, list_checkpoints, load_checkpoint, load_weights, save_checkpoint
from .data import WindowDataset, collate_clips, crop_length
from .device import get_device, model_device, seed_everything, seeded, to_device
from .ema import EMA
from .schedules import SCHEDULES, lr_multiplier
from .trainer import TrainConfig, Trainer, final_loss

__all__ = [
    "EMA",
    "SCHEDULES",
    "DamagedArtefactError",
    "TrainConfig",
    "Trainer",
    "WindowDataset",
    "artefact_dir",
    "collate_clips",
    "config_hash",
    "crop_length",
    "final_loss",
    "get_device",
    "model_device",
    "is_trained",
    "latest_checkpoint",
    "list_checkpoints",
    "load_checkpoint",
    "load_result",
    "load_trained",
    "load_weights",
    "lr_multiplier",
    "save_checkpoint",
    "seed_everything",
    "seeded",
    "to_device",
    "train_or_load",
    "training_sittings",
]
