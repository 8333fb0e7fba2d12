"""Motion data: the HumanML3D on-disk layout (also KIT-ML's and the embedded dataset's) and its loaders."""

from .humanml3d import (
    KINDS,
    SPLITS,
    Caption,
    DatasetKind,
    MotionClip,
    MotionDataset,
    check_dataset,
    crop_to_unit,
    floor_to_unit,
    format_caption_line,
    load_dataset,
    parse_caption_line,
    read_captions,
    read_split_ids,
)

__all__ = [
    "KINDS",
    "SPLITS",
    "Caption",
    "DatasetKind",
    "MotionClip",
    "MotionDataset",
    "check_dataset",
    "crop_to_unit",
    "floor_to_unit",
    "format_caption_line",
    "load_dataset",
    "parse_caption_line",
    "read_captions",
    "read_split_ids",
]
