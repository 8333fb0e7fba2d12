"""The library's trainers as the benchmarks build them: one builder for every trained model of the book.

``book_trainer(name, ...)`` returns the Trainer the library fits ``name`` with (random initial weights, no progress
bar) and a function that builds a second instance of its model with the same config, for timing the bare module.
The text-to-motion networks' inputs (the train clips' VQ tokens, captions, transitions) cost seconds to build, so
:func:`diffusion_parts` builds them once for every trainer that needs them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from motionlab.diffusion.training import (
    TextToMotionNetworks,
    build_vocabulary,
    diffusion_training_config,
    make_transitions,
    text_to_motion_trainer,
    tokenize_clips,
)
from motionlab.flow import DisCoRDDecoder, discord_config
from motionlab.flow.training import discord_trainer
from motionlab.tokenizers import build_tokenizer, rvq_config, vq_config
from motionlab.tokenizers.training import tokenizer_trainer

TRAINED = ("vq", "rvq", "discord", "t2m", "evaluator")


@dataclass(frozen=True)
class DiffusionParts:
    """What the text-to-motion trainer reads besides the networks, and the random VQ tokenizer it came from."""

    tokenizer: torch.nn.Module
    config: object
    captions: list
    sequences: list
    transitions: object
    vocabulary: object


def diffusion_parts(dataset, profile: str) -> DiffusionParts:
    """The text-to-motion networks' inputs at ``profile``'s sizes: VQ tokens of the train clips and their captions."""
    tokenizer = build_tokenizer(vq_config(profile)).eval()
    config = diffusion_training_config(profile, num_codes=tokenizer.codebook_size)
    captions = [[c.text for c in clip.captions] for clip in dataset.split("train")]
    sequences = tokenize_clips(tokenizer, dataset.normalized("train"))
    transitions = make_transitions(config.transformer, tokenizer.codebook().cpu())
    return DiffusionParts(tokenizer, config, captions, sequences, transitions, build_vocabulary(captions, config))


def book_trainer(
    name: str,
    profile: str,
    dataset,
    precision: str,
    device: str | torch.device = "cpu",
    parts: DiffusionParts | None = None,
) -> tuple[object, Callable[[], torch.nn.Module]]:
    """``(trainer, twin)`` for model ``name`` (one of :data:`TRAINED`) at ``profile``'s sizes on ``device``.

    ``parts`` are the text-to-motion inputs (:func:`diffusion_parts`), built here when not given.
    """
    device = str(device)
    clips = dataset.normalized("train")
    if name in ("vq", "rvq"):
        config = (vq_config if name == "vq" else rvq_config)(profile)
        trainer = tokenizer_trainer(build_tokenizer(config), clips, device=device, progress=False, precision=precision)
        return trainer, lambda: build_tokenizer(config)
    if name == "discord":
        tokenizer = build_tokenizer(rvq_config(profile)).eval()
        config = discord_config(profile, tokenizer=tokenizer)
        trainer = discord_trainer(
            DisCoRDDecoder(config), tokenizer, clips, device=device, progress=False, precision=precision
        )
        return trainer, lambda: DisCoRDDecoder(config)
    if name == "t2m":
        p = parts if parts is not None else diffusion_parts(dataset, profile)
        trainer = text_to_motion_trainer(
            TextToMotionNetworks(p.config, p.vocabulary),
            p.sequences,
            p.captions,
            p.transitions,
            p.config,
            device=device,
            progress=False,
            precision=precision,
        )
        return trainer, lambda: TextToMotionNetworks(p.config, p.vocabulary)
    if name == "evaluator":
        from motionlab.metrics.evaluator_training import (
            EvaluatorNetworks,
            evaluator_config,
            evaluator_trainer,
        )
        from motionlab.metrics.evaluator_training import build_vocabulary as evaluator_vocabulary

        config = evaluator_config(profile)
        vocabulary = evaluator_vocabulary(dataset, config)

        def twin() -> torch.nn.Module:
            return EvaluatorNetworks(config.evaluator, len(vocabulary), torch.Generator().manual_seed(config.seed))

        return evaluator_trainer(twin(), dataset, vocabulary, config, precision=precision, device=device), twin
    raise ValueError(f"name must be one of {TRAINED}, got {name!r}")
